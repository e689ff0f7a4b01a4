#include <spdlog/spdlog.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "commands.hpp"

namespace quadtune::cli {

std::string AssetPath(const std::string& relative) {
  namespace fs = std::filesystem;
  if (const char* env = std::getenv("QUADTUNE_ASSETS")) {
    if (fs::exists(fs::path(env) / relative)) return (fs::path(env) / relative).string();
  }
  const fs::path in_tree = fs::path(QUADTUNE_SOURCE_DIR) / "assets" / relative;
  if (fs::exists(in_tree)) return in_tree.string();
  return relative;
}

int RunPythonScript(const std::string& script_in_source, const char* override_env,
                    const std::string& args) {
  namespace fs = std::filesystem;
  std::string script = (fs::path(QUADTUNE_SOURCE_DIR) / script_in_source).string();
  if (const char* env = std::getenv(override_env)) script = env;
  // Debian's interpreter, which has python3-matplotlib; a python3 earlier on PATH may not.
  const std::string python = fs::exists("/usr/bin/python3") ? "/usr/bin/python3" : "python3";
  // The script's stderr goes to a file: on failure its last line (a traceback's "Error: why")
  // is the one line shown; the whole text is in the debug log.
  char errors[] = "/tmp/quadtune_script_XXXXXX";
  const int fd = mkstemp(errors);
  if (fd >= 0) close(fd);
  const std::string command = python + " '" + script + "' " + args +
                              (fd >= 0 ? std::string(" 2>'") + errors + "'" : std::string());
  spdlog::debug("running {}", command);
  const int status = std::system(command.c_str());
  std::string text;  // the script's stderr
  std::string why;   // its last line that is not blank
  if (fd >= 0) {
    {
      std::ifstream in(errors);
      for (std::string line; std::getline(in, line);) {
        text += line + '\n';
        if (line.find_first_not_of(" \t\r") != std::string::npos) why = line;
      }
    }
    fs::remove(errors);
  }
  if (status == 0) {
    if (!text.empty()) std::fputs(text.c_str(), stderr);  // warnings of a script that worked
    return 0;
  }
  if (!text.empty()) spdlog::debug("{} stderr:\n{}", script_in_source, text);
  const std::size_t lead = why.find_first_not_of(' ');
  why = lead == std::string::npos ? fmt::format("exit status {}", status) : why.substr(lead);
  spdlog::error("{} failed: {} (the script's whole output: --log-level debug)",
                fs::path(script).filename().string(), why);
  return 1;
}

int RunPlotScript(const std::string& args) {
  return RunPythonScript("experiments/plot/quadtune_plot.py", "QUADTUNE_PLOT_SCRIPT", args);
}

namespace {

/// " --out 'PATH'" for the figure script, or "" when no --out was given.
std::string OutArgument(const std::string& out) {
  return out.empty() ? std::string() : " --out '" + out + "'";
}

}  // namespace

void RegisterPlot(CLI::App& app, int& exit_code) {
  auto* cmd = app.add_subcommand("plot", "draw figures (PNG) from quadtune outputs");
  auto* flight = cmd->add_subcommand("flight", "top-down figure of a flight directory");
  static std::string dir;
  flight->add_option("DIR", dir, "directory written by `quadtune fly`")->required()->check(
      CLI::ExistingDirectory);
  static std::string flight_out;
  flight->add_option("--out", flight_out, "figure (PNG; default: DIR/flight_topdown.png)");
  flight->callback([&exit_code] {
    exit_code = RunPlotScript("flight '" + dir + "'" + OutArgument(flight_out));
  });
  auto* run = cmd->add_subcommand("run", "figures and table of a tuning run (`quadtune run` output)");
  static std::string run_dir;
  run->add_option("DIR", run_dir, "directory holding results.sqlite")->required()->check(
      CLI::ExistingDirectory);
  static std::string run_out;
  run->add_option("--out", run_out, "output folder (default: DIR)");
  run->callback([&exit_code] {
    exit_code = RunPlotScript("run '" + run_dir + "'" + OutArgument(run_out));
  });
  auto* study = cmd->add_subcommand("study", "figures and tables of a study (`quadtune study` output)");
  static std::string study_dir;
  study->add_option("DIR", study_dir, "directory holding study.json")->required()->check(
      CLI::ExistingDirectory);
  static std::string study_out;
  study->add_option("--out", study_out, "output folder (default: DIR)");
  study->callback([&exit_code] {
    exit_code = RunPlotScript("study '" + study_dir + "'" + OutArgument(study_out));
  });
  auto* bench = cmd->add_subcommand("bench", "thread-scaling figure of `quadtune bench --csv` output");
  static std::string bench_csv;
  static std::string bench_out;
  bench->add_option("CSV", bench_csv, "CSV written by `quadtune bench --csv`")->required()->check(
      CLI::ExistingFile);
  bench->add_option("--out", bench_out, "figure (PNG; default: next to the CSV)");
  bench->callback([&exit_code] {
    exit_code = RunPlotScript("bench '" + bench_csv + "'" + OutArgument(bench_out));
  });
  auto* flights = cmd->add_subcommand("flights", "summary figures and table of several flights");
  static std::vector<std::string> dirs;
  static std::string out;
  flights->add_option("DIRS", dirs, "directories written by `quadtune fly`")->required()->check(
      CLI::ExistingDirectory);
  flights->add_option("--out", out, "output directory")->required();
  flights->callback([&exit_code] {
    std::string args = "flights --out '" + out + "'";
    for (const auto& d : dirs) args += " '" + d + "'";
    exit_code = RunPlotScript(args);
  });
  auto* adapt = cmd->add_subcommand("adapt", "velocity along the path and top-down view of a "
                                             "`quadtune adapt` directory");
  static std::string adapt_dir;
  adapt->add_option("DIR", adapt_dir, "directory written by `quadtune adapt`")->required()->check(
      CLI::ExistingDirectory);
  static std::string adapt_out;
  adapt->add_option("--out", adapt_out, "figure (PNG; default: DIR/adapt.png)");
  adapt->callback([&exit_code] {
    exit_code = RunPlotScript("adapt '" + adapt_dir + "'" + OutArgument(adapt_out));
  });
  cmd->require_subcommand(1);
}

}  // namespace quadtune::cli
