#include <spdlog/spdlog.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "commands.hpp"
#include "program_paths.hpp"
#include "quadtune/common/error.hpp"
#include "quadtune/common/text_file.hpp"
#include "quadtune/engine/experiment/experiment.hpp"

namespace quadtune::cli {

std::string AssetPath(const std::string& relative) {
  for (const std::string& dir : engine::AssetDirs()) {
    const std::string path = (std::filesystem::path(dir) / relative).string();
    if (PathExists(path)) return path;
  }
  return relative;
}

int RunPythonScript(const std::string& script_in_source, const char* override_env,
                    const std::string& args) {
  namespace fs = std::filesystem;
  const std::string script = ScriptPath(script_in_source, override_env);
  // An installed program's scripts import the installed package quadtune (program_paths.hpp).
  std::string python_path;
  if (!InstallPrefix().empty()) {
    python_path = "PYTHONPATH='" + PythonPackageDir() + "'\"${PYTHONPATH:+:$PYTHONPATH}\" ";
  }
  // Debian's interpreter, which has python3-matplotlib; a python3 earlier on PATH may not.
  const std::string python = PathExists("/usr/bin/python3") ? "/usr/bin/python3" : "python3";
  // The script's stderr goes to a file: on failure its last line (a traceback's "Error: why")
  // is the one line shown; the whole text is in the debug log.
  char errors[] = "/tmp/quadtune_script_XXXXXX";
  const int fd = mkstemp(errors);
  if (fd >= 0) close(fd);
  const std::string command = python_path + python + " '" + script + "' " + args +
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

/// A `plot` sub-command that hands one input (a directory or a file) and an optional --out to
/// the figure script's sub-command of the same name.
struct SingleInputPlot {
  const char* name;
  const char* help;
  const char* input_name;  ///< DIR or CSV
  const char* input_help;
  const char* out_help;
  bool input_is_file;  ///< false: a directory
  const char* must_hold = nullptr;  ///< a file the directory must hold (refused before plotting)
};

constexpr SingleInputPlot kSingleInputPlots[] = {
    {"flight", "top-down figure of a flight directory", "DIR",
     "directory written by `quadtune fly`", "figure (PNG; default: DIR/flight_topdown.png)", false},
    {"run", "figures and table of a tuning run (`quadtune run` output)", "DIR",
     "directory holding results.sqlite", "output folder (default: DIR)", false, "results.sqlite"},
    {"study", "figures and tables of a study (`quadtune study` output)", "DIR",
     "directory holding study.json", "output folder (default: DIR)", false, "study.json"},
    {"bench", "thread-scaling figure of `quadtune bench --csv` output", "CSV",
     "CSV written by `quadtune bench --csv`", "figure (PNG; default: next to the CSV)", true},
    {"adapt", "velocity along the path and top-down view of a `quadtune adapt` directory", "DIR",
     "directory written by `quadtune adapt`", "figure (PNG; default: DIR/adapt.png)", false},
};

void AddSingleInputPlot(CLI::App& plot, const SingleInputPlot& spec, int& exit_code) {
  // The parsed values live as long as the program (CLI11 keeps pointers to them).
  static std::vector<std::unique_ptr<std::pair<std::string, std::string>>> values;
  auto& value = *values.emplace_back(std::make_unique<std::pair<std::string, std::string>>());
  auto* sub = plot.add_subcommand(spec.name, spec.help);
  sub->add_option(spec.input_name, value.first, spec.input_help)
      ->required()
      ->check(spec.input_is_file ? CLI::Validator(CLI::ExistingFile)
                                 : CLI::Validator(CLI::ExistingDirectory));
  sub->add_option("--out", value.second, spec.out_help);
  sub->callback([&exit_code, &value, name = std::string(spec.name), must_hold = spec.must_hold] {
    if (must_hold != nullptr && !PathExists(value.first + "/" + must_hold)) {
      throw ConfigError(value.first, "DIR",
                        std::string("holds no ") + must_hold + "; give a directory written by "
                        "`quadtune " + name + "`");
    }
    exit_code = RunPlotScript(name + " '" + value.first + "'" + OutArgument(value.second));
  });
}

}  // namespace

void RegisterPlot(CLI::App& app, int& exit_code) {
  auto* cmd = app.add_subcommand("plot", "draw figures (PNG) from quadtune outputs");
  for (const SingleInputPlot& spec : kSingleInputPlots) AddSingleInputPlot(*cmd, spec, exit_code);
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
  cmd->require_subcommand(1);
}

}  // namespace quadtune::cli
