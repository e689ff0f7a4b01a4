// Malformed inputs through the `quadtune` program: every file kind it reads (experiment, study,
// adaptation, drone, layout options, saved layout, world options, results store) and its
// command line. Each case must exit non-zero, say what is wrong in one line on stderr naming
// the file (or option) and the key, and create no output (progress lines on stdout are allowed).
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <set>
#include <string>
#include <vector>

#include "../cli_util.hpp"

namespace quadtune::test {
namespace {

namespace fs = std::filesystem;

const char* kToy = R"(name: toy
seed: 3
threads: 1
repeats: 1
methods: [default, random]
planner:
  type: toy
  toy: {length: 20, gates: 6}
parameters:
  - {name: gain, lower: 0.05, upper: 1.5, default: 0.3}
  - {name: max_iter, lower: 2, upper: 40, type: integer, default: 20}
  - {name: speed, lower: 0.5, upper: 6.0, default: 2.0}
  - {name: margin, lower: 0.0, upper: 3.0, default: 0.5}
short_term: [gain, max_iter]
long_term: [speed, margin]
budget: {flights: 2, flight_batch: 1, short_evals_per_flight: 2}
)";

const char* kIpopt = R"(name: ip
seed: 1
methods: [default]
planner:
  type: ipopt
  drone: drone.yaml
  layout_file: options.yaml
parameters:
  - {name: w_col, lower: 0.05, upper: 5.0, log: true, default: 0.5}
  - {name: w_dyn, lower: 0.01, upper: 1.0, log: true, default: 0.1}
  - {name: n_pol, lower: 3, upper: 10, type: integer, default: 5}
  - {name: v_des, lower: 0.5, upper: 4.0, default: 2.0}
  - {name: h_pl, lower: 3.0, upper: 12.0, default: 7.5}
  - {name: t_pl, lower: 0.2, upper: 2.0, default: 1.0}
short_term: [w_col, w_dyn, n_pol]
long_term: [v_des, h_pl, t_pl]
budget: {flights: 1}
)";

const char* kStudy = R"(name: st
seed: 4
experiment: toy.yaml
override: {budget: {flights: 2}}
sweep:
  key: planner.toy.gates
  values: [2, 4]
  labels: [two, four]
validation: {flights: 1}
)";

const char* kAdapt = R"(name: ad
seed: 3
drone: drone.yaml
layout:
  region: {min: [0.0, -4.0], max: [16.0, 4.0]}
  mission: {start: [0.0, 0.0, 1.2], goal: [16.0, 0.0, 1.2], keep_out_radius: 1.5}
  min_gap: 0.2
  obstacles:
    ring_fraction: 0.0
    cylinder: {radius: [0.125, 0.3], height: [3.0, 3.0]}
  zones:
    - {x_range: [0.0, 8.0], spacing: 3.0}
    - {x_range: [8.0, 16.0], spacing: 1.3}
max_time: 40
planner: {v_des: 2.0}
baselines: [2.0]
adaptation:
  v_des_bounds: [1.0, 6.0]
  trials_per_segment: 4
)";

/// `text` with its first `from` replaced by `to` (the case fails loudly if `from` is absent).
std::string Edit(const std::string& text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  if (at == std::string::npos) return "EDIT-NOT-FOUND: " + from;
  std::string out = text;
  out.replace(at, from.size(), to);
  return out;
}

std::string Asset(const std::string& relative) {
  return ReadText(fs::path(QUADTUNE_SOURCE_DIR) / "assets" / relative);
}

struct Case {
  std::string name;
  std::string file;                 ///< written into the case's folder ("" = none)
  std::string text;                 ///< its content
  std::string args;                 ///< command line; {d} is the case's folder
  std::vector<std::string> expect;  ///< each must appear in the stderr line (file, key, value)
};

