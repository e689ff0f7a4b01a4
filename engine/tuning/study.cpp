#include "quadtune/engine/tuning/study.hpp"

#include <yaml-cpp/yaml.h>

#include <cctype>
#include <chrono>
#include <filesystem>
#include <limits>
#include <map>
#include <sstream>
#include <string_view>

#include "../experiment/field_util.hpp"
#include "quadtune/common/error.hpp"
#include "quadtune/common/random.hpp"
#include "quadtune/common/text_file.hpp"
#include "quadtune/common/yaml.hpp"
#include "quadtune/engine/tuning/validation.hpp"

namespace quadtune::engine {
namespace {

namespace fs = std::filesystem;

std::string Slug(const std::string& label) {
  std::string out;
  for (char ch : label) {
    const bool ok = std::isalnum(static_cast<unsigned char>(ch)) || ch == '-' || ch == '_' || ch == '.';
    out += ok ? ch : '_';
  }
  return out.empty() ? std::string("point") : out;
}

std::string StagePath(const std::string& out, const std::string& label, const std::string& stage) {
  return (fs::path(out) / Slug(label) / stage).string();
}

/// Refuses a study label that its destinations would read as something else: a NUL or control
/// character (a folder name, stored text), `$` or `\` (matplotlib mathtext in the figures), `<`,
/// `>`, `|` or a backtick (HTML and Markdown tables in study.md), or a leading `=`, `+`, `@` or a
/// `-` that does not start a number (a formula in a spreadsheet opening study.csv).
void CheckLabel(const YamlMap& sweep, std::size_t i, const std::string& label) {
  const auto fail = [&](const std::string& what) {
    sweep.Fail("labels." + std::to_string(i),
               "'" + label + "' " + what +
                   "; a label is plain text: it names a folder and appears in study.md, "
                   "study.csv and the figures (give sweep.labels)");
  };
  for (const char ch : label) {
    if (static_cast<unsigned char>(ch) < 0x20 || ch == 0x7f) fail("holds a control character");
    if (std::string_view("$\\<>|`").find(ch) != std::string_view::npos) {
      fail(std::string("holds '") + ch + "'");
    }
  }
  const bool number = label.size() > 1 && label[0] == '-' &&
                      (std::isdigit(static_cast<unsigned char>(label[1])) || label[1] == '.');
  if (!label.empty() && std::string_view("=+@-").find(label[0]) != std::string_view::npos &&
      !number) {
    fail(std::string("starts with '") + label[0] + "'");
  }
}

/// A parameter set flown in validation, and where it came from.
struct Candidate {
  std::string stage, method;
  int repeat = 0;
  ParamValues params;
};

}  // namespace

const Fields<Study>& StudySweepFields() {
  static const Fields<Study> fields =
      Fields<Study>()
          .Text("key", &Study::sweep_key, {}, "a dotted experiment key; one study point per value")
          .Required()
          .Custom(
              {"values", "list", "required", "YAML scalars", "the values `key` takes"},
              [](const YamlMap& sweep, Study& s) {
                const YAML::Node values = sweep.node()["values"];
                if (!values || !values.IsSequence() || values.size() == 0) {
                  sweep.Fail("values",
                             "must be a non-empty list of values for '" + s.sweep_key + "'");
                }
                s.sweep_values.clear();
                for (const auto& v : values) s.sweep_values.push_back(YamlEmit(v));
              },
              [](YAML::Emitter& out, const Study& s) {
                out << YAML::Key << "values" << YAML::Value << YAML::Flow << YAML::BeginSeq;
                for (const auto& v : s.sweep_values) out << YAML::Load(v);
                out << YAML::EndSeq;
              })
          .Custom(
              {"labels", "list of strings", "the values", "one per value",
               "names of the points (output folders)"},
              [](const YamlMap& sweep, Study& s) {
                const YAML::Node values = sweep.node()["values"];
                const YAML::Node labels = sweep.node()["labels"];
                s.labels.clear();
                if (labels) {
                  if (!labels.IsSequence() || labels.size() != values.size()) {
                    sweep.Fail("labels", "must list one label per value (" +
                                             std::to_string(values.size()) + ")");
                  }
                  for (const auto& l : labels) {
                    if (!l.IsScalar()) {
                      sweep.Fail("labels", "must be a list of names (plain text), one per value");
                    }
                    s.labels.push_back(l.as<std::string>());
                  }
                } else {
                  for (const auto& v : values) {
                    s.labels.push_back(v.IsScalar() ? v.as<std::string>() : YamlEmit(v));
                  }
                }
                for (std::size_t i = 0; i < s.labels.size(); ++i) {
                  CheckLabel(sweep, i, s.labels[i]);
                  for (std::size_t j = 0; j < i; ++j) {
                    if (Slug(s.labels[i]) == Slug(s.labels[j])) {
                      sweep.Fail("labels", "two points are both named '" + Slug(s.labels[i]) + "'");
                    }
                  }
                }
              },
              [](YAML::Emitter& out, const Study& s) {
                out << YAML::Key << "labels" << YAML::Value << YAML::Flow << s.labels;
              });
  return fields;
}

const Fields<StudyStage>& StudyStageFields() {
  static const Fields<StudyStage> fields =
      Fields<StudyStage>()
          .Text("name", &StudyStage::name, {},
                "the stage's name (its output folder): letters, digits, '-', '_' or '.'; unique")
          .Required()
          .Custom(
              {"override", "map", "absent", "experiment keys", "this stage's changes"},
              [](const YamlMap& st, StudyStage& stage) {
                if (st.Has("override")) stage.override_yaml = YamlEmit(st.Map("override").node());
              },
              [](YAML::Emitter& out, const StudyStage& stage) {
                if (stage.override_yaml.empty()) return;
                out << YAML::Key << "override" << YAML::Value << YAML::Load(stage.override_yaml);
              })
          .Text("start_from", &StudyStage::start_from, {},
                "an earlier stage's name: the experiment's `start:` is that stage's recommended "
                "point");
  return fields;
}

const Fields<Study>& StudyValidationFields() {
  static const Fields<Study> fields = Fields<Study>().Integer(
      "flights", &Study::validation_flights, Range::Closed(0, 100000),
      "held-out maps each recommended point (and the defaults) flies, in the last stage's "
      "world; 0: none");
  return fields;
}

const Fields<Study>& StudyFields() {
  static const Fields<Study> fields =
      Fields<Study>()
          .Text("name", &Study::name, {}, "name stored in study.json")
          .Integer("seed", &Study::seed, Range::Closed(0, 9.0e15),
                   "stored in study.json; each experiment keeps its own seed")
          .Custom(
              {"experiment", "path", "required", "an [experiment](#experiment) file",
               "the base experiment (relative to the study file)"},
              [](const YamlMap& map, Study& s) {
                // The base, with `override` merged onto it.
                s.experiment_file = map.String("experiment");
                const std::string dir = fs::path(s.file).parent_path().string();
                const std::string base_file =
                    ResolvePath(s.experiment_file, dir.empty() ? "." : dir);
                if (!PathExists(base_file)) {
                  map.Fail("experiment",
                           "file '" + base_file + "' not found (relative to the study file)");
                }
                const YamlMap base = YamlMap::LoadFile(base_file);
                s.base_dir = fs::path(base_file).parent_path().string();
                if (s.base_dir.empty()) s.base_dir = ".";
                YAML::Node merged = base.node();
                if (map.Has("override")) {
                  merged = YamlDeepMerge(merged, map.Map("override").node());
                }
                s.base_text = YamlEmit(merged);
              },
              [](YAML::Emitter& out, const Study& s) {
                out << YAML::Key << "experiment" << YAML::Value << s.experiment_file;
              })
          // Merged by the `experiment` reader; base_text holds it merged, so nothing writes it.
          .Custom(
              {"override", "map", "absent", "experiment keys",
               "deep-merged onto the base (maps merge, anything else is replaced)"},
              [](const YamlMap&, Study&) {}, [](YAML::Emitter&, const Study&) {})
          .Custom(
              MapDoc("sweep", "one study point per value, below", "absent"),
              [](const YamlMap& map, Study& s) {
                if (map.Has("sweep")) {
                  StudySweepFields().Read(map.Map("sweep"), s);
                } else {
                  s.labels = {"all"};
                }
              },
              [](YAML::Emitter& out, const Study& s) {
                if (s.sweep_key.empty()) return;
                out << YAML::Key << "sweep" << YAML::Value;
                StudySweepFields().Write(out, s);
              })
          .Custom(
              {"stages", "list", "one stage `tuning`", "", "run in order per point, below"},
              [](const YamlMap& map, Study& s) {
                for (const YamlMap& st : map.Maps("stages")) {
                  const StudyStage stage = StudyStageFields().Read(st);
                  if (stage.name.empty() || Slug(stage.name) != stage.name) {
                    st.Fail("name", "must be a non-empty name of letters, digits, '-', '_' or '.'");
                  }
                  for (const auto& earlier : s.stages) {
                    if (earlier.name == stage.name) {
                      st.Fail("name", "stage '" + stage.name + "' is defined twice");
                    }
                  }
                  if (!stage.start_from.empty()) {
                    bool found = false;
                    for (const auto& earlier : s.stages) {
                      found = found || earlier.name == stage.start_from;
                    }
                    if (!found) {
                      st.Fail("start_from",
                              "must name an earlier stage, got '" + stage.start_from + "'");
                    }
                  }
                  s.stages.push_back(stage);
                }
                if (s.stages.empty()) s.stages.push_back({"tuning", "", ""});
              },
              [](YAML::Emitter& out, const Study& s) {
                out << YAML::Key << "stages" << YAML::Value << YAML::BeginSeq;
                for (const auto& stage : s.stages) StudyStageFields().Write(out, stage);
                out << YAML::EndSeq;
              })
          .Custom(MapDoc("validation", "validation flights of the tuned parameters, below"),
                  ReadSection("validation", StudyValidationFields()),
                  WriteSection("validation", StudyValidationFields()));
  return fields;
}

Study Study::LoadFile(const std::string& path) { return LoadFile(path, {}); }

Study Study::LoadFile(const std::string& path, const std::vector<std::string>& assignments) {
  const YamlMap original = YamlMap::LoadFile(path);  // file errors name the file and the line
  const YamlMap map =
      assignments.empty()
          ? original
          : YamlMap::FromString(ApplyAssignments(YamlEmit(original.node()), assignments, path),
                                path);
  Study s;
  s.file = path;
  StudyFields().Read(map, s);
  // Every point and stage must load: all configuration errors before any work.
  for (std::size_t p = 0; p < s.labels.size(); ++p) {
    for (std::size_t k = 0; k < s.stages.size(); ++k) (void)s.Build(p, k);
  }
  return s;
}

Experiment Study::Build(std::size_t point, std::size_t stage, const ParamValues& start) const {
  QT_DEMAND(point < labels.size() && stage < stages.size(), "Study::Build: index out of range");
  YAML::Node node = YAML::Load(base_text);
  if (!sweep_key.empty()) YamlSetPath(node, sweep_key, YAML::Load(sweep_values[point]), file, "sweep.key");
  if (!stages[stage].override_yaml.empty()) {
    node = YamlDeepMerge(node, YAML::Load(stages[stage].override_yaml));
  }
  if (!start.empty()) {
    YAML::Node s(YAML::NodeType::Map);
    for (const auto& [k, v] : start) s[k] = v;
    node["start"] = s;
  }
  const std::string origin =
      file + " (point " + labels[point] + ", stage " + stages[stage].name + ")";
  return Experiment::FromString(YamlEmit(node), origin, base_dir);
}

namespace {

using Clock = std::chrono::steady_clock;

// The outcome entry of one finished stage.
StudyStageResult StageEntry(const StudyStage& stage, const ParamValues& start,
                            const std::string& store, const ParamValues& best, double wall_s,
                            const Experiment& e) {
  StudyStageResult r;
  r.name = stage.name;
  r.start_from = stage.start_from;
  r.start = start;
  r.store = store;
  r.best = best;
  r.wall_s = wall_s;
  r.space = e.space.Parameters();
  return r;
}

// The stages of point p in order, each started from its start_from stage's best point: their
// entries into point.stages, the recommendations of the tuned trials into *candidates, the last
// stage's experiment into *last. False when cancelled.
bool RunPointStages(const Study& study, const StudyOptions& options, std::size_t p,
                    StudySummary& summary, StudyPointResult& point,
                    std::vector<Candidate>* candidates, Experiment* last) {
  std::map<std::string, ParamValues> stage_best;
  for (std::size_t k = 0; k < study.stages.size(); ++k) {
    const StudyStage& stage = study.stages[k];
    const ParamValues start =
        stage.start_from.empty() ? ParamValues{} : stage_best.at(stage.start_from);
    const Experiment e = study.Build(p, k, start);
    if (k + 1 == study.stages.size()) *last = e;
    const std::string dir = StagePath(options.out_dir, study.labels[p], stage.name);
    fs::create_directories(dir);
    RunOptions ro;
    ro.store_path = (fs::path(dir) / "results.sqlite").string();
    ro.threads = options.threads;
    ro.resume = options.resume && PathExists(ro.store_path);
    ro.validate = false;  // the study validates every stage's points in the last stage's world
    ro.cancel = options.cancel;
    if (options.on_progress) {
      ro.on_progress = [&](const Progress& run) {
        StudyProgress sp;
        sp.label = study.labels[p];
        sp.stage = stage.name;
        sp.point = p;
        sp.points = study.labels.size();
        sp.run = run;
        options.on_progress(sp);
      };
    }
    const RunSummary rs = RunExperiment(e, ro);
    summary.flights += rs.flights;
    summary.resolves += rs.resolves;
    if (rs.status == RunStatus::kCancelled) return false;
    double best = std::numeric_limits<double>::infinity();
    for (const auto& t : rs.trials) {
      if (t.method == ToString(Method::kDefault)) continue;
      candidates->push_back({stage.name, t.method, t.repeat, t.recommended});
      if (t.recommended_value < best) {
        best = t.recommended_value;
        stage_best[stage.name] = t.recommended;
      }
    }
    if (!stage_best.count(stage.name)) stage_best[stage.name] = e.Defaults();
    point.stages.push_back(StageEntry(stage, start,
                                      fs::relative(ro.store_path, options.out_dir).string(),
                                      stage_best[stage.name], rs.wall_s, e));
  }
  return true;
}

// Validation of point p: every candidate (the defaults first) on the same held-out maps and
// flight seeds, in the last stage's world `last`; one entry per flight into `flights`. False
// when cancelled.
bool ValidatePoint(const Study& study, const StudyOptions& options, std::size_t p,
                   const Experiment& last, std::vector<Candidate> candidates,
                   std::vector<StudyValidationFlight>& flights, StudySummary& summary) {
  candidates.insert(candidates.begin(), Candidate{"", "default", 0, last.Defaults()});
  const int n = study.validation_flights;
  std::vector<std::uint64_t> map_seeds(static_cast<std::size_t>(n));
  for (int f = 0; f < n; ++f) map_seeds[static_cast<std::size_t>(f)] = last.HeldOutMapSeed(f);
  std::vector<FlightJob> jobs;
  for (const Candidate& c : candidates) {
    for (int f = 0; f < n; ++f) {
      FlightJob job;
      job.params = last.Defaults();
      for (const auto& [k, v] : c.params) job.params[k] = v;
      job.map_seed = map_seeds[static_cast<std::size_t>(f)];
      job.flight_seed = last.HeldOutFlightSeed(f);
      jobs.push_back(std::move(job));
    }
  }
  const std::size_t total = jobs.size();
  const int threads = options.threads > 0 ? options.threads : last.threads;
  const std::vector<FlightRecord> records =
      FlyJobs(last.planner, jobs, threads, options.cancel, [&](int d, int t) {
        if (!options.on_progress) return;
        StudyProgress sp;
        sp.label = study.labels[p];
        sp.stage = "validation";
        sp.point = p;
        sp.points = study.labels.size();
        sp.validating = true;
        sp.validation_done = d;
        sp.validation_total = t;
        options.on_progress(sp);
      });
  if (options.cancel != nullptr && options.cancel->load()) return false;
  summary.flights += static_cast<long>(total);
  for (std::size_t i = 0; i < total; ++i) {
    const Candidate& c = candidates[i / static_cast<std::size_t>(n)];
    const std::size_t f = i % static_cast<std::size_t>(n);
    const FlightRecord& r = records[i];
    StudyValidationFlight v;
    v.point = p;
    v.label = study.labels[p];
    v.source_stage = c.stage;
    v.method = c.method;
    v.repeat = c.repeat;
    v.flight = f;
    v.map_seed = map_seeds[f];
    v.status = r.status;
    v.completed = r.completed;
    v.flight_time = r.flight_time;
    v.collisions = r.collisions;
    v.emergency_stops = r.emergency_stops;
    v.plans = r.plans;
    v.failed_plans = r.failed_plans;
    v.f_l = r.status == EvalStatus::kOk ? LongTermObjective(r, last.objective).value
                                        : last.objective.failure_value;
    v.params = c.params;
    flights.push_back(std::move(v));
  }
  return true;
}

}  // namespace

StudyOutcome RunStudy(const Study& study, const StudyOptions& options) {
  const auto t0 = Clock::now();
  StudyOutcome outcome;
  outcome.name = study.name;
  outcome.file = study.file;
  outcome.seed = study.seed;
  outcome.sweep_key = study.sweep_key;
  outcome.validation_flights = study.validation_flights;
  StudySummary& summary = outcome.summary;
  fs::create_directories(options.out_dir);
  const auto update = [&] {
    if (options.on_update) options.on_update(outcome);
  };
  update();
  for (std::size_t p = 0; p < study.labels.size(); ++p) {
    StudyPointResult point;
    point.label = study.labels[p];
    point.value = study.sweep_key.empty() ? "" : study.sweep_values[p];
    std::vector<Candidate> candidates;
    Experiment last = study.Build(p, study.stages.size() - 1);
    if (!RunPointStages(study, options, p, summary, point, &candidates, &last)) {
      summary.status = RunStatus::kCancelled;
      break;
    }
    outcome.points.push_back(std::move(point));
    update();
    if (study.validation_flights == 0) continue;
    if (!ValidatePoint(study, options, p, last, std::move(candidates), outcome.validation,
                       summary)) {
      summary.status = RunStatus::kCancelled;
      break;
    }
    update();
  }
  summary.wall_s = std::chrono::duration<double>(Clock::now() - t0).count();
  return outcome;
}

}  // namespace quadtune::engine
