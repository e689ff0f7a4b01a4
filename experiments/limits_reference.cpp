#include "limits_reference.hpp"

#include <fstream>
#include <iostream>
#include <sstream>
#include <vector>

#include "limits.hpp"
#include "quadtune/common/error.hpp"
#include "quadtune/common/fields.hpp"
#include "quadtune/common/text_file.hpp"
#include "quadtune/engine/adaptation/online_adaptation.hpp"
#include "quadtune/engine/experiment/experiment.hpp"
#include "quadtune/engine/tuning/study.hpp"
#include "quadtune/engine/tuning/sweep.hpp"
#include "quadtune/layout/layout.hpp"
#include "quadtune/optimizers/bayes_opt.hpp"
#include "quadtune/optimizers/pso.hpp"
#include "quadtune/optimizers/racing.hpp"

namespace quadtune::cli {
namespace {

/// One limit: where it applies, its value, why it is there.
struct Limit {
  std::string where, value, why;
};

std::string Table(const std::vector<Limit>& rows,
                  const std::string& header = "| where | limit | why |") {
  std::string out = header + "\n|---|---|---|\n";
  for (const Limit& r : rows) out += "| " + r.where + " | " + r.value + " | " + r.why + " |\n";
  return out;
}

std::string N(double v) { return FormatNumber(v); }

std::vector<Limit> TextLimits() {
  const YamlBounds layout = layout::SavedLayoutBounds();
  return {
      {"bytes of a YAML file or `--set` value", N(kMaxYamlBytes), "memory of reading"},
      {"aliases (`*name`)", "none", "no quadtune file uses anchors; none is ever expanded"},
      {"nesting of mappings and lists", N(kMaxYamlDepth), "quadtune files nest a few levels"},
      {"keys of one mapping", N(kMaxYamlMapKeys), "the largest mapping has a few dozen keys"},
      {"entries of one list", N(kMaxYamlListEntries), "the largest list: a saved layout's obstacles"},
      {"values of one text", N(kMaxYamlNodes), "memory of yaml-cpp's nodes"},
      {"values of a saved layout", N(static_cast<double>(layout.max_nodes)), layout.nodes_why},
      {"obstacles of a layout (generated or saved)", N(layout::kMaxObstaclesPerLayout),
       "memory and the time of building a world"},
  };
}

std::vector<Limit> CommandLimits() {
  const std::string queued = kQueuedWhy;
  return {
      {"`--threads` (run, study, sweep, adapt), `threads`", N(engine::kMaxThreads), kThreadsWhy},
      {"worker threads under `ulimit -v` L MiB", "(L − " + N(kProgramReserveMib) + ") / " +
                                                     N(kThreadReserveMib),
       "a thread the system cannot create would abort the process"},
      {"`sweep --points`, `--maps`, `--queries`",
       N(kMaxSweepPoints) + ", " + N(kMaxSweepMaps) + ", " + N(kMaxSweepQueries), "design size"},
      {"`sweep`: N·(d+2)·K flights per layout", N(engine::kMaxSweepFlights), queued},
      {"`sweep`: N·(d+2)·Q re-solves per layout", N(engine::kMaxSweepResolves), queued},
      {"`bench --max-threads`", N(kMaxBenchThreads), kBenchThreadsWhy},
      {"`bench --flights`", N(kMaxBenchFlights), queued},
      {"`bench --resolves`", N(kMaxBenchResolves), queued},
      {"`bench --soak`", N(kMaxSoakFlights), kSoakWhy},
      {"`budget.flights` × methods × `repeats`", N(engine::kMaxTotalFlights),
       "a run that could never finish is a mistake"},
  };
}

/// Every integer key with a finite ceiling in `rows`, as `prefix` + key.
void AddCountKeys(const std::vector<FieldDoc>& rows, const std::string& prefix,
                  std::vector<Limit>& out) {
  for (const FieldDoc& r : rows) {
    if (r.type != "integer" || r.key == "seed" || r.allowed.find("inf") != std::string::npos) {
      continue;  // a seed is a name, not a size
    }
    out.push_back({"`" + prefix + r.key + "`", r.allowed, r.meaning});
  }
}

std::vector<Limit> KeyLimits() {
  std::vector<Limit> out;
  AddCountKeys(engine::ExperimentFields().Docs(), "", out);
  AddCountKeys(engine::BudgetFields().Docs(), "budget.", out);
  AddCountKeys(engine::MapsFields().Docs(), "maps.", out);
  AddCountKeys(engine::ValidationFields().Docs(), "validation.", out);
  AddCountKeys(engine::RecommendFields().Docs(), "recommend.", out);
  AddCountKeys(optimizers::RaceFields().Docs(), "race.", out);
  AddCountKeys(engine::StudyFields().Docs(), "study: ", out);
  AddCountKeys(engine::StudyValidationFields().Docs(), "study: validation.", out);
  AddCountKeys(engine::AdaptExperimentFields().Docs(), "adapt: ", out);
  AddCountKeys(engine::AdaptationFields().Docs(), "adapt: adaptation.", out);
  AddCountKeys(optimizers::PsoFields().Docs(), "pso.", out);
  AddCountKeys(optimizers::BayesOptFields().Docs(), "bo.", out);
  return out;
}

const char* const kIntro =
    R"(## Limits

Every limit is checked before any work; a value past it is refused with exit 2 and one line
naming the file (or option), the key, the value, the limit and why. This section is generated
from the constants the checks use and the field lists (`quadtune limits-reference --out
docs/hardening.md` rewrites it; the test `LimitsReference.HardeningPageIsCurrent` fails when
they differ). `bounded_inputs_tests` runs the hostile cases under a 2 s deadline (8 s for the
8–18 MB saved layouts, refused in about 1 s on an idle machine), a 200 MiB peak
resident set and a 4 GiB address space, and SIGTERM in long loops under a 1 s deadline to
exit 130: `ctest --test-dir build -R 'Bounded|PromptCancellation|FreeText'`.
)";

}  // namespace

