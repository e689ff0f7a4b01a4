#include "program_paths.hpp"

#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <system_error>

#include "commands.hpp"

// QUADTUNE_INSTALL_BINDIR, _DATADIR and _PYTHONDIR (the install layout, relative to the prefix)
// are set by cmake/QuadtuneInstall.cmake, QUADTUNE_SOURCE_DIR by experiments/CMakeLists.txt.

namespace quadtune::cli {
namespace {

namespace fs = std::filesystem;

/// P for an executable at P/<QUADTUNE_INSTALL_BINDIR>/NAME: one folder up per component of the
/// (relative) bin folder; "" when that folder is absolute.
fs::path PrefixOf(const fs::path& executable) {
  const fs::path bindir(QUADTUNE_INSTALL_BINDIR);
  if (bindir.is_absolute()) return {};
  fs::path prefix = executable.parent_path();
  for (const auto& part : bindir) {
    if (!part.empty() && part != ".") prefix = prefix.parent_path();
  }
  return prefix;
}

fs::path InstalledData(const fs::path& prefix) {
  return prefix / QUADTUNE_INSTALL_DATADIR / "quadtune";
}

}  // namespace

std::string InstallPrefix() {
  std::error_code error;
  const fs::path exe = fs::read_symlink("/proc/self/exe", error);
  if (error || exe.empty()) return {};
  const fs::path prefix = PrefixOf(exe);
  if (prefix.empty() || !fs::is_directory(InstalledData(prefix), error)) return {};
  return prefix.string();
}

std::string DataRoot() {
  const std::string prefix = InstallPrefix();
  return prefix.empty() ? std::string(QUADTUNE_SOURCE_DIR) : InstalledData(prefix).string();
}

std::string ScriptPath(const std::string& relative, const char* override_env) {
  if (const char* env = std::getenv(override_env)) return env;
  return (fs::path(DataRoot()) / relative).string();
}

std::string PythonPackageDir() {
  const std::string prefix = InstallPrefix();
  if (prefix.empty()) return (fs::path(QUADTUNE_SOURCE_DIR) / "experiments" / "python").string();
  return (fs::path(prefix) / QUADTUNE_INSTALL_PYTHONDIR).string();
}

std::string ReportJsDir() {
  if (const char* env = std::getenv("QUADTUNE_REPORT_JS")) return env;
  return (fs::path(DataRoot()) / "experiments" / "report" / "js" / "node_modules").string();
}

std::vector<std::string> ProgramAssetDirs() {
  std::vector<std::string> dirs;
  if (const char* env = std::getenv("QUADTUNE_ASSETS")) dirs.emplace_back(env);
  dirs.push_back((fs::path(DataRoot()) / "assets").string());
  return dirs;
}

std::vector<std::pair<std::string, std::string>> ProgramPathLines() {
  const std::string prefix = InstallPrefix();
  std::vector<std::pair<std::string, std::string>> lines = {
      {"prefix",
       prefix.empty() ? "(none: the build tree's program, files from the source tree)" : prefix},
      {"plot_script", ScriptPath("experiments/plot/quadtune_plot.py", "QUADTUNE_PLOT_SCRIPT")},
      {"report_script",
       ScriptPath("experiments/report/quadtune_report.py", "QUADTUNE_REPORT_SCRIPT")},
      {"report_js", ReportJsDir()},
      {"python_package", PythonPackageDir()}};
  for (const std::string& dir : ProgramAssetDirs()) lines.emplace_back("assets", dir);
  return lines;
}

void RegisterPaths(CLI::App& app, int& exit_code) {
  auto* cmd = app.add_subcommand(
      "paths",
      "print where this program finds its figure and report scripts, the report's JavaScript "
      "libraries, the Python package quadtune and the assets (installed: under the prefix)");
  cmd->callback([&exit_code] {
    for (const auto& [name, path] : ProgramPathLines()) std::cout << name << ": " << path << "\n";
    exit_code = 0;
  });
}

}  // namespace quadtune::cli