std::vector<Case> Cases() {
  const std::string toy = kToy;
  const std::string ip = kIpopt;
  const std::string study = kStudy;
  const std::string adapt = kAdapt;
  const std::string drone = Asset("drones/crazyflie.yaml");
  const std::string options = Asset("layouts/forest_thin_1p3.yaml");
  const std::string saved = Asset("layouts/forest_1p3_seed1.layout.yaml");
  const std::string run = "run {d}/bad.yaml --out {d}/out --quiet";
  const std::string ip_run = "run {d}/ip.yaml --out {d}/out --quiet";
  const std::string study_run = "study {d}/bad.yaml --out {d}/out --no-plot --quiet";
  const std::string adapt_run = "adapt {d}/bad.yaml --out {d}/out --no-plot";
  const std::string fly = "fly --layout {d}/saved.yaml --out {d}/out --no-plot";
  std::vector<Case> c = {
      // ---- experiment file ----
      {"exp_duplicate_key",
       "bad.yaml",
       Edit(toy, "seed: 3\n", "seed: 7\nseed: 8\n"),
       run,
       {"bad.yaml", "seed", "twice"}},
      {"exp_duplicate_nested_key",
       "bad.yaml",
       Edit(toy, "budget: {flights: 2,", "budget: {flights: 2, flights: 3,"),
       run,
       {"bad.yaml", "budget.flights", "twice"}},
      {"exp_octal_looking_seed_too_big",
       "bad.yaml",
       Edit(toy, "seed: 3", "seed: 0x10"),
       run,
       {"bad.yaml", "seed", "0x10"}},
      {"exp_negative_seed",
       "bad.yaml",
       Edit(toy, "seed: 3", "seed: -5"),
       run,
       {"bad.yaml", "seed", "-5"}},
      {"exp_huge_seed",
       "bad.yaml",
       Edit(toy, "seed: 3", "seed: 99999999999999999999999"),
       run,
       {"bad.yaml", "seed", "99999999999999999999999"}},
      {"exp_float_repeats",
       "bad.yaml",
       Edit(toy, "repeats: 1", "repeats: 1.5"),
       run,
       {"bad.yaml", "repeats", "1.5"}},
      {"exp_non_utf8_name",
       "bad.yaml",
       Edit(toy, "name: toy", "name: to\xff\xfey"),
       run,
       {"bad.yaml", "line 1", "UTF-8"}},
      {"exp_unknown_key",
       "bad.yaml",
       Edit(toy, "seed: 3", "seed: 3\nsede: 4"),
       run,
       {"bad.yaml", "sede", "unknown key"}},
      {"exp_unknown_method",
       "bad.yaml",
       Edit(toy, "[default, random]", "[default, magic]"),
       run,
       {"bad.yaml", "methods", "magic"}},
      {"exp_method_twice",
       "bad.yaml",
       Edit(toy, "[default, random]", "[random, random]"),
       run,
       {"bad.yaml", "methods", "twice"}},
      {"exp_threads_zero",
       "bad.yaml",
       Edit(toy, "threads: 1", "threads: 0"),
       run,
       {"bad.yaml", "threads", "0"}},
      {"exp_mode_bad",
       "bad.yaml",
       Edit(toy, "repeats: 1", "repeats: 1\nmode: fast"),
       run,
       {"bad.yaml", "mode", "fast"}},
      {"exp_flights_zero",
       "bad.yaml",
       Edit(toy, "flights: 2,", "flights: 0,"),
       run,
       {"bad.yaml", "budget.flights", "0"}},
      {"exp_flights_beyond_cap",
       "bad.yaml",
       Edit(toy, "flights: 2,", "flights: 1000000,"),
       run,
       {"bad.yaml", "budget.flights", "1000000"}},
      {"exp_total_flights_beyond_cap",
       "bad.yaml",
       Edit(Edit(toy, "flights: 2,", "flights: 100000,"), "repeats: 1", "repeats: 1000"),
       run,
       {"bad.yaml", "budget.flights", "2e+08"}},
      {"exp_repeats_beyond_cap",
       "bad.yaml",
       Edit(toy, "repeats: 1", "repeats: 5000"),
       run,
       {"bad.yaml", "repeats", "5000"}},
      {"exp_short_evals_beyond_cap",
       "bad.yaml",
       Edit(toy, "short_evals_per_flight: 2", "short_evals_per_flight: 10000000"),
       run,
       {"bad.yaml", "budget.short_evals_per_flight", "10000000"}},
      {"exp_lower_above_upper",
       "bad.yaml",
       Edit(toy, "lower: 0.05, upper: 1.5", "lower: 2, upper: 1.5"),
       run,
       {"bad.yaml", "parameters", "gain"}},
      {"exp_box_outside_planner",
       "bad.yaml",
       Edit(toy, "upper: 40,", "upper: 100000,"),
       run,
       {"bad.yaml", "parameters.1.upper", "100000", "[1, 10000]"}},
      {"exp_integer_param_continuous",
       "bad.yaml",
       Edit(toy, ", type: integer", ""),
       run,
       {"bad.yaml", "parameters.1.type", "integer"}},
      {"exp_unknown_parameter",
       "bad.yaml",
       Edit(toy, "name: margin", "name: marjin"),
       run,
       {"bad.yaml", "parameters", "marjin"}},
      {"exp_short_term_unknown",
       "bad.yaml",
       Edit(toy, "short_term: [gain, max_iter]", "short_term: [gain, speed]"),
       run,
       {"bad.yaml", "short_term", "speed"}},
      {"exp_parameters_not_list",
       "bad.yaml",
       "name: x\nmethods: [default]\nplanner: {type: toy}\nparameters: 3\n",
       run,
       {"bad.yaml", "parameters", "sequence"}},
      {"exp_top_level_list", "bad.yaml", "- a\n- b\n", run, {"bad.yaml", "mapping"}},
      {"exp_malformed_yaml",
       "bad.yaml",
       "name: [unclosed\nseed: 1\n",
       run,
       {"bad.yaml", "malformed YAML", "line"}},
      {"exp_deep_nesting",
       "bad.yaml",
       std::string(100000, '[') + std::string(100000, ']') + "\n",
       run,
       {"bad.yaml", "nesting"}},
      {"exp_tab_garbage", "bad.yaml", "\t\t: : :\n{{{\n", run, {"bad.yaml", "malformed YAML"}},
      {"exp_planner_type_bad",
       "bad.yaml",
       Edit(toy, "type: toy", "type: rrt"),
       run,
       {"bad.yaml", "planner.type", "rrt"}},
      {"exp_toy_gates_negative",
       "bad.yaml",
       Edit(toy, "gates: 6", "gates: -1"),
       run,
       {"bad.yaml", "planner.toy.gates", "-1"}},
      {"exp_flight_batch_text",
       "bad.yaml",
       Edit(toy, "flight_batch: 1", "flight_batch: two"),
       run,
       {"bad.yaml", "budget.flight_batch", "two"}},
      {"exp_pso_particles_zero",
       "bad.yaml",
       toy + "pso: {num_particles: 0}\n",
       run,
       {"bad.yaml", "pso.num_particles", "0"}},
      {"exp_bo_unknown_key",
       "bad.yaml",
       toy + "bo: {initial_desing_size: 3}\n",
       run,
       {"bad.yaml", "bo.initial_desing_size", "unknown key"}},
      {"exp_start_outside_box",
       "bad.yaml",
       toy + "start: {speed: 9.0}\n",
       run,
       {"bad.yaml", "start.speed", "9"}},
      {"exp_missing_file",
       "",
       "",
       "run {d}/nothere.yaml --out {d}/out",
       {"nothere.yaml", "no such file"}},
      {"exp_is_directory", "", "", "run {d} --out {d}/out", {"is a directory"}},
      {"exp_set_box_outside_planner",
       "toy.yaml",
       toy,
       "run {d}/toy.yaml --out {d}/out --set parameters.2.upper=1000",
       {"toy.yaml", "parameters.2.upper", "1000"}},
      {"exp_set_not_key_value",
       "toy.yaml",
       toy,
       "run {d}/toy.yaml --out {d}/out --set repeats",
       {"toy.yaml", "--set", "repeats"}},
      // A typo in a --set key is the option's fault, not the file's: named with what is allowed.
      {"exp_set_key_typo",
       "",
       "",
       "run {d}/toy.yaml --out {d}/out --set budget.flight=3",
       {"] --set: budget.flight: unknown key", "flights", "--set budget.flight=3"}},
      {"exp_set_map_typo",
       "",
       "",
       "run {d}/toy.yaml --out {d}/out --set budgt.flights=3",
       {"] --set: budgt: unknown key", "budget", "--set budgt.flights=3"}},
      // An option near a known one is named as the likely meaning.
      {"run_thread_typo",
       "",
       "",
       "run {d}/toy.yaml --out {d}/out --thread 2",
       {"not expected", "did you mean --threads instead of --thread?"}},
      // ---- ipopt experiment: drone and layout options files ----
      {"ipopt_nbol_outside_planner",
       "ip.yaml",
       Edit(ip, "lower: 3, upper: 10", "lower: 0, upper: 1000"),
       ip_run,
       {"ip.yaml", "parameters.2.lower", "[2, 12]"}},
      {"ipopt_vdes_outside_planner",
       "ip.yaml",
       Edit(ip, "lower: 0.5, upper: 4.0", "lower: 0.5, upper: 99"),
       ip_run,
       {"ip.yaml", "parameters.3.upper", "99"}},
      {"ipopt_drone_missing",
       "ip.yaml",
       Edit(ip, "drone: drone.yaml", "drone: nodrone.yaml"),
       ip_run,
       {"ip.yaml", "planner.drone", "nodrone.yaml"}},
      {"ipopt_drone_is_directory",
       "ip.yaml",
       Edit(ip, "drone: drone.yaml", "drone: sub"),
       ip_run,
       {"sub", "is a directory"}},
      {"ipopt_fixed_unknown",
       "ip.yaml",
       Edit(ip, "  layout_file: options.yaml", "  layout_file: options.yaml\n  fixed: {a_maxx: 2}"),
       ip_run,
       {"ip.yaml", "a_maxx"}},
      // ---- drone file (fly --drone) ----
      {"drone_negative_mass",
       "bad.yaml",
       Edit(drone, "mass: 0.027", "mass: -1"),
       fly + " --drone {d}/bad.yaml",
       {"bad.yaml", "mass", "-1"}},
      {"drone_duplicate_mass",
       "bad.yaml",
       Edit(drone, "mass: 0.027", "mass: 0.027\nmass: 0.03"),
       fly + " --drone {d}/bad.yaml",
       {"bad.yaml", "mass", "twice"}},
      {"drone_inertia_two_numbers",
       "bad.yaml",
       Edit(drone, "inertia: [1.4e-5, 1.4e-5, 2.17e-5]", "inertia: [1.4e-5, 1.4e-5]"),
       fly + " --drone {d}/bad.yaml",
       {"bad.yaml", "inertia", "3 numbers"}},
      {"drone_unknown_key",
       "bad.yaml",
       drone + "colour: red\n",
       fly + " --drone {d}/bad.yaml",
       {"bad.yaml", "colour", "unknown key"}},
      {"drone_configuration_bad",
       "bad.yaml",
       Edit(drone, "configuration: x", "configuration: y"),
       fly + " --drone {d}/bad.yaml",
       {"bad.yaml", "configuration", "y"}},
      {"drone_rotor_text",
       "bad.yaml",
       Edit(drone, "time_constant: 0.02", "time_constant: fast"),
       fly + " --drone {d}/bad.yaml",
       {"bad.yaml", "rotor.time_constant", "fast"}},
      {"drone_is_directory", "", "", fly + " --drone {d}/sub", {"sub", "is a directory"}},
      {"drone_empty_file", "bad.yaml", "", fly + " --drone {d}/bad.yaml", {"bad.yaml", "missing"}},
      // ---- layout options (layout --layout-options) ----
      {"layout_spacing_negative",
       "bad.yaml",
       Edit(options, "spacing: 1.3", "spacing: -1.3"),
       "layout --layout-options {d}/bad.yaml --out {d}/l.yaml",
       {"bad.yaml", "spacing", "-1.3"}},
      {"layout_duplicate_spacing",
       "bad.yaml",
       Edit(options, "spacing: 1.3", "spacing: 1.3\nspacing: 2"),
       "layout --layout-options {d}/bad.yaml --out {d}/l.yaml",
       {"bad.yaml", "spacing", "twice"}},
      {"layout_region_inverted",
       "bad.yaml",
       Edit(options, "region: {min: [0.0, -5.0], max: [24.0, 5.0]}",
            "region: {min: [24.0, -5.0], max: [0.0, 5.0]}"),
       "layout --layout-options {d}/bad.yaml --out {d}/l.yaml",
       {"bad.yaml", "region"}},
      {"layout_unknown_key",
       "bad.yaml",
       options + "densitty: 3\n",
       "layout --layout-options {d}/bad.yaml --out {d}/l.yaml",
       {"bad.yaml", "densitty", "unknown key"}},
      {"layout_ring_fraction_above_one",
       "bad.yaml",
       Edit(options, "ring_fraction: 0.1", "ring_fraction: 1.5"),
       "layout --layout-options {d}/bad.yaml --out {d}/l.yaml",
       {"bad.yaml", "obstacles.ring_fraction", "1.5"}},
      {"layout_options_is_directory",
       "",
       "",
       "layout --layout-options {d}/sub --out {d}/l.yaml",
       {"sub", "is a directory"}},
      {"layout_out_missing_folder",
       "options.yaml",
       options,
       "layout --layout-options {d}/options.yaml --out {d}/nofolder/l.yaml",
       {"nofolder", "--out", "does not exist"}},
      {"layout_out_is_directory",
       "options.yaml",
       options,
       "layout --layout-options {d}/options.yaml --out {d}/sub",
       {"sub", "--out", "directory"}},
      {"layout_negative_seed", "", "", "layout --seed -5 --out {d}/l.yaml", {"--seed", "-5"}},
      // ---- saved layout (fly --layout) ----
      {"saved_format_bad",
       "saved.yaml",
       Edit(saved, "format: quadtune.layout/1", "format: other/2"),
       fly,
       {"saved.yaml", "format", "other/2"}},
      {"saved_duplicate_seed",
       "saved.yaml",
       Edit(saved, "seed: 1\n", "seed: 1\nseed: 2\n"),
       fly,
       {"saved.yaml", "seed", "twice"}},
      {"saved_truncated",
       "saved.yaml",
       saved.substr(0, saved.size() / 2) + "\n  - [1, 2",
       fly,
       {"saved.yaml"}},
      {"saved_is_directory",
       "",
       "",
       "fly --layout {d}/sub --out {d}/out --no-plot",
       {"sub", "is a directory"}},
      // ---- world options (fly --world) ----
      {"world_unknown_key",
       "world.yaml",
       "motor_lagg: true\n",
       fly + " --world {d}/world.yaml",
       {"world.yaml", "motor_lagg", "unknown key"}},
      {"world_wind_text",
       "world.yaml",
       "wind: windy\n",
       fly + " --world {d}/world.yaml",
       {"world.yaml", "wind"}},
      // ---- fly command line ----
      {"fly_negative_seed", "", "", fly + " --seed -5", {"--seed", "-5"}},
      {"fly_set_unknown", "", "", fly + " --set v_dez=3", {"--set", "v_dez"}},
      {"fly_set_out_of_range", "", "", fly + " --set n_pol=1000", {"--set", "n_pol", "1000"}},
      {"fly_out_is_file",
       "afile",
       "x",
       "fly --layout {d}/saved.yaml --out {d}/afile --no-plot",
       {"afile", "--out", "not a directory"}},
      // ---- study file ----
      {"study_duplicate_key",
       "bad.yaml",
       Edit(study, "seed: 4\n", "seed: 4\nseed: 5\n"),
       study_run,
       {"bad.yaml", "seed", "twice"}},
      {"study_unknown_key",
       "bad.yaml",
       study + "stagez: []\n",
       study_run,
       {"bad.yaml", "stagez", "unknown key"}},
      {"study_set_key_typo",
       "bad.yaml",
       study,
       study_run + " --set validaton.flights=2",
       {"] --set: validaton: unknown key", "--set validaton.flights=2"}},
      {"study_set_override_typo",
       "bad.yaml",
       study,
       study_run + " --set override.budgt.flights=3",
       {"] --set: budgt: unknown key", "budget", "--set override.budgt.flights=3"}},
      {"study_labels_mismatch",
       "bad.yaml",
       Edit(study, "labels: [two, four]", "labels: [two]"),
       study_run,
       {"bad.yaml", "sweep.labels"}},
      {"study_validation_negative",
       "bad.yaml",
       Edit(study, "validation: {flights: 1}", "validation: {flights: -1}"),
       study_run,
       {"bad.yaml", "validation.flights", "-1"}},
      {"study_experiment_missing",
       "bad.yaml",
       Edit(study, "experiment: toy.yaml", "experiment: none.yaml"),
       study_run,
       {"none.yaml"}},
      {"study_override_box_outside",
       "bad.yaml",
       Edit(study, "override: {budget: {flights: 2}}", "override: {budget: {flights: 0}}"),
       study_run,
       {"budget.flights", "0"}},
      // ---- adaptation experiment ----
      {"adapt_duplicate_key",
       "bad.yaml",
       Edit(adapt, "seed: 3\n", "seed: 3\nseed: 9\n"),
       adapt_run,
       {"bad.yaml", "seed", "twice"}},
      {"adapt_bounds_inverted",
       "bad.yaml",
       Edit(adapt, "v_des_bounds: [1.0, 6.0]", "v_des_bounds: [6.0, 1.0]"),
       adapt_run,
       {"bad.yaml", "v_des_bounds"}},
      {"adapt_unknown_key",
       "bad.yaml",
       adapt + "baseline: [1.0]\n",
       adapt_run,
       {"bad.yaml", "baseline", "unknown key"}},
      {"adapt_trials_zero",
       "bad.yaml",
       Edit(adapt, "trials_per_segment: 4", "trials_per_segment: 0"),
       adapt_run,
       {"bad.yaml", "adaptation.trials_per_segment", "0"}},
      {"adapt_set_key_typo",
       "bad.yaml",
       adapt,
       adapt_run + " --set adaptation.trials_per_segmnt=3",
       {"] --set: adaptation.trials_per_segmnt: unknown key", "trials_per_segment",
        "--set adaptation.trials_per_segmnt=3"}},
      {"adapt_negative_seed_cli",
       "",
       "",
       "adapt {d}/ad.yaml --out {d}/out --no-plot --seed -3",
       {"--seed", "-3"}},
      // ---- run command line and result directory ----
      {"run_out_is_file",
       "afile",
       "x",
       "run {d}/toy.yaml --out {d}/afile --quiet",
       {"afile", "--out", "not a directory"}},
      {"run_threads_zero",
       "",
       "",
       "run {d}/toy.yaml --out {d}/out --threads 0",
       {"--threads", "0"}},
      {"run_resume_without_store",
       "",
       "",
       "run {d}/toy.yaml --out {d}/sub --resume --quiet",
       {"results.sqlite", "--resume"}},
      {"run_resume_garbage_store",
       "used/results.sqlite",
       std::string(3000, 'x'),
       "run {d}/toy.yaml --out {d}/used --resume --quiet",
       {"used/results.sqlite", "--resume"}},
      {"run_resume_truncated_store",
       "used/results.sqlite",
       "SQLite format 3",
       "run {d}/toy.yaml --out {d}/used --resume --quiet",
       {"used/results.sqlite", "--resume"}},
      {"run_into_used_dir",
       "used/results.sqlite",
       "not touched",
       "run {d}/toy.yaml --out {d}/used --quiet",
       {"used", "--out", "--resume", "--overwrite"}},
      {"run_resume_and_overwrite",
       "",
       "",
       "run {d}/toy.yaml --out {d}/out --resume --overwrite",
       {"--overwrite", "--resume"}},
      {"export_missing_store", "", "", "export {d}/none.sqlite --csv {d}/csv", {"none.sqlite"}},
      // A name the system cannot look up (a component past 255 bytes) is not a crash.
      {"export_store_name_too_long",
       "",
       "",
       "export {d}/" + std::string(300, 'n') + ".sqlite --csv {d}/csv",
       {"nnnn.sqlite", "no such results file"}},
      {"sweep_out_is_file",
       "afile",
       "x",
       "sweep {d}/toy.yaml --out {d}/afile --points 2 --no-plot",
       {"afile", "--out", "not a directory"}},
      {"sweep_resume_without_a_journal",
       "notes.txt",
       "x",
       "sweep {d}/toy.yaml --out {d} --points 2 --no-plot --resume",
       {"--resume", "holds no sweep to continue"}},
      {"plot_run_without_a_store",
       "notes.txt",
       "x",
       "plot run {d}",
       {"DIR", "holds no results.sqlite", "quadtune run"}},
      {"plot_study_without_a_study",
       "notes.txt",
       "x",
       "plot study {d}",
       {"DIR", "holds no study.json", "quadtune study"}},
      {"sweep_out_name_too_long",
       "",
       "",
       "sweep {d}/toy.yaml --out {d}/" + std::string(300, 'o') + " --points 2 --no-plot",
       {"oooo", "--out", "cannot create the directory"}},
  };
  return c;
}

