// quadtune: automatic parameter adaptation for online quadrotor trajectory planners.
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <exception>
#include <filesystem>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "commands.hpp"
#include "config_reference.hpp"
#include "limits_reference.hpp"
#include "program_paths.hpp"
#include "quadtune/common/error.hpp"
#include "quadtune/engine/experiment/experiment.hpp"

namespace {

/// Log lines at warning level and above go to stderr, the others to stdout, so that a caller
/// that keeps stdout (e.g. a table) still sees every problem on stderr.
class SplitSink final : public spdlog::sinks::sink {
 public:
  void log(const spdlog::details::log_msg& msg) override {
    (msg.level >= spdlog::level::warn ? err_ : out_)->log(msg);
  }
  void flush() override {
    out_->flush();
    err_->flush();
  }
  void set_pattern(const std::string& pattern) override {
    out_->set_pattern(pattern);
    err_->set_pattern(pattern);
  }
  void set_formatter(std::unique_ptr<spdlog::formatter> formatter) override {
    out_->set_formatter(formatter->clone());
    err_->set_formatter(std::move(formatter));
  }

 private:
  std::shared_ptr<spdlog::sinks::sink> out_ =
      std::make_shared<spdlog::sinks::stdout_color_sink_mt>();
  std::shared_ptr<spdlog::sinks::sink> err_ =
      std::make_shared<spdlog::sinks::stderr_color_sink_mt>();
};

/// An error message as one line (line breaks inside it become spaces).
std::string OneLine(std::string text) {
  std::replace(text.begin(), text.end(), '\n', ' ');
  std::replace(text.begin(), text.end(), '\r', ' ');
  return text;
}

/// Edits (insertions, deletions, substitutions) between `a` and `b`.
std::size_t EditDistance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = up;
    }
  }
  return row[b.size()];
}

/// "; did you mean --X?" for each unexpected option of the command line that is near a long
/// option of the command given (the deepest one parsed) or of its parents: a prefix of it or at
/// most two edits away; "" when none is.
std::string Suggestions(const CLI::App* app) {
  const CLI::App* command = app;
  while (true) {
    const auto used = command->get_subcommands();
    if (used.empty()) break;
    command = used.front();
  }
  std::string out;
  for (const std::string& extra : app->remaining(true)) {
    if (extra.rfind("--", 0) != 0 || extra.size() < 4) continue;
    const std::string given = extra.substr(2, extra.find('=') - 2);
    std::string best;
    std::size_t best_distance = 3;
    for (const CLI::App* c = command; c != nullptr; c = c->get_parent()) {
      for (const CLI::Option* o : c->get_options()) {
        for (const std::string& name : o->get_lnames()) {
          const std::size_t d = name.rfind(given, 0) == 0 ? 0 : EditDistance(given, name);
          if (d < best_distance) best = name, best_distance = d;
        }
      }
    }
    if (!best.empty()) out += "; did you mean --" + best + " instead of " + extra + "?";
  }
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  // Drone and layout files named in experiments are found in these folders (ResolvePath).
  quadtune::engine::SetAssetDirs(quadtune::cli::ProgramAssetDirs());
  spdlog::set_default_logger(std::make_shared<spdlog::logger>("", std::make_shared<SplitSink>()));
  CLI::App app{"quadtune — tunes the parameters of online quadrotor trajectory planners "
               "(short-term by PSO, long-term by Bayesian optimisation)"};
  app.set_version_flag("--version", std::string("quadtune ") + QUADTUNE_VERSION);
  app.require_subcommand(1);
  // A malformed command line is one line on stderr, like every other error.
  app.failure_message([](const CLI::App* failed, const CLI::Error& e) {
    const std::string near = dynamic_cast<const CLI::ExtrasError*>(&e) ? Suggestions(failed) : "";
    return "quadtune: " + OneLine(e.what()) + near + " (see quadtune --help)\n";
  });
  std::string log_level = "info";
  app.add_option("--log-level", log_level, "log level: trace, debug, info, warn, error, off")
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error", "off"}));
  app.parse_complete_callback([&] { spdlog::set_level(spdlog::level::from_str(log_level)); });

  int exit_code = 0;
  quadtune::cli::RegisterFly(app, exit_code);
  quadtune::cli::RegisterLayout(app, exit_code);
  quadtune::cli::RegisterPlot(app, exit_code);
  quadtune::cli::RegisterRun(app, exit_code);
  quadtune::cli::RegisterExport(app, exit_code);
  quadtune::cli::RegisterBench(app, exit_code);
  quadtune::cli::RegisterAdapt(app, exit_code);
  quadtune::cli::RegisterPolicy(app, exit_code);
  quadtune::cli::RegisterStudy(app, exit_code);
  quadtune::cli::RegisterReport(app, exit_code);
  quadtune::cli::RegisterSweep(app, exit_code);
  quadtune::cli::RegisterEvaluate(app, exit_code);
  quadtune::cli::RegisterConfigReference(app, exit_code);
  quadtune::cli::RegisterLimitsReference(app, exit_code);
  quadtune::cli::RegisterPaths(app, exit_code);
  // Every command's --help, nested ones (plot run, …) included, ends with the exit codes.
  const std::function<void(CLI::App*)> add_footer = [&add_footer](CLI::App* command) {
    command->footer(quadtune::cli::kExitCodes);
    for (CLI::App* sub : command->get_subcommands({})) add_footer(sub);
  };
  add_footer(&app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help and --version exit 0; a malformed command line is refused like a bad file (2).
    return app.exit(e) == 0 ? 0 : 2;
  } catch (const quadtune::ConfigError& e) {
    spdlog::error("{}", OneLine(e.what()));
    return 2;
  } catch (const std::filesystem::filesystem_error& e) {
    // A path the program could not create or write: name it and the reason.
    spdlog::error("{}: {}", e.path1().string(), OneLine(e.code().message()));
    return 1;
  } catch (const std::exception& e) {
    spdlog::error("{}", OneLine(e.what()));
    return 1;
  }
  return exit_code;
}
