// `quadtune study`: an experiment swept over a setting and/or run in stages, then validation
// flights of the tuned parameters (engine/tuning/study.hpp), with the study's figures and tables.
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "file_kind.hpp"
#include "commands.hpp"
#include "limits.hpp"
#include "eta.hpp"
#include "quadtune/common/cancel.hpp"
#include "quadtune/common/error.hpp"
#include "quadtune/engine/distributed/distributed.hpp"
#include "quadtune/engine/tuning/study.hpp"
#include "result_dir.hpp"

namespace quadtune::cli {
namespace {

struct StudyArgs {
  std::string file;
  std::vector<std::string> set;  ///< --set KEY=VALUE edits of the study file
  std::string out = "results/study";
  int threads = 0;
  bool resume = false;
  bool overwrite = false;
  bool quiet = false;
  bool plot = true;
};

/// The progress line of a study: the point, then its validation flights or its stage's trial.
std::string ProgressLine(const engine::StudyProgress& p, double job_s, const Eta& left) {
  if (p.validating) {
    return fmt::format("point {}/{} ({}): validation flights {}/{}, elapsed {:.0f} s, {}",
                       p.point + 1, p.points, p.label, p.validation_done, p.validation_total, job_s,
                       left.Text());
  }
  return fmt::format(
      "point {}/{} ({}), stage {}: trial {}/{} {} r{}: flights {}/{}, best f_l "
      "{:.3f}, elapsed {:.0f} s, {}",
      p.point + 1, p.points, p.label, p.stage, p.run.trials_done + 1, p.run.trials_total,
      p.run.method, p.run.repeat, p.run.flights_done, p.run.flights_total, p.run.best_long, job_s,
      left.Text());
}

/// OUT/summary.json: the study's status, wall time, flights and re-solves.
void WriteSummary(const engine::StudySummary& s, const std::string& out) {
  nlohmann::json j;
  j["status"] = quadtune::ToString(s.status);
  j["wall_s"] = s.wall_s;
  j["flights"] = s.flights;
  j["resolves"] = s.resolves;
  std::ofstream(std::filesystem::path(out) / "summary.json") << j.dump(1) << '\n';
}

/// engine::Study::LoadFile(path, sets), errors about a --set key blamed on --set (BlameSet).
engine::Study LoadStudy(const std::string& path, const std::vector<std::string>& sets) {
  try {
    return engine::Study::LoadFile(path, sets);
  } catch (const ConfigError& e) {
    BlameSet(e, sets);
    throw;
  }
}

int RunStudyCommand(const StudyArgs& a) {
  engine::CheckSingleProcessLaunch(engine::MpiLaunchSize(), "study");
  CheckFileKind(a.file, FileKind::kStudy);
  const engine::Study study = LoadStudy(a.file, a.set);  // all errors before any work
  if (a.threads > 0) CheckThreadsFitAddressSpace(a.threads, "", "--threads");
  spdlog::info("study '{}' ({}): {} point(s){}, {} stage(s), {} validation flights per tuned trial",
               study.name, a.file, study.labels.size(),
               study.sweep_key.empty() ? "" : " over " + study.sweep_key, study.stages.size(),
               study.validation_flights);
  if (a.resume && !HoldsRun(a.out)) {
    throw ConfigError(a.out, "--resume",
                      "holds no study to continue (no stage store or study.json in it); run "
                      "without --resume to start one");
  }
  const ResultDir dir(a.out, ResultDirPolicy{a.resume, a.overwrite, true});
  engine::StudyOptions options;
  options.out_dir = a.out;
  options.threads = a.threads;
  options.resume = a.resume;
  options.cancel = &CancelFlag();
  InstallCancelSignalHandlers();
  const bool tty = isatty(fileno(stderr)) != 0 && !a.quiet;
  std::string last_stage;
  using Clock = std::chrono::steady_clock;
  const Clock::time_point start = Clock::now();
  WorkPlan plan = WorkPlan::Of(study, a.threads);
  if (a.plot) {
    const engine::Experiment last = study.Build(0, study.stages.size() - 1);
    plan.AddDrawing(last, a.threads > 0 ? a.threads : last.threads,
                    static_cast<int>(study.labels.size() * study.stages.size()));
  }
  EtaEstimator eta(std::move(plan));
  const int stages = static_cast<int>(study.stages.size());
  options.on_progress = [&](const engine::StudyProgress& p) {
    const double job_s = std::chrono::duration<double>(Clock::now() - start).count();
    // The plan numbers the runs point by point, stage by stage (WorkPlan::Of(Study)).
    int stage = stages - 1;
    for (int k = 0; k < stages; ++k) {
      if (study.stages[static_cast<std::size_t>(k)].name == p.stage) stage = k;
    }
    const int run = static_cast<int>(p.point) * stages + stage;
    engine::Progress report = p.run;
    if (p.validating) {
      report = engine::Progress{};
      report.method = "validation";
      report.flights_done = p.validation_done;
      report.flights_total = p.validation_total;
    }
    eta.Observe(report, job_s, run);
    const Eta left = eta.Remaining();
    const std::string line = ProgressLine(p, job_s, left);
    spdlog::debug(
        "eta: at {:.2f} s, {:.1f} s left{}, predicted total {:.1f} s; flights {:.0f} of "
        "{:.0f} planned",
        job_s, left.seconds, left.lower_bound ? " (lower bound)" : "", job_s + left.seconds,
        eta.FlightsDone(), eta.FlightsPlanned());
    if (tty) {
      std::fprintf(stderr, "\r\033[K%s", line.c_str());
      std::fflush(stderr);
    } else {
      // A line per stage, per finished trial and at the end of validation keeps logs short.
      const std::string key = p.label + "/" + p.stage + "/" + p.run.method +
                              std::to_string(p.run.repeat);
      const bool trial_done = p.validating ? p.validation_done == p.validation_total
                                           : p.run.flights_done == p.run.flights_total;
      if (key != last_stage || trial_done) {
        spdlog::info("{}", line);
      } else {
        spdlog::debug("{}", line);
      }
      last_stage = key;
    }
  };
  // The files follow the outcome as it grows, so a study killed on the way keeps those of the
  // points it finished.
  options.on_update = [&a](const engine::StudyOutcome& o) { engine::WriteStudyFiles(o, a.out); };
  engine::StudySummary s;
  try {
    const engine::StudyOutcome outcome = engine::RunStudy(study, options);
    engine::WriteStudyFiles(outcome, a.out);
    s = outcome.summary;
  } catch (const Cancelled&) {
    s.status = engine::RunStatus::kCancelled;  // cancelled while a map was generated
  }
  if (tty) std::fprintf(stderr, "\n");
  WriteSummary(s, a.out);
  spdlog::info("{} flights and {} re-solves in {:.1f} s; results in {}", s.flights, s.resolves,
               s.wall_s, a.out);
  if (s.status != engine::RunStatus::kCompleted) {
    spdlog::warn("interrupted: continue with `quadtune study {} --out {} --resume`", a.file, a.out);
    return 130;
  }
  if (!a.plot) return 0;
  eta.Finished();
  spdlog::info("drawing the figures and the report, {}", eta.Remaining().Text());
  return DrawFiguresAndReport("study '" + a.out + "'", a.out);
}

}  // namespace

void RegisterStudy(CLI::App& app, int& exit_code) {
  static StudyArgs args;
  auto* cmd = app.add_subcommand(
      "study",
      "an experiment swept over a setting and/or run in stages, then validation flights "
      "of the tuned parameters; figures, tables and OUT/report.html");
  cmd->add_option("study", args.file, "study file (YAML)")->required()->check(CLI::ExistingFile);
  cmd->add_option("--out", args.out, "output directory")->capture_default_str();
  cmd->add_option("--threads", args.threads, "worker threads (default: the experiment's)")
      ->check(CountIn(1, engine::kMaxThreads, kThreadsWhy));
  cmd->add_flag("--resume", args.resume, "continue the stages stored in OUT");
  cmd->add_flag("--overwrite", args.overwrite, "replace the study already in OUT")
      ->excludes("--resume");
  cmd->add_flag("--quiet", args.quiet, "no progress line");
  AddNoPlotFlag(*cmd, args.plot, "skip the figures, tables and report.html");
  cmd->add_option("--set", args.set,
                  "KEY=VALUE: change the study file's dotted KEY, e.g. --set "
                  "override.budget.flights=10 --set validation.flights=2 (repeatable)");
  cmd->callback([&exit_code] { exit_code = RunStudyCommand(args); });
}

}  // namespace quadtune::cli
