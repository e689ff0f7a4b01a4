#pragma once
/// \file
/// Sub-commands of the `quadtune` program. Each Register* adds its sub-command to the app; the
/// callback runs the command and returns the process exit code through the shared int.

#include <CLI/CLI.hpp>
#include <string>
#include <vector>

#include "quadtune/common/error.hpp"
#include "quadtune/engine/adaptation/online_adaptation.hpp"
#include "quadtune/engine/experiment/experiment.hpp"
#include "quadtune/layout/options.hpp"

namespace quadtune::cli {

/// `quadtune fly`: one closed-loop flight with given parameters, writing its log and figure.
void RegisterFly(CLI::App& app, int& exit_code);
/// `quadtune layout`: generate an obstacle layout and save it.
void RegisterLayout(CLI::App& app, int& exit_code);
/// `quadtune plot`: figures from outputs (matplotlib through Debian's python3).
void RegisterPlot(CLI::App& app, int& exit_code);
/// `quadtune run`: a tuning experiment (engine), results in SQLite (run_command.cpp).
void RegisterRun(CLI::App& app, int& exit_code);
/// `quadtune export`: a results store to CSV.
void RegisterExport(CLI::App& app, int& exit_code);
/// `quadtune bench`: engine throughput at 1..N threads.
void RegisterBench(CLI::App& app, int& exit_code);
/// `quadtune study`: sweeps and stages of an experiment, then validation flights.
void RegisterStudy(CLI::App& app, int& exit_code);
void RegisterAdapt(CLI::App& app, int& exit_code);  ///< `quadtune adapt`: Sec. IV-B experiment
void RegisterPolicy(CLI::App& app, int& exit_code);  ///< `quadtune policy`: learn a context policy
/// `quadtune report`: a self-contained HTML page of a run, study or flight directory.
void RegisterReport(CLI::App& app, int& exit_code);
/// `quadtune sweep`: Sobol' indices of the objectives over the parameter box (sweep_command.cpp).
void RegisterSweep(CLI::App& app, int& exit_code);
/// `quadtune evaluate`: one parameter point flown on an experiment's maps, f_l per flight as CSV.
void RegisterEvaluate(CLI::App& app, int& exit_code);

/// Adds `--no-plot` to `cmd`: given, it sets `plot` to false (a plain flag, so that help shows no
/// default value beside it).
inline void AddNoPlotFlag(CLI::App& cmd, bool& plot, const std::string& help) {
  cmd.add_flag_callback("--no-plot", [&plot] { plot = false; }, help);
}

/// The exit codes every command uses (shown by `quadtune --help`, listed in docs/config.md).
inline constexpr const char* kExitCodes =
    "Exit codes: 0 done; 1 failed while running (a file that cannot be written, a figure script "
    "that failed, an internal error); 2 refused before any work (bad command line, configuration "
    "file or result directory); 3 done, but the outcome is negative (fly: the flight did not "
    "complete; bench --soak: memory not flat); 4 fly --from flew a flight other than the stored "
    "one; 130 interrupted (SIGINT/SIGTERM; the store is "
    "consistent, continue with --resume).";

/// Checks a --seed option: a decimal integer in [0, 2^64), refused with one line otherwise (CLI11
/// would wrap "-5" to 2^64 - 5).
inline CLI::Validator SeedValidator() {
  return CLI::Validator(
      [](std::string& text) -> std::string {
        if (text.empty() || text.find_first_not_of("0123456789") != std::string::npos) {
          return "a seed is a decimal integer >= 0, got '" + text + "'";
        }
        return "";
      },
      "SEED");
}

/// Rethrows `e` (an error about the experiment file) as an error of the --set option, naming
/// the key and keeping what is allowed, when it is an unknown key that an assignment of `sets`
/// (KEY=VALUE) wrote, or a map above it (a typo in a --set key is not the file's fault); returns
/// otherwise (a bad value keeps naming the file and its key).
void BlameSet(const ConfigError& e, const std::vector<std::string>& sets);
/// engine::Experiment::LoadFile(path, sets), errors about a --set key blamed on --set (BlameSet).
engine::Experiment LoadExperiment(const std::string& path, const std::vector<std::string>& sets);
/// The changing-environment experiment `path` with the --set assignments `sets` applied, errors
/// about a --set key blamed on --set (BlameSet).
engine::AdaptExperiment LoadAdaptExperiment(const std::string& path,
                                            const std::vector<std::string>& sets);

/// Runs `script_in_source` (relative to the source tree, or to an installed program's
/// share/quadtune: ScriptPath in program_paths.hpp; $`override_env` names another file) with
/// Debian's python3 and `args`; returns 0 on success, 1 otherwise (logged).
int RunPythonScript(const std::string& script_in_source, const char* override_env,
                    const std::string& args);
/// Runs the figure script with `args`; returns its exit status (0 on success).
int RunPlotScript(const std::string& args);
/// Writes DIR/report.html (`quadtune report DIR --flights N`): a run, study or flight directory;
/// returns 0, or 1 when the page could not be written (logged in one line). Throws ConfigError
/// for a directory that holds no store and no flight.
int WriteReport(const std::string& dir, int flights = 3);
/// What `run` and `study` draw when they end: the figure script with `plot_args` (e.g. "run
/// 'DIR'"), then DIR/report.html. Returns 0, or 1 when either failed (each failure one log line;
/// the results stay).
int DrawFiguresAndReport(const std::string& plot_args, const std::string& dir);
/// The asset folders of `quadtune` (main hands them to engine::SetAssetDirs at start-up):
/// $QUADTUNE_ASSETS when set, then an installed program's share/quadtune/assets, or the source
/// tree's assets/ for the program in the build tree (program_paths.cpp).
std::vector<std::string> ProgramAssetDirs();
/// Path of an asset shipped with the sources (assets/…): the first of engine::AssetDirs() that
/// holds it (else `relative`).
std::string AssetPath(const std::string& relative);
/// The forest the experiments fly at `spacing` (m): assets/layouts/forest_<S>.yaml when one is
/// shipped for that spacing (e.g. forest_1p3.yaml for 1.3), else forest_1p3.yaml with its
/// spacing replaced and its min_gap scaled by the same factor. The layout files are the one source
/// of truth for `fly --spacing` and `layout --spacing`. Throws ConfigError("--spacing", ...) for a
/// spacing its obstacles cannot reach.
layout::LayoutOptions ForestOptions(double spacing);

}  // namespace quadtune::cli