/// Every path under `dir`, relative, except the lock file a refused run may leave.
std::set<std::string> Listing(const fs::path& dir) {
  std::set<std::string> out;
  for (const auto& e : fs::recursive_directory_iterator(dir)) {
    if (e.path().filename() == ".quadtune.lock") continue;
    out.insert(fs::relative(e.path(), dir).string());
  }
  return out;
}

std::string Replace(std::string s, const std::string& from, const std::string& to) {
  for (auto at = s.find(from); at != std::string::npos; at = s.find(from, at + to.size())) {
    s.replace(at, from.size(), to);
  }
  return s;
}

void Write(const fs::path& path, const std::string& text) {
  fs::create_directories(path.parent_path());
  std::ofstream(path, std::ios::binary) << text;
}

class MalformedInputs : public ::testing::TestWithParam<Case> {};

TEST_P(MalformedInputs, ExitsNonZeroWithOneLineOnStderrAndNoOutput) {
  const Case& c = GetParam();
  const fs::path dir =
      fs::temp_directory_path() / ("qt_malformed_" + std::to_string(::getpid()) + "_" + c.name);
  fs::remove_all(dir);
  fs::create_directories(dir / "sub");
  // Valid companions that the case's command may name.
  Write(dir / "toy.yaml", kToy);
  Write(dir / "ip.yaml", kIpopt);
  Write(dir / "ad.yaml", kAdapt);
  Write(dir / "drone.yaml", Asset("drones/crazyflie.yaml"));
  Write(dir / "options.yaml", Asset("layouts/forest_thin_1p3.yaml"));
  Write(dir / "saved.yaml", Asset("layouts/forest_1p3_seed1.layout.yaml"));
  if (!c.file.empty()) Write(dir / c.file, c.text);
  ASSERT_EQ(c.text.find("EDIT-NOT-FOUND"), std::string::npos) << c.text;
  const auto before = Listing(dir);
  const std::string store_before =
      fs::exists(dir / "used/results.sqlite") ? ReadText(dir / "used/results.sqlite") : "";

  const std::string cmd = QuadtuneBinary() + " " + Replace(c.args, "{d}", dir.string()) + " > '" +
                          (dir.parent_path() / (dir.filename().string() + ".out")).string() +
                          "' 2> '" +
                          (dir.parent_path() / (dir.filename().string() + ".err")).string() + "'";
  const int status = std::system(cmd.c_str());
  const std::string out = ReadText(dir.parent_path() / (dir.filename().string() + ".out"));
  const std::string err = ReadText(dir.parent_path() / (dir.filename().string() + ".err"));
  ASSERT_TRUE(WIFEXITED(status)) << cmd;
  EXPECT_NE(WEXITSTATUS(status), 0) << cmd << "\nstdout: " << out << "\nstderr: " << err;
  ASSERT_FALSE(err.empty()) << cmd;
  EXPECT_EQ(err.find('\n'), err.size() - 1) << "more than one line on stderr:\n" << err;
  for (const auto& e : c.expect) {
    EXPECT_NE(err.find(e), std::string::npos) << "'" << e << "' not in: " << err;
  }
  EXPECT_EQ(Listing(dir), before) << "the command created output: " << cmd;
  if (!store_before.empty()) {
    EXPECT_EQ(ReadText(dir / "used/results.sqlite"), store_before) << "the old store changed";
  }
  fs::remove_all(dir);
  fs::remove(dir.parent_path() / (dir.filename().string() + ".out"));
  fs::remove(dir.parent_path() / (dir.filename().string() + ".err"));
}

