#include "config_reference.hpp"

#include <fstream>
#include <iostream>

#include "quadtune/common/error.hpp"
#include "quadtune/common/fields.hpp"
#include "quadtune/optimizers/pso.hpp"

namespace quadtune::cli {
namespace {

/// A section heading, its source line, the prose before the table, and the table.
std::string Section(const std::string& heading, const std::string& prose,
                    const std::vector<FieldDoc>& rows) {
  std::string out = heading + "\n\n";
  if (!prose.empty()) out += prose + "\n\n";
  if (!rows.empty()) out += MarkdownTable(rows) + "\n";
  return out;
}

const char* const kIntro = R"(# Configuration reference

Every input file is YAML. Unknown keys, wrong types and values out of range stop the command
before any work starts, with a message that names the file, the key and what is allowed
(`ConfigError`). Relative paths inside a file resolve next to that file first, then under
`$QUADTUNE_ASSETS`, then under the source tree's `assets/`.

Every command that reads an experiment file (`run`, `study`, `sweep`, `adapt`, `bench`) takes
`--set KEY=VALUE` on the file's dotted keys (list elements by index, e.g. `--set
parameters.3.upper=6`); the edited text is validated like the file itself and stored with the
results. `run`, `study`, `sweep` and `adapt` take `--threads N` (`adapt`: flights flown at once;
`bench` measures 1…`--max-threads`). `quadtune fly` takes `--set NAME=VALUE` on planner
parameters (below).

The command line spells a concept as the files do: `fly --mission go_and_return|go_to` as
`planner.mission`; `--layout-options FILE` (layout generator options) in `fly` and `layout`.
Exit codes of every command: 0 done, 1 failed while running, 2 refused before any work (command
line, file or result directory), 3 done with a negative outcome (`fly`: flight not completed;
`bench --soak`: memory not flat), 130 interrupted (continue with `--resume`).

This page is generated from the field lists that the readers use (`common/fields.hpp`): each
table is one list, with the defaults of the code. `quadtune config-reference --out
docs/config.md` writes it; the test `ConfigReference.DocsPageIsCurrent` fails when the page and
the lists differ. In the tables, "allowed" is an interval of numbers, `[` and `]` closed, `(`
and `)` open.

| file kind | read by | section |
|---|---|---|
| experiment (`experiments/*.yaml`) | `quadtune run`, `bench`, the stages of a study | [Experiment](#experiment) |
| study | `quadtune study` | [Study](#study) |
| adaptation experiment | `quadtune adapt` | [Adaptation experiment](#adaptation-experiment) |
| drone (`assets/drones/*.yaml`) | experiments, `fly --drone` | [Drone](#drone) |
| world options | `planner.world`, `fly --world` | [World](#world) |
| layout options (`assets/layouts/*.yaml`) | `planner.layout[_file]`, `fly --layout-options`, `layout` | [Layout](#layout) |
| planner parameters | `planner.fixed`, `parameters`, `fly --set` | [Planner parameters](#planner-parameters) |
| optimiser settings | `pso:`, `bo:` | [PSO](#pso), [Bayesian optimisation](#bayesian-optimisation) |
)";

std::string OptimiserPart() {
  return Section("## PSO",
                 "Source: `optimizers/include/quadtune/optimizers/pso.hpp` (asynchronous PSO, "
                 "paper Sec. III-C-1), `PsoFields()`.",
                 optimizers::PsoFields().Docs());
}

}  // namespace

std::string ConfigReference() {
  std::string out = kIntro;
  out += "\n";
  out += OptimiserPart();
  // One newline at the end of the page.
  while (out.size() > 1 && out[out.size() - 1] == '\n' && out[out.size() - 2] == '\n') {
    out.pop_back();
  }
  return out;
}

void RegisterConfigReference(CLI::App& app, int& exit_code) {
  static std::string out_path;
  auto* cmd = app.add_subcommand(
      "config-reference",
      "print the configuration reference (every key of every file: type, default, range, "
      "meaning) as Markdown; the page docs/config.md is this output");
  cmd->add_option("--out", out_path, "write it to this file instead of standard output");
  cmd->callback([&exit_code] {
    const std::string text = ConfigReference();
    if (out_path.empty()) {
      std::cout << text;
      exit_code = 0;
      return;
    }
    std::ofstream file(out_path, std::ios::binary);
    file << text;
    file.close();
    if (!file) throw ConfigError(out_path, "--out", "cannot write the file");
    exit_code = 0;
  });
}

}  // namespace quadtune::cli
