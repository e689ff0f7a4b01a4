#pragma once
/// \file
/// Where the `quadtune` program finds the files it does not compile in: the figure and report
/// scripts, the report's JavaScript libraries, the assets (drones, layouts) and the Python
/// package `quadtune` the scripts import.
///
/// A program installed by `cmake --install build --prefix P` runs as P/bin/quadtune and finds
/// them under P: P/share/quadtune/experiments/{plot,report}/, P/share/quadtune/assets and
/// P/<QUADTUNE_INSTALL_PYTHONDIR>/quadtune (its own executable, /proc/self/exe, tells P). The
/// program in the build tree (no P/share/quadtune beside it) finds them in the source tree it was
/// built from. Environment variables override each: $QUADTUNE_PLOT_SCRIPT,
/// $QUADTUNE_REPORT_SCRIPT, $QUADTUNE_REPORT_JS (read by the report script), $QUADTUNE_ASSETS
/// (searched first).
///
/// Thread safety: the functions read the environment and the file system only; call them from
/// the command's thread.

#include <CLI/CLI.hpp>
#include <string>
#include <utility>
#include <vector>

namespace quadtune::cli {

/// P when this program runs as P/<bin>/quadtune from an install (P/share/quadtune exists), ""
/// otherwise (the build tree).
std::string InstallPrefix();

/// The folder the scripts' relative paths start from: P/share/quadtune when installed, else the
/// source tree.
std::string DataRoot();

/// The script at `relative` (e.g. "experiments/plot/quadtune_plot.py") under DataRoot(), or
/// $`override_env` when set.
std::string ScriptPath(const std::string& relative, const char* override_env);

/// The folder that holds the Python package quadtune the scripts import: P/<python dir> when
/// installed, else the source tree's experiments/python.
std::string PythonPackageDir();

/// The report's JavaScript libraries: $QUADTUNE_REPORT_JS when set, else
/// experiments/report/js/node_modules under DataRoot().
std::string ReportJsDir();

/// (name, path) for each of the above and each assets folder (ProgramAssetDirs), as `quadtune
/// paths` prints them.
std::vector<std::pair<std::string, std::string>> ProgramPathLines();

/// `quadtune paths`: prints ProgramPathLines(), "name: path" a line.
void RegisterPaths(CLI::App& app, int& exit_code);

}  // namespace quadtune::cli
