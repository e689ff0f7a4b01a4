// quadtune: automatic parameter adaptation for online quadrotor trajectory planners.
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <exception>

#include "commands.hpp"
#include "quadtune/common/error.hpp"

int main(int argc, char** argv) {
  CLI::App app{"quadtune — tunes the parameters of online quadrotor trajectory planners "
               "(short-term by PSO, long-term by Bayesian optimisation)"};
  app.set_version_flag("--version", std::string("quadtune ") + QUADTUNE_VERSION);
  app.require_subcommand(1);
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
  quadtune::cli::RegisterStudy(app, exit_code);
  quadtune::cli::RegisterReport(app, exit_code);
  quadtune::cli::RegisterSweep(app, exit_code);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const quadtune::ConfigError& e) {
    spdlog::error("{}", e.what());
    return 2;
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
  return exit_code;
}
