// `quadtune run`, `quadtune export` and `quadtune bench`: the engine's command-line front end.
// Under an MPI launcher with more than one process, `run` spreads the trials over the ranks
// (engine/distributed/distributed.hpp); only rank 0 prints progress and writes OUT.
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "commands.hpp"
#include "eta.hpp"
#include "file_kind.hpp"
#include "limits.hpp"
#include "quadtune/common/cancel.hpp"
#include "quadtune/common/error.hpp"
#include "quadtune/engine/distributed/distributed.hpp"
#include "quadtune/engine/experiment/experiment.hpp"
#include "quadtune/engine/store/column_json.hpp"
#include "quadtune/engine/store/result_store.hpp"
#include "quadtune/engine/tuning/scheduler.hpp"
#include "quadtune/engine/tuning/summary_json.hpp"
#include "quadtune/engine/tuning/tuner.hpp"
#include "result_dir.hpp"
#include "soak.hpp"
#include "stored_flight.hpp"

namespace quadtune::cli {
namespace {

struct RunArgs {
  std::string experiment;
  std::vector<std::string> set;  ///< --set KEY=VALUE edits of the experiment file
  int threads = 0;
  std::string out = "results/run";
  bool resume = false;
  bool overwrite = false;  ///< replace a run already in OUT
  bool quiet = false;
  bool plot = true;  ///< draw the figures and the report when the run has completed
  /// --test-kill-rank R:N (tests of distributed runs, hidden from --help): rank R raises SIGKILL
  /// right after sending the batch that holds its Nth evaluation. "" when not given.
  std::string test_kill_rank;
};

/// The progress line: on a terminal rewritten in place at every update; otherwise (a log file,
/// a cluster job) an info log line at most every 30 s and whenever a trial ends, so long runs
/// show progress without flooding the log. Every other update, and all of them with `quiet`,
/// goes to the debug log. The ETA is the measured cost of the work `eta`'s plan has left
/// (eta.hpp), on a wall clock started here.
std::function<void(const engine::Progress&)> ProgressPrinter(
    bool tty, bool quiet, const std::shared_ptr<EtaEstimator>& eta) {
  using Clock = std::chrono::steady_clock;
  auto last = std::make_shared<Clock::time_point>();
  const Clock::time_point start = Clock::now();
  return [tty, quiet, last, eta, start](const engine::Progress& p) {
    const auto now = Clock::now();
    const double job_s = std::chrono::duration<double>(now - start).count();
    eta->Observe(p, job_s);
    const Eta left = eta->Remaining();
    const bool validation = p.method == "validation";  // the held-out validation after the trials
    std::string line;
    if (validation) {
      line = fmt::format("validation on held-out maps: flights {}/{}, elapsed {:.0f} s, {}",
                         p.flights_done, p.flights_total, job_s, left.Text());
    } else {
      const double rate = p.elapsed_s > 0 ? static_cast<double>(p.short_evals) / p.elapsed_s : 0.0;
      line = fmt::format(
          "trial {}/{} {} r{}{}: flights {}/{}, best f_l {:.3f}, re-solves {} ({:.0f}/s), "
          "elapsed {:.0f} s, {}",
          p.trials_done + 1, p.trials_total, p.method, p.repeat,
          p.rank > 0 ? fmt::format(" (rank {})", p.rank) : std::string(), p.flights_done,
          p.flights_total, p.best_long, p.short_evals, rate, job_s, left.Text());
    }
    spdlog::debug(
        "eta: at {:.2f} s, {:.1f} s left{}, predicted total {:.1f} s; flights {:.0f} of "
        "{:.0f} planned",
        job_s, left.seconds, left.lower_bound ? " (lower bound)" : "", job_s + left.seconds,
        eta->FlightsDone(), eta->FlightsPlanned());
    if (tty) {
      std::fprintf(stderr, "\r\033[K%s", line.c_str());
      std::fflush(stderr);
      return;
    }
    if (!quiet && (p.flights_done == p.flights_total || now - *last >= std::chrono::seconds(30))) {
      *last = now;
      spdlog::info("{}", line);
    } else {
      spdlog::debug("{}", line);
    }
  };
}

/// The plan of the run of `e` on `threads` threads (with its figures and report unless
/// --no-plot), for the progress line's ETA.
std::shared_ptr<EtaEstimator> RunEta(const engine::Experiment& e, int threads, bool plot) {
  WorkPlan plan = WorkPlan::Of(e, threads);
  if (plot) plan.AddDrawing(e, threads, 1);
  return std::make_shared<EtaEstimator>(std::move(plan));
}

/// The end of a run that returned `code`: with --no-plot or after a failure, `code`; else the
/// run's figures and table (`quadtune plot run OUT`) and its browser report (`quadtune report
/// OUT`), announced with their ETA.
int DrawRun(int code, const RunArgs& a, EtaEstimator& eta) {
  if (code != 0 || !a.plot) return code;
  eta.Finished();
  spdlog::info("drawing the figures and the report, {}", eta.Remaining().Text());
  return DrawFiguresAndReport("run '" + a.out + "'", a.out);
}

/// Logs the run's outcome and writes OUT/summary.json; returns the exit code.
int Finish(const engine::RunSummary& s, const RunArgs& a, const std::string& store, bool tty,
           int queries_per_eval) {
  namespace fs = std::filesystem;
  if (tty) std::fprintf(stderr, "\n");
  for (const auto& t : s.trials) {
    spdlog::info(
        "{} repeat {}: best f_l {:.3f} after {} flights, {} θ_s candidates ({} "
        "re-solves), {} failed, {} replayed",
        t.method, t.repeat, t.best_value, t.flights, t.short_evals,
        static_cast<long>(t.short_evals) * queries_per_eval, t.failed, t.replayed);
  }
  for (const auto& v : s.validation) {
    spdlog::info(
        "held-out validation, {}{}: mean f_l {:.3f} over {} maps, {} completed, {} "
        "collision-free, {} emergency stops",
        v.method, v.repeat >= 0 ? fmt::format(" repeat {}", v.repeat) : std::string(), v.mean_value,
        v.flights, v.completed, v.collision_free, v.emergency_stops);
  }
  const nlohmann::json j = engine::SummaryJson(s, queries_per_eval);
  std::ofstream(fs::path(a.out) / "summary.json") << j.dump(1) << '\n';
  if (s.ranks > 1) {
    spdlog::info(
        "{} flights and {} re-solves in {:.1f} s on {} ranks × {} threads ({} pooled "
        "worlds); results in {}",
        s.flights, s.resolves, s.wall_s, s.ranks, s.threads, s.worlds, store);
  } else {
    spdlog::info(
        "{} flights and {} re-solves in {:.1f} s on {} threads ({} pooled worlds); "
        "results in {}",
        s.flights, s.resolves, s.wall_s, s.threads, s.worlds, store);
  }
  if (s.status != engine::RunStatus::kCompleted) {
    std::string sets;
    for (const auto& kv : a.set) sets += " --set '" + kv + "'";
    spdlog::warn(
        "interrupted; the store is consistent. Continue with: quadtune run {} --out {} "
        "--resume{}{}",
        a.experiment, a.out,
        a.threads > 0 ? fmt::format(" --threads {}", a.threads) : std::string(), sets);
    return 130;
  }
  return 0;
}

/// The fault of --test-kill-rank R:N (RunArgs::test_kill_rank): rank R, at its Nth evaluation,
/// says what rank 0 acknowledged and what is in flight, and raises SIGKILL. Off for "".
engine::FaultInjection KillRankFault(const std::string& text) {
  engine::FaultInjection fault;
  if (text.empty()) return fault;
  int r = -1;
  int n = -1;
  char extra = 0;
  if (std::sscanf(text.c_str(), "%d:%d%c", &r, &n, &extra) != 2 || r < 1 || n < 1) {
    throw ConfigError("", "--test-kill-rank",
                      "got '" + text +
                          "', allowed: RANK:N with RANK >= 1 and N >= 1 (that rank raises SIGKILL "
                          "right after sending the batch that holds its Nth evaluation)");
  }
  fault.rank = r;
  fault.after = n;
  fault.trigger = [](const engine::FaultReport& f) {
    std::fprintf(stderr,
                 "quadtune: test hook: rank %d: %ld evaluations acknowledged by rank 0, %ld sent "
                 "in a batch not yet acknowledged (trials %s); raising SIGKILL\n",
                 f.rank, f.acknowledged, f.in_flight, f.trials.c_str());
    std::fflush(stderr);
    std::raise(SIGKILL);
    std::_Exit(137);
  };
  return fault;
}

/// True when process `pid` has ended: /proc has no entry for it, or it is a zombie (state Z or
/// X in /proc/PID/stat).
bool ProcessEnded(long pid) {
  std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
  std::string text;
  if (!std::getline(stat, text)) return true;
  const auto close = text.rfind(')');
  if (close == std::string::npos || close + 2 >= text.size()) return true;
  const char state = text[close + 2];
  return state == 'Z' || state == 'X';
}

/// Ends this rank of a distributed run that ended early (DistributedOptions::on_stop). Rank 0
/// prints the report: after an error, the error, and it ends every rank (MPI_Abort, code 2);
/// after a signal, which rank was lost, the state of the store and how to resume (code 143).
/// Another rank waits to be killed by the runtime (so that rank 0 can tell the lost rank from
/// the stopped ones), and leaves after 10 s (code 143) if it is not.
[[noreturn]] void EndStoppedRank(const engine::MpiSession& mpi, const engine::StopReport& r) {
  if (r.rank != 0) {
    std::this_thread::sleep_for(std::chrono::seconds(10));
    std::_Exit(143);
  }
  if (r.end == engine::DistributedEnd::kFailed) {
    std::fprintf(stderr, "quadtune: error: %s\nquadtune: stopping every rank\n", r.error.c_str());
    std::fflush(stderr);
    mpi.Abort(2);
  }
  std::string lost;
  for (const auto& l : r.lost) {
    lost += (lost.empty() ? "" : ", ") + std::string("rank ") + std::to_string(l.rank) + " (pid " +
            std::to_string(l.pid) + " on " + l.host + ", running " + l.trial + ")";
  }
  if (!lost.empty()) {
    std::fprintf(stderr, "quadtune: %s was lost; the MPI runtime stopped the other ranks.\n",
                 lost.c_str());
  } else {
    std::fprintf(stderr,
                 "quadtune: the run was stopped by a signal (a rank was lost or the job was "
                 "cancelled; the MPI runtime's message names the rank).\n");
  }
  if (!r.store_path.empty()) {
    std::fprintf(stderr,
                 "quadtune: store %s is consistent: %zu evaluations committed (every batch rank "
                 "0 acknowledged is in it), %d of %d trials finished; unfinished trials resume "
                 "from their stored evaluations.\nquadtune: resume with: %s\n",
                 r.store_path.c_str(), r.committed, r.trials_done, r.trials_total,
                 r.resume_command.c_str());
  }
  std::fflush(stderr);
  std::_Exit(143);
}

/// `run` under an MPI launcher with more than one process: every rank takes trials; rank 0
/// stores, reports progress and writes OUT.
int RunMpi(const RunArgs& a, const engine::FaultInjection& fault) {
  engine::MpiSession mpi(&CancelFlag());
  const int rank = mpi.Rank();
  if (rank != 0) spdlog::set_pattern(fmt::format("[%Y-%m-%d %H:%M:%S.%e] [%l] [rank {}] %v", rank));
  namespace fs = std::filesystem;
  const std::string store = (fs::path(a.out) / "results.sqlite").string();
  InstallCancelSignalHandlers();
  try {
    const engine::Experiment e = [&] {
      try {
        return engine::LoadExperimentShared(mpi, a.experiment, a.set);
      } catch (const ConfigError& error) {
        BlameSet(error, a.set);
        throw;
      }
    }();
    CheckThreadsFitAddressSpace(a.threads, e.threads, a.experiment);
    const bool tty = rank == 0 && isatty(fileno(stderr)) != 0 && !a.quiet;
    engine::DistributedOptions options;
    options.run.threads = a.threads;
    options.run.resume = a.resume;
    options.run.cancel = &CancelFlag();
    options.on_stop = [&mpi](const engine::StopReport& r) { EndStoppedRank(mpi, r); };
    options.process_ended = ProcessEnded;
    options.fault = fault;
    std::unique_ptr<ResultDir> dir;
    std::shared_ptr<EtaEstimator> eta;
    if (rank == 0) {
      try {
        dir = std::make_unique<ResultDir>(a.out, ResultDirPolicy{a.resume, a.overwrite, true});
      } catch (const ConfigError& ex) {
        // The other ranks wait for rank 0 in the run: end them all.
        spdlog::error("{}", ex.what());
        mpi.Abort(2);
      }
      options.run.store_path = store;
      eta = RunEta(e, a.threads > 0 ? a.threads : e.threads, a.plot);
      options.run.on_progress = ProgressPrinter(tty, a.quiet, eta);
      std::error_code ec;
      const fs::path self = fs::read_symlink("/proc/self/exe", ec);
      std::string sets;
      for (const auto& kv : a.set) sets += " --set '" + kv + "'";
      options.resume_command = fmt::format(
          "mpirun -np {} {} run {} --out {} --resume{}{}", mpi.Size(),
          ec ? std::string("quadtune") : self.string(), a.experiment, a.out,
          a.threads > 0 ? fmt::format(" --threads {}", a.threads) : std::string(), sets);
      spdlog::info(
          "experiment '{}' ({}): planner {}, methods {}, repeats {}, {} flights per "
          "trial, {} ranks × {} threads, {} mode{}",
          e.name, a.experiment, e.planner.Name(), e.methods.size(), e.repeats, e.budget.flights,
          mpi.Size(), a.threads > 0 ? a.threads : e.threads,
          e.mode == engine::TimingMode::kRealtime ? "realtime" : "reproducible",
          a.resume ? ", resuming" : "");
    }
    const engine::RunSummary s = engine::RunDistributed(mpi, e, options);
    if (rank != 0) return 0;
    return DrawRun(Finish(s, a, store, tty, e.budget.queries_per_eval), a, *eta);
  } catch (const engine::PeerError& ex) {
    // Another rank failed before the run started and reported why; rank 0 says which.
    if (rank == 0) spdlog::error("{}", ex.what());
    return 2;
  } catch (const ConfigError& ex) {
    // Configuration problems are found before the run starts, on every rank at once.
    spdlog::error("{}", ex.what());
    return 2;
  } catch (const std::exception& ex) {
    // Anything else happened on this rank alone: the others cannot finish without it.
    spdlog::error("{}", ex.what());
    mpi.Abort(1);
  }
}

int Run(const RunArgs& a) {
  const engine::FaultInjection fault = KillRankFault(a.test_kill_rank);
  if (const int processes = engine::MpiLaunchSize(); processes > 1) {
    engine::CheckMpiLaunch(processes, engine::MpiBuilt());
    return RunMpi(a, fault);
  }
  // Every configuration error is reported here, before any work starts.
  CheckFileKind(a.experiment, FileKind::kExperiment);
  const engine::Experiment e = LoadExperiment(a.experiment, a.set);
  CheckThreadsFitAddressSpace(a.threads, e.threads, a.experiment);
  namespace fs = std::filesystem;
  const ResultDir dir(a.out, ResultDirPolicy{a.resume, a.overwrite, true});
  const std::string store = (fs::path(a.out) / "results.sqlite").string();
  engine::RunOptions options;
  options.store_path = store;
  options.threads = a.threads;
  options.resume = a.resume;
  options.cancel = &CancelFlag();
  InstallCancelSignalHandlers();
  const bool tty = isatty(fileno(stderr)) != 0 && !a.quiet;
  const int threads = a.threads > 0 ? a.threads : e.threads;
  spdlog::info(
      "experiment '{}' ({}): planner {}, methods {}, repeats {}, {} flights per trial, "
      "{} threads, {} mode{}",
      e.name, a.experiment, e.planner.Name(), e.methods.size(), e.repeats, e.budget.flights,
      threads, e.mode == engine::TimingMode::kRealtime ? "realtime" : "reproducible",
      a.resume ? ", resuming" : "");
  const std::shared_ptr<EtaEstimator> eta = RunEta(e, threads, a.plot);
  options.on_progress = ProgressPrinter(tty, a.quiet, eta);
  engine::RunSummary s;
  try {
    s = engine::RunExperiment(e, options);
  } catch (const Cancelled&) {
    // Cancelled while the maps were generated: the store holds the experiment and no trial.
    s.status = engine::RunStatus::kCancelled;
    s.threads = threads;
  }
  return DrawRun(Finish(s, a, store, tty, e.budget.queries_per_eval), a, *eta);
}

/// Resident set size of this process (MiB), from /proc/self/statm: the pool's memory as the
/// machine sees it, whichever allocator the program uses (mallinfo2 knows only glibc's).
double ResidentMiB() {
  std::ifstream statm("/proc/self/statm");
  long pages_total = 0;
  long pages_resident = 0;
  statm >> pages_total >> pages_resident;
  return static_cast<double>(pages_resident) * static_cast<double>(sysconf(_SC_PAGESIZE)) /
         (1024.0 * 1024.0);
}

struct BenchArgs {
  std::string experiment;
  int max_threads = 2;
  int flights = 4;
  int resolves = 200;
  std::string csv;               ///< "": no CSV; else one row per thread count
  bool plot = false;             ///< draw the thread-scaling figure next to the CSV
  int soak = 0;                  ///< > 0: the soak benchmark (Soak) with this many flights instead
  std::vector<std::string> set;  ///< --set KEY=VALUE edits of the experiment file
};

/// The soak benchmark: `flights` closed-loop flights with the defaults on one map, through one
/// world pool and `threads` workers (as a tuning run flies them), the resident set sampled after
/// every 1 % of the flights. Reports whether memory is flat (within 5 %) after the first 1 000
/// flights (half of them when fewer than 2 000), i.e. whether the pool's reused worlds leak. Exit 0
/// when flat, 3 when not, 130 when interrupted.
int Soak(const engine::Experiment& e, int flights, int threads, const std::string& csv_path) {
  using Clock = std::chrono::steady_clock;
  InstallCancelSignalHandlers();
  const engine::Opaque map = e.planner.PrepareMap(e.MapSeed(0));
  const engine::ParamValues defaults = e.planner.Defaults();
  const int every = std::max(1, flights / 100);
  const int warmup = std::min(1000, std::max(1, flights / 2));
  engine::Scheduler sched(threads);
  engine::WorldPool pool;
  std::mutex mutex;
  std::vector<std::pair<int, double>> samples;  // (flights done, RSS MiB)
  std::atomic<int> done{0};
  const double rss_start = ResidentMiB();
  const auto t0 = Clock::now();
  engine::TaskGroup group;
  // One task per worker, each taking the next flight until all are flown or a signal came: the
  // queue stays `threads` long however many flights are asked for.
  std::atomic<int> next{0};
  const auto fly_next = [&] {
    for (int i = next++; i < flights && !CancelRequested(); i = next++) {
      const engine::WorldPool::Lease slot = pool.Borrow();
      engine::FlightRequest req;
      req.map = map;
      req.params = defaults;
      req.seed = static_cast<std::uint64_t>(i) + 1;
      req.cancelled = [] { return CancelRequested(); };
      (void)e.planner.Fly(req, *slot);
      const int d = ++done;
      if (d % every == 0 || d == flights) {
        const double rss = ResidentMiB();
        const std::lock_guard<std::mutex> lock(mutex);
        samples.emplace_back(d, rss);
      }
    }
  };
  for (int w = 0; w < threads; ++w) sched.Submit(group, engine::Priority::kFlight, fly_next);
  sched.Wait(group);
  const double wall = std::chrono::duration<double>(Clock::now() - t0).count();
  std::sort(samples.begin(), samples.end());
  if (!csv_path.empty()) {
    std::ofstream csv(csv_path);
    if (!csv) throw ConfigError(csv_path, "--csv", "cannot write the file");
    csv << "flights,rss_mib\n";
    for (const auto& [d, rss] : samples) csv << d << ',' << rss << '\n';
  }
  if (CancelRequested()) {
    spdlog::warn("soak interrupted after {} of {} flights", done.load(), flights);
    return 130;
  }
  const SoakVerdict v = JudgeSoak(samples, warmup);
  std::printf("soak: %d flights on %d threads in %.1f s (%.2f flights/s), %d pooled worlds\n",
              flights, threads, wall, flights / wall, pool.Size());
  std::printf(
      "soak: RSS %.1f MiB at start; after %d flights %.1f .. %.1f MiB; median of the first "
      "tenth after warm-up %.1f MiB, of the last %.1f MiB (growth %+.2f %%, largest "
      "tenth %.1f MiB), least-squares trend %+.2f %% over the run: %s\n",
      rss_start, warmup, v.low, v.high, v.first_median, v.last_median, 100.0 * v.growth,
      v.max_median, 100.0 * v.trend, v.flat ? "flat within 5 %" : "NOT flat within 5 %");
  return v.flat ? 0 : 3;
}

/// Flights/s and re-solves/s at 1..N threads, and the scheduler's overhead per task.
// The planning queries one flight at the defaults records on `map`.
std::vector<engine::Opaque> RecordQueries(const engine::Experiment& e, const engine::Opaque& map,
                                          const engine::ParamValues& defaults) {
  std::vector<engine::Opaque> queries;
  engine::WorkerSlot slot;
  engine::FlightRequest req;
  req.map = map;
  req.params = defaults;
  req.seed = 1;
  req.on_query = [&](const engine::Opaque& q) { queries.push_back(q); };
  (void)e.planner.Fly(req, slot);
  return queries;
}

// The bench CSV with its header, or a closed stream when `path` is empty.
std::ofstream OpenBenchCsv(const std::string& path) {
  std::ofstream csv;
  if (path.empty()) return csv;
  const std::filesystem::path parent = std::filesystem::path(path).parent_path();
  if (!parent.empty()) std::filesystem::create_directories(parent);
  csv.open(path);
  if (!csv) throw ConfigError(path, "--csv", "cannot write the file");
  csv << "threads,cores,flights_per_s,resolves_per_s,mixed_s,mixed_speedup,overhead_us,"
         "flights,resolves,experiment\n";
  return csv;
}

// Memory of a world pool: 64 slots, each holding the world a flight built on this map (the
// flights are cancelled at once; the worlds stay in their slots, as in a tuning run).
void PrintPoolMemory(const engine::Experiment& e, const engine::Opaque& map,
                     const engine::ParamValues& defaults) {
  const double before = ResidentMiB();
  std::vector<engine::WorkerSlot> slots(64);
  for (std::size_t i = 0; i < slots.size(); ++i) {
    engine::FlightRequest req;
    req.map = map;
    req.params = defaults;
    req.seed = i;
    req.cancelled = [] { return true; };
    (void)e.planner.Fly(req, slots[i]);
  }
  const double mib = ResidentMiB() - before;
  std::printf("memory of a pool of %zu worlds on this map: %.1f MiB (%.3f MiB per world)\n",
              slots.size(), mib, mib / static_cast<double>(slots.size()));
}

int Bench(const BenchArgs& a) {
  CheckFileKind(a.experiment, FileKind::kExperiment);
  const engine::Experiment e = LoadExperiment(a.experiment, a.set);
  CheckThreadsFitAddressSpace(a.max_threads, "", "--max-threads");
  if (a.soak > 0) return Soak(e, a.soak, a.max_threads, a.csv);
  const engine::Opaque map = e.planner.PrepareMap(e.MapSeed(0));
  const engine::ParamValues defaults = e.planner.Defaults();
  const std::vector<engine::Opaque> queries = RecordQueries(e, map, defaults);
  if (queries.empty()) {
    spdlog::error("the benchmark flight recorded no planning query");
    return 1;
  }
  engine::ParamValues theta_s;
  for (const auto& p : e.planner.ShortTermParameters()) theta_s[p.name] = p.default_value;
  using Clock = std::chrono::steady_clock;
  std::printf("%8s %12s %16s %16s %14s %20s\n", "threads", "flights/s", "re-solves/s",
              "mixed wall (s)", "mixed speed-up", "overhead/task (us)");
  double mixed_one_thread = 0.0;
  std::ofstream csv = OpenBenchCsv(a.csv);
  const unsigned cores = std::thread::hardware_concurrency();
  for (int t = 1; t <= a.max_threads; ++t) {
    engine::Scheduler sched(t);
    engine::WorldPool pool;
    const auto submit_flights = [&](engine::TaskGroup& g) {
      for (int i = 0; i < a.flights; ++i) {
        sched.Submit(g, engine::Priority::kFlight, [&, i] {
          const engine::WorldPool::Lease slot = pool.Borrow();
          engine::FlightRequest req;
          req.map = map;
          req.params = defaults;
          req.seed = static_cast<std::uint64_t>(i);
          (void)e.planner.Fly(req, *slot);
        });
      }
    };
    const auto submit_resolves = [&](engine::TaskGroup& g) {
      for (int i = 0; i < a.resolves; ++i) {
        sched.Submit(g, engine::Priority::kShort, [&, i] {
          (void)e.planner.Resolve(queries[static_cast<std::size_t>(i) % queries.size()], theta_s);
        });
      }
    };
    // Seconds to run what `submit` submits.
    const auto timed = [&](const auto& submit) {
      engine::TaskGroup g;
      const auto t0 = Clock::now();
      submit(g);
      sched.Wait(g);
      return std::chrono::duration<double>(Clock::now() - t0).count();
    };
    const double flights_per_s = a.flights / timed(submit_flights);
    const double resolves_per_s = a.resolves / timed(submit_resolves);
    // The mixed workload of a tuning run: the flights and the re-solves submitted together.
    const double mixed_s = timed([&](engine::TaskGroup& g) {
      submit_flights(g);
      submit_resolves(g);
    });
    if (t == 1) mixed_one_thread = mixed_s;
    double overhead_us = 0.0;
    {
      const int n = 20000;
      engine::TaskGroup g;
      const auto t0 = Clock::now();
      for (int i = 0; i < n; ++i) sched.Submit(g, engine::Priority::kShort, [] {});
      sched.Wait(g);
      overhead_us = 1e6 * std::chrono::duration<double>(Clock::now() - t0).count() / n;
    }
    std::printf("%8d %12.2f %16.1f %16.2f %14.2f %20.2f\n", t, flights_per_s, resolves_per_s,
                mixed_s, mixed_one_thread / mixed_s, overhead_us);
    std::fflush(stdout);
    if (csv.is_open()) {
      csv << t << ',' << cores << ',' << flights_per_s << ',' << resolves_per_s << ',' << mixed_s
          << ',' << mixed_one_thread / mixed_s << ',' << overhead_us << ',' << a.flights << ','
          << a.resolves << ',' << e.name << '\n';
      csv.flush();
    }
  }
  PrintPoolMemory(e, map, defaults);
  if (csv.is_open()) {
    spdlog::info("wrote {}", a.csv);
    if (a.plot) return RunPlotScript("bench '" + a.csv + "'");
  }
  return 0;
}

}  // namespace

void BlameSet(const ConfigError& e, const std::vector<std::string>& sets) {
  const std::string what = e.what();
  if (e.key().empty() || what.find("--set") != std::string::npos) return;
  const auto names = [&e](const std::string& key) {
    return key == e.key() || key.rfind(e.key() + ".", 0) == 0;
  };
  for (const std::string& item : sets) {
    const std::string key = item.substr(0, item.find('='));
    // A study's `override.KEY` reaches its experiment, whose error names KEY.
    const std::string study_override = "override.";
    const bool overrides = key.rfind(study_override, 0) == 0;
    if (!names(key) && !(overrides && names(key.substr(study_override.size())))) continue;
    const std::size_t prefix = (e.file().empty() ? 0 : e.file().size() + 2) + e.key().size() + 2;
    const std::string message = what.size() > prefix ? what.substr(prefix) : what;
    if (message.rfind("unknown key", 0) != 0) return;  // a bad value: the file's key names it
    throw ConfigError("--set", e.key(),
                      message + " (from --set " + item + ", applied to " + e.file() + ")");
  }
}

engine::Experiment LoadExperiment(const std::string& path, const std::vector<std::string>& sets) {
  try {
    return engine::Experiment::LoadFile(path, sets);
  } catch (const ConfigError& e) {
    BlameSet(e, sets);
    throw;
  }
}

void RegisterRun(CLI::App& app, int& exit_code) {
  static RunArgs args;
  auto* cmd = app.add_subcommand("run",
                                 "run a tuning experiment (YAML), store every evaluation "
                                 "in OUT/results.sqlite, then draw its figures, table and "
                                 "OUT/report.html");
  cmd->add_option("experiment", args.experiment, "experiment file (YAML)")->required();
  cmd->add_option("--threads", args.threads, "worker threads (default: the experiment's)")
      ->check(CountIn(1, engine::kMaxThreads, kThreadsWhy));
  cmd->add_option("--out", args.out, "output directory")->capture_default_str();
  cmd->add_flag("--resume", args.resume, "continue the run stored in OUT/results.sqlite");
  cmd->add_flag("--overwrite", args.overwrite,
                "replace the run already stored in OUT (its store, figures and tables)")
      ->excludes("--resume");
  cmd->add_flag("--quiet", args.quiet, "no progress line");
  AddNoPlotFlag(*cmd, args.plot,
                "skip the figures, table and report.html (`quadtune plot run OUT`, `quadtune "
                "report OUT` draw them later)");
  cmd->add_option("--set", args.set,
                  "KEY=VALUE: change the experiment file's dotted KEY, e.g. --set "
                  "budget.flights=10 --set repeats=2 (repeat as needed; --resume needs the same)");
  // For the tests of distributed runs (test/mpi): an empty group keeps it out of --help.
  cmd->add_option("--test-kill-rank", args.test_kill_rank,
                  "R:N: under mpirun, rank R raises SIGKILL right after sending the batch that "
                  "holds its Nth evaluation (tests only)")
      ->group("");
  cmd->callback([&exit_code] { exit_code = Run(args); });
}

void RegisterExport(CLI::App& app, int& exit_code) {
  static std::string store;
  static std::string csv = "results/csv";
  auto* cmd = app.add_subcommand(
      "export", "export a results store to CSV files: experiment.csv, trials.csv and "
                "evaluations.csv in --csv, or the tidy tables in --tidy");
  cmd->add_option("results", store, "results.sqlite")->required();
  static std::string tidy;
  cmd->add_option("--csv", csv,
                  "output directory of experiment.csv, trials.csv and evaluations.csv (the "
                  "stored rows as stored)")
      ->capture_default_str();
  cmd->add_option("--tidy", tidy,
                  "instead: typed tables in this folder, one row per evaluation, one column "
                  "per parameter (params_*) and objective term (terms_*): long_term.csv, "
                  "short_term.csv, and validation.csv, recheck.csv, race.csv, incumbent.csv "
                  "where the store holds such rows");
  cmd->callback([&exit_code] {
    if (!tidy.empty()) {
      std::string files;
      for (const auto& f : WriteTidyCsv(store, tidy)) files += (files.empty() ? "" : ", ") + f;
      spdlog::info("wrote {} in {}", files, tidy);
      exit_code = 0;
      return;
    }
    engine::ResultStore s(store);
    s.ExportCsv(csv);
    spdlog::info("wrote {}/experiment.csv, trials.csv, evaluations.csv", csv);
    exit_code = 0;
  });
}

void RegisterBench(CLI::App& app, int& exit_code) {
  static BenchArgs args;
  auto* cmd = app.add_subcommand("bench",
                                 "flights/s and re-solves/s at 1..N threads, and the "
                                 "scheduler's overhead per task");
  cmd->add_option("experiment", args.experiment,
                  "experiment file (its planner and map), e.g. experiments/tiny.yaml")
      ->required();
  cmd->add_option("--set", args.set,
                  "KEY=VALUE: change the experiment file's dotted KEY "
                  "(repeatable), e.g. --set planner.max_time=20");
  cmd->add_option("--max-threads", args.max_threads, "largest thread count")
      ->capture_default_str()
      ->check(CountIn(1, kMaxBenchThreads, kBenchThreadsWhy));
  cmd->add_option("--flights", args.flights, "flights per thread count")
      ->capture_default_str()
      ->check(CountIn(1, kMaxBenchFlights, kQueuedWhy));
  cmd->add_option("--resolves", args.resolves, "re-solves per thread count")
      ->capture_default_str()
      ->check(CountIn(1, kMaxBenchResolves, kQueuedWhy));
  cmd->add_option("--csv", args.csv, "also write one row per thread count to this CSV file");
  cmd->add_flag("--plot", args.plot, "draw the thread-scaling figure next to the CSV (PNG)");
  cmd->add_option("--soak", args.soak,
                  "instead: N closed-loop flights through one world pool on --max-threads "
                  "threads, resident memory sampled; says whether it stays flat (within 5 %)")
      ->check(CountIn(1, kMaxSoakFlights, kSoakWhy));
  cmd->callback([&exit_code] { exit_code = Bench(args); });
}

}  // namespace quadtune::cli
