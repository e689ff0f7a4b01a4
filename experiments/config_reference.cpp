#include "config_reference.hpp"

#include <fstream>
#include <iostream>

#include "quadtune/common/error.hpp"
#include "quadtune/common/fields.hpp"
#include "quadtune/engine/adaptation/context_policy.hpp"
#include "quadtune/engine/adaptation/online_adaptation.hpp"
#include "quadtune/engine/experiment/experiment.hpp"
#include "quadtune/engine/experiment/objectives.hpp"
#include "quadtune/engine/planners/planners.hpp"
#include "quadtune/engine/tuning/study.hpp"
#include "quadtune/layout/options.hpp"
#include "quadtune/optimizers/bayes_opt.hpp"
#include "quadtune/optimizers/gaussian_process.hpp"
#include "quadtune/optimizers/parameter_space.hpp"
#include "quadtune/optimizers/pso.hpp"
#include "quadtune/optimizers/racing.hpp"
#include "quadtune/physics/drone.hpp"
#include "quadtune/physics/world.hpp"
#include "quadtune/planning/parameters.hpp"

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
(`ConfigError`). Relative paths inside a file resolve next to that file first, then in the
working directory, then under `$QUADTUNE_ASSETS`, then under the installed program's
`share/quadtune/assets` (the source tree's `assets/` for the program in the build tree; `quadtune
paths` prints the folders).

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
`bench --soak`: memory not flat), 4 `fly --from` flew a flight other than the stored one, 130
interrupted (continue with `--resume`).

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
| depth sensor | `planner.sensor` | [Depth sensor](#depth-sensor) |
| layout options (`assets/layouts/*.yaml`) | `planner.layout[_file]`, `fly --layout-options`, `layout` | [Layout](#layout) |
| planner parameters | `planner.fixed`, `parameters`, `fly --set` | [Planner parameters](#planner-parameters) |
| optimiser settings | `pso:`, `bo:` | [PSO](#pso), [Bayesian optimisation](#bayesian-optimisation) |
)";

/// `rows` with `prefix` before every key (a nested map's keys as dotted paths).
std::vector<FieldDoc> Prefixed(std::vector<FieldDoc> rows, const std::string& prefix) {
  for (FieldDoc& r : rows) r.key = prefix + r.key;
  return rows;
}

/// `a` followed by `b`.
std::vector<FieldDoc> Join(std::vector<FieldDoc> a, const std::vector<FieldDoc>& b) {
  a.insert(a.end(), b.begin(), b.end());
  return a;
}

const char* const kRecommendProse =
    R"(After its budget a tuned trial ranks its candidates (`bo`, `bo_pso`: the observed points by
posterior mean, `bo_pso` with PSO's final θ_s; `random`, `pso`: the flights by f_l) and tries them
in turn on re-flight maps: fresh maps of the trial's density, the same for every method and
candidate of a repeat, disjoint from tuning and held-out maps. The first candidate that passes
is recommended; when none passes, the defaults. Re-flights are stored as kind `recheck`
(iteration = the candidate's rank, index = the re-flight) and replayed on `--resume`.)";

const char* const kRaceProse =
    R"(With `enabled: true` a tuned trial keeps an incumbent, at first the defaults. After a round of
its method, whenever racing flights are below `share` of the flights so far, the method's best
candidate not raced yet (`bo`, `bo_pso`: lowest posterior mean; `random`, `pso`: lowest f_l)
challenges it on race maps shared with the incumbent (common random numbers: the same maps and
world seeds for both sides, for every method of a repeat, disjoint from tuning, re-flight and
held-out maps). On n maps with paired differences d = f_l(challenger) − f_l(incumbent) the
challenger is turned away when mean(d) >= 0 or when it fails (collides or does not finish) on more
maps where the incumbent did not than the other way round; it replaces the incumbent when
Wilcoxon's one-sided signed-rank test gives p <= `alpha`; else it flies twice as many maps, up to
`max_maps`. Every racing flight counts against `budget.flights`; the trial hands back its
incumbent. Race flights are stored as kind `race` (iteration = the race, index = the flight within
it; terms `race_map`, `challenger`), each race's outcome as kind `incumbent` (index 0: the
incumbent after the race, its mean f_l on the maps it flew, terms `accepted`, `p_value`,
`mean_difference`, `maps`); with racing on, every flight's terms hold `flight_no`, its place among
the trial's flights.)";

const char* const kObjectiveProse =
    R"(f_s (solve-time kind, paper Sec. III-D) = w_t J_t + w_s n_s (+ w_c J_c when `w_c` is given), with
J_t = t_c + w_τ max(0, t_c − τ_t)². f_s (changing-environment kind, Sec. IV-B) = w_t t_exe +
w_p ∫‖jerk‖² + w_c J_c, J_c = (C − c_obs)² when c_obs < C. f_l (Sec. IV-A) = t_f + t_f·n_c + w_e·n_e.)";

std::string ExperimentPart() {
  using namespace engine;
  std::string out = Section("## Experiment",
                            "Source: `engine/include/quadtune/engine/experiment/experiment.hpp`, "
                            "`experiment/objectives.hpp`, `planners/planners.hpp`.",
                            {});
  out += Section("### Top level", "", ExperimentFields().Docs());
  out += Section("### `parameters` (one item per tuned parameter)", "",
                 optimizers::ParameterFields().Docs());
  out += Section("### `maps`", "", MapsFields().Docs());
  out += Section("### `validation`", "", ValidationFields().Docs());
  out += Section("### `recommend`", kRecommendProse, RecommendFields().Docs());
  out += Section("### `race`", kRaceProse, optimizers::RaceFields().Docs());
  out += Section("### `planner`", "", ClosedLoopFields().Docs());
  out += Section("### `objective`", kObjectiveProse,
                 Join(Join(ObjectiveFields().Docs(),
                           Prefixed(ObjectiveShortTermFields().Docs(), "short_term.")),
                      Prefixed(ObjectiveLongTermFields().Docs(), "long_term.")));
  out += Section("### `budget`", "", BudgetFields().Docs());
  return out;
}

std::string StudyPart() {
  using namespace engine;
  std::string out = Section(
      "## Study",
      "Source: `engine/include/quadtune/engine/tuning/study.hpp`. One experiment run at several "
      "settings (a sweep) and/or in stages, then validation flights of the tuned parameters on "
      "held-out maps. Outputs: `study.json`, `OUT/<label>/<stage>/results.sqlite` (a `quadtune "
      "run` store, so `--resume` works per stage), `validation.csv`.",
      StudyFields().Docs());
  out += Section("### `sweep`", "", StudySweepFields().Docs());
  out += Section("### `stages` (one item per stage, run in order per point)", "",
                 StudyStageFields().Docs());
  out += Section("### `validation`", "", StudyValidationFields().Docs());
  out += Section("## Adaptation experiment",
                 "Source: `engine/include/quadtune/engine/adaptation/online_adaptation.hpp`. "
                 "Read by `quadtune adapt` (paper Sec. IV-B: v_des adapted online through zones "
                 "of changing density).",
                 AdaptExperimentFields().Docs());
  out += Section("### `adaptation`", "", AdaptationFields().Docs());
  out += Section("### Context policy",
                 "`adaptation.policy`, or a file that `quadtune policy` writes and `quadtune "
                 "adapt --policy` reads: v_des at measured free ranges, interpolated between "
                 "them (docs/design.md, \"Adaptation that sees risk\").",
                 ContextPolicyFields().Docs());
  out += Section("#### `free_range`", "", FreeRangeFields().Docs());
  return out;
}

std::string PhysicsPart() {
  const physics::DroneDescription drone;
  std::string out = Section(
      "## Drone",
      "Source: `physics/include/quadtune/physics/drone.hpp` (`DroneFields()`); examples in "
      "`assets/drones/`. SI units, rotor speeds in rpm. A drone that cannot lift itself "
      "(thrust-to-weight ≤ 1 at `max_speed_rpm`) is refused.",
      physics::DroneFields().Docs());
  out += Section("### `rotor`", "", physics::RotorFields().Docs(drone));
  out += Section("### `collision`",
                 "`shape: sphere` takes `radius`; `shape: box` takes `half_extents`.",
                 Join(physics::SphereCollisionFields().Docs(drone),
                      physics::BoxCollisionFields().Docs(drone)));
  out += Section("### `controller`",
                 "SE(3) controller gains: position and velocity gains normalised by mass, "
                 "attitude and angular-rate gains by inertia.",
                 physics::ControllerFields().Docs());
  out += Section("## World",
                 "Source: `physics/include/quadtune/physics/world.hpp` (`WorldFields()`). "
                 "Defaults give an ideal, noise-free world.",
                 physics::WorldFields().Docs());
  out += Section("### `measurement_noise`",
                 "Standard deviations of the noise on the state the controller sees.",
                 physics::MeasurementNoiseFields().Docs());
  out += Section("## Depth sensor",
                 "Source: `physics/include/quadtune/physics/depth_sensor.hpp` "
                 "(`DepthSensorFields()`). Keys of `planner.sensor`; a key not given keeps the "
                 "closed loop's default camera (48 x 32 pixels, 87° x 58°, 15 Hz, 5 m).",
                 physics::DepthSensorFields().Docs());
  return out;
}

const char* const kDensityProse =
    R"(Source: `physics/layout/include/quadtune/layout/options.hpp` (`LayoutFields()`); examples
in `assets/layouts/`. World frame, z up, metres and radians.

**Density.** A zone's spacing s is the paper's "average spacing" (3.0, 2.1, 1.3, 0.9 m). With
`density: area` (the default) a zone of area A (its x-extent times the region's y-extent,
keep-out zones included) holds round(A / (4 s²)) obstacles, at least 1: the intensity
λ = 1 / (4 s²) of a uniform random forest whose expected mean nearest-neighbour distance is s.
The count, and so the crowding, is fixed and grows as 1 / s². With `density: nearest_neighbour`
obstacles are added until the mean nearest-neighbour distance between centres reaches s. With
`density: free_gap` obstacles are added until the mean nearest-neighbour free gap (from each
footprint's boundary to the nearest other footprint of its zone) reaches s: one obstacle mix
crowded by the room left between surfaces, the definition of the density study's forests. Every
definition measures and reports the achieved centre spacing and free gap.

A layout is refused when a spacing is below what its obstacles need side by side (below
min_gap under `free_gap`), when the
keep-out zones cover more than half the region, or when it asks for more than 100 000 obstacles.)";

std::string LayoutPart() {
  std::string out = Section("## Layout", kDensityProse, layout::LayoutFields().Docs());
  out += Section("### `region`", "", layout::RegionFields().Docs());
  out += Section("### `mission`", "", layout::MissionFields().Docs());
  out += Section("### `keep_out` (one item per cylinder)", "", layout::KeepOutFields().Docs());
  out += Section("### `obstacles`", "", layout::ObstacleMixFields().Docs());
  out += Section("### `obstacles.cylinder`", "", layout::CylinderShapeFields().Docs());
  out += Section("### `obstacles.ring`", "", layout::RingShapeFields().Docs());
  out += Section("### `zones` (one item per zone)",
                 "Consecutive x-intervals covering the region; a zone's `obstacles` start from "
                 "the layout's mixture.",
                 layout::ZoneFields().Docs());
  return out;
}

std::string OptimiserPart() {
  std::string out = Section(
      "## Planner parameters",
      "Source: `planning/include/quadtune/planning/parameters.hpp` (`PlannerParamsFields()`). "
      "Names usable in `parameters`, `planner.fixed`, the adaptation experiment's `planner` and "
      "`fly --set`; θ_s are short-term parameters (PSO), θ_l long-term ones (BO).",
      planning::PlannerParamsFields().Docs());
  out += Section("## Bayesian optimisation",
                 "Source: `optimizers/include/quadtune/optimizers/bayes_opt.hpp`, "
                 "`gaussian_process.hpp`.",
                 optimizers::BayesOptFields().Docs());
  out += Section("### `moving_bounds` (paper Sec. III-E)", "",
                 optimizers::MovingBoundsFields().Docs());
  out += Section("### `gp`", "", optimizers::GpFields().Docs());
  return out + Section("## PSO",
                 "Source: `optimizers/include/quadtune/optimizers/pso.hpp` (asynchronous PSO, "
                 "paper Sec. III-C-1), `PsoFields()`.",
                 optimizers::PsoFields().Docs());
}

}  // namespace

std::string ConfigReference() {
  std::string out = kIntro;
  out += "\n";
  out += ExperimentPart();
  out += StudyPart();
  out += PhysicsPart();
  out += LayoutPart();
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