INSTANTIATE_TEST_SUITE_P(AllFileKinds, MalformedInputs, ::testing::ValuesIn(Cases()),
                         [](const ::testing::TestParamInfo<Case>& info) {
                           return info.param.name;
                         });

TEST(MalformedInputs, TableCoversAtLeastSixtyCases) { EXPECT_GE(Cases().size(), 60U); }

// The test planners live in the test program only: the production `quadtune` refuses `toy` and
// `sleep` as unregistered planner types, naming the file and the key and listing the types it
// has, while quadtune_test_cli (QuadtuneBinary()) runs the same file.
TEST(MalformedInputs, ProductionProgramHasNoTestPlanners) {
  const fs::path dir =
      fs::temp_directory_path() / ("qt_malformed_" + std::to_string(::getpid()) + "_production");
  fs::remove_all(dir);
  fs::create_directories(dir);
  Write(dir / "toy.yaml", kToy);
  Write(dir / "sleep.yaml",
        Edit(Edit(kToy, "type: toy", "type: sleep"), "  toy: {length: 20, gates: 6}\n", ""));
  for (const std::string type : {"toy", "sleep"}) {
    const fs::path log = dir / (type + ".err");
    const std::string file = (dir / (type + ".yaml")).string();
    const std::string cmd = ProductionQuadtuneBinary() + " run " + file + " --out " +
                            (dir / (type + "_out")).string() + " --quiet 2> '" + log.string() +
                            "'";
    const int status = std::system(cmd.c_str());
    ASSERT_TRUE(WIFEXITED(status)) << cmd;
    EXPECT_EQ(WEXITSTATUS(status), 2) << cmd << "\n" << ReadText(log);
    const std::string err = ReadText(log);
    EXPECT_EQ(err.find('\n'), err.size() - 1) << err;
    for (const std::string& expect : std::vector<std::string>{
             file, "planner.type", "unknown planner type '" + type + "'", "registered: ", "ego",
             "ipopt"}) {
      EXPECT_NE(err.find(expect), std::string::npos) << "'" << expect << "' not in: " << err;
    }
    const std::string registered = err.substr(err.find("registered: "));
    EXPECT_EQ(registered.find("toy"), std::string::npos) << err;
    EXPECT_EQ(registered.find("sleep"), std::string::npos) << err;
    EXPECT_FALSE(fs::exists(dir / (type + "_out") / "results.sqlite"));
  }
  EXPECT_EQ(RunQuadtune("run " + (dir / "toy.yaml").string() + " --out " +
                            (dir / "test_cli_out").string() + " --quiet",
                        dir / "test_cli.log"),
            0)
      << ReadText(dir / "test_cli.log");
  fs::remove_all(dir);
}

}  // namespace
}  // namespace quadtune::test