std::string LimitsReference() {
  std::string out = std::string(kLimitsBegin) + "\n" + kIntro;
  out += "\n### Text read as YAML (common/text_file.hpp, physics/layout)\n\n" + Table(TextLimits());
  out += "\n### The command line and run sizes (experiments/limits.hpp, engine)\n\n" +
         Table(CommandLimits());
  out += "\n### Count keys of the files (from the field lists; see docs/config.md)\n\n" +
         Table(KeyLimits(), "| key | allowed | meaning |");
  return out + kLimitsEnd + "\n";
}

std::string WithLimitsReference(const std::string& page, const std::string& file) {
  const auto begin = page.find(kLimitsBegin);
  const auto end = page.find(kLimitsEnd);
  if (begin == std::string::npos || end == std::string::npos || end < begin) {
    throw ConfigError(file, "--out", "has no limits section (the markers '" +
                                         std::string(kLimitsBegin) + "' and '" + kLimitsEnd +
                                         "'); add them where the section goes");
  }
  std::string after = page.substr(end + std::string(kLimitsEnd).size());
  if (!after.empty() && after[0] == '\n') after.erase(0, 1);
  return page.substr(0, begin) + LimitsReference() + after;
}

namespace {
/// Rewrites the limits section of the page `path` in place.
void RewriteLimitsSection(const std::string& path) {
  const std::string page = WithLimitsReference(ReadFileText(path), path);
  std::ofstream file(path, std::ios::binary);
  file << page;
  file.close();
  if (!file) throw ConfigError(path, "--out", "cannot write the file");
}
}  // namespace

void RegisterLimitsReference(CLI::App& app, int& exit_code) {
  static std::string out_path;
  app.add_subcommand("limits-reference",
                     "print every limit quadtune checks before work (value and reason) as "
                     "Markdown; the limits section of docs/hardening.md is this output")
      ->callback([&exit_code] {
        if (out_path.empty()) std::cout << LimitsReference();
        if (!out_path.empty()) RewriteLimitsSection(out_path);
        exit_code = 0;
      })
      ->add_option("--out", out_path, "rewrite the limits section of this file instead");
}

}  // namespace quadtune::cli
