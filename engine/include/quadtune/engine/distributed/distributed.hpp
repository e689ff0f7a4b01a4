#pragma once
/// \file
/// Distributed experiments over MPI: `mpirun -np K quadtune run EXPERIMENT.yaml` spreads the
/// trials (method × repeat) of one experiment over K ranks; each rank runs whole trials on its
/// own TrialRunner (its own scheduler threads and world pool).
///
/// Rank 0 owns the SQLite store. Its main thread serves the other ranks: a work queue hands out
/// one trial at a time to a rank that asks (bo_pso trials first, the most expensive, then the
/// experiment's order). A second thread of rank 0 runs trials from the same queue and stores its
/// rows one transaction each, as a single process does. The trial rows are created up front in
/// the single-process order, so trial ids, and in reproducible mode every stored evaluation,
/// equal the single-process run's. On resume, a trial's stored rows travel with its assignment
/// and the rank replays them exactly as a single process does.
///
/// Rows of the other ranks travel in batches (binary, row_codec.hpp): a rank sends its batch
/// when it holds 256 rows, when a row comes 50 ms after the batch's first one, and before any
/// message about its trial (finished, next), and goes on computing. Rank 0 takes every message
/// that has arrived (up to 64), commits their rows in one transaction (InsertBatch), and only
/// then acknowledges each rank's last batch. A rank keeps at most 8 batches unacknowledged and
/// waits for rank 0 beyond that. Guarantees: what rank 0 acknowledged is in the store (a
/// committed SQLite transaction, WAL journal); a row is stored once (the store keeps the first
/// row of a key); a rank that is lost loses only its rows not yet committed, which a resume
/// computes again, as it does for a killed single process.
///
/// Losing a rank: the MPI runtime then stops the others with SIGTERM. Rank 0 hands its caller a
/// StopReport (DistributedOptions::on_stop): which rank was lost (when it ran on rank 0's host
/// and DistributedOptions::process_ended says its process has ended; otherwise mpirun names it),
/// the evaluations committed to the store and the command that resumes the run. The other ranks
/// hand theirs a StopReport too; the `quadtune` program makes them wait to be stopped, so that
/// the lost one can be told apart.
///
/// Waiting never blocks inside MPI (OpenMPI spins there and would take a core from the
/// computing threads): it polls (MPI_Improbe / MPI_Test), a few times back to back and then
/// with sleeps from 20 µs doubling to 1 ms while nothing comes; rank 0 sleeps only when no
/// message is waiting.
///
/// Fault injection (DistributedOptions::fault, for tests): rank `fault.rank` (>= 1), at its
/// `fault.after`th evaluation, waits until rank 0 has acknowledged every earlier batch, sends the
/// batch that holds that evaluation and calls `fault.trigger` with how many evaluations rank 0
/// acknowledged, how many are in flight and the ids of its trials. `quadtune run
/// --test-kill-rank R:N` sets it; its trigger prints the report on stderr and raises SIGKILL
/// before the acknowledgement can arrive.
///
/// Without MPI (QUADTUNE_WITH_MPI=OFF or MPI not found) MpiBuilt() is false and MpiSession's
/// constructor throws.
///
/// Room engine/distributed: its files include engine headers of this room, api, experiment, store
/// and tuning only (scripts/check_rooms.py; docs/design.md, "Architecture").
///
/// Thread safety: MPI is called only from the thread that built the MpiSession
/// (MPI_THREAD_FUNNELED); RunDistributed and LoadExperimentShared must run on it.

#include <atomic>
#include <cstddef>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include "quadtune/engine/experiment/experiment.hpp"
#include "quadtune/engine/tuning/tuner.hpp"

namespace quadtune::engine {

/// True when quadtune was built with MPI.
bool MpiBuilt();

/// The number of processes an MPI launcher started, read from the environment (mpirun/mpiexec:
/// OMPI_COMM_WORLD_SIZE; MPICH and srun --mpi=pmi2: PMI_SIZE; srun: SLURM_STEP_NUM_TASKS when
/// SLURM_PROCID is set); 1 when none did.
int MpiLaunchSize();

/// A quadtune without MPI started as one of several MPI processes would run the whole experiment
/// in each of them, into the same store. Throws ConfigError (key "mpirun": the launch, the
/// process count and how to fix it) when `processes` > 1 and `mpi_built` is false; returns
/// otherwise. `quadtune run` calls it with MpiLaunchSize() and MpiBuilt().
void CheckMpiLaunch(int processes, bool mpi_built);

/// Commands that run in one process (`study`, `adapt`, `sweep`) started as one of several MPI
/// processes would run the whole job in each of them. Throws ConfigError (key "mpirun": the
/// command, the process count, and that only `run` spreads over ranks) when `processes` > 1;
/// returns otherwise. Those commands call it with MpiLaunchSize().
void CheckSingleProcessLaunch(int processes, const std::string& command);

/// Thrown on a rank when another rank failed before the run started (that rank reports why).
class PeerError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// MPI for one `quadtune run`: MPI_Init_thread (FUNNELED) on construction, MPI_Finalize on
/// destruction after every rank got there (waiting without spinning).
class MpiSession {
 public:
  /// Throws std::runtime_error when built without MPI or when MPI cannot start. The session's
  /// own waits (LoadExperimentShared, the barrier before MPI_Finalize) give up once `cancel`
  /// (may be null, e.g. quadtune::CancelFlag()) is set.
  explicit MpiSession(const std::atomic<bool>* cancel = nullptr);
  ~MpiSession();
  MpiSession(const MpiSession&) = delete;
  MpiSession& operator=(const MpiSession&) = delete;

  [[nodiscard]] int Rank() const { return rank_; }
  [[nodiscard]] int Size() const { return size_; }
  /// Host name of this rank.
  [[nodiscard]] const std::string& Host() const { return host_; }
  /// Ends every rank of the job (MPI_Abort) with exit code `code`.
  [[noreturn]] void Abort(int code) const;
  /// The flag the session's waits give up on (may be null).
  [[nodiscard]] const std::atomic<bool>* Cancel() const { return cancel_; }

 private:
  const std::atomic<bool>* cancel_ = nullptr;
  int rank_ = 0;
  int size_ = 1;
  std::string host_;
};

/// Rank 0 reads and checks `path`; the other ranks build the experiment from rank 0's text
/// (relative paths inside resolve against the file's folder on every rank). A collective call.
/// Throws ConfigError on the rank that could not load it and PeerError on the others.
/// `assignments` are `--set` edits (Experiment::LoadFile), applied on rank 0.
Experiment LoadExperimentShared(const MpiSession& mpi, const std::string& path,
                                const std::vector<std::string>& assignments = {});

/// How a distributed run ended early on one rank.
enum class DistributedEnd {
  kStopped,  ///< a signal stopped it (the runtime's SIGTERM after a rank was lost, or the user)
  kFailed,   ///< an error on some rank ended it (StopReport::error says which and why)
};

/// A rank that was lost: its process ended while the run went on.
struct LostRank {
  int rank = 0;
  long pid = 0;
  std::string host;
  std::string trial;  ///< what it ran: "trial METHOD rREPEAT", or "no trial"
};

/// What one rank knows when the run ends before it completes (DistributedOptions::on_stop).
/// Rank 0 fills every field; another rank fills `end`, `rank` and `error`.
struct StopReport {
  DistributedEnd end = DistributedEnd::kStopped;
  int rank = 0;                ///< the rank that reports
  std::vector<LostRank> lost;  ///< rank 0, kStopped: ranks whose process had ended (may be empty)
  std::string store_path;      ///< rank 0: the store ("" when the run has none)
  std::size_t committed = 0;   ///< rank 0: evaluations committed to the store
  int trials_done = 0;         ///< rank 0: trials finished
  int trials_total = 0;
  std::string resume_command;  ///< DistributedOptions::resume_command
  /// kFailed: the error. Rank 0: "rank R: message" (R: the rank it happened on); another rank:
  /// its own error, already sent to rank 0, which ends the job.
  std::string error;
};

/// What the faulting rank knows when its fault is triggered (FaultInjection).
struct FaultReport {
  int rank = 0;
  long acknowledged = 0;  ///< its evaluations rank 0 acknowledged
  long in_flight = 0;     ///< its evaluations in the batch sent and not yet acknowledged
  std::string trials;     ///< ids of the trials it was assigned, e.g. "3,7"
};

/// Fault injection for tests: see the file comment. Off while `rank` or `after` is 0.
struct FaultInjection {
  int rank = 0;   ///< the rank (>= 1) that faults
  int after = 0;  ///< at its Nth evaluation (>= 1)
  /// What the fault does (e.g. raise SIGKILL); the rank goes on if it returns.
  std::function<void(const FaultReport&)> trigger;
};

/// How to run distributed.
struct DistributedOptions {
  /// store_path, resume, on_progress and cancel are used on rank 0 (cancel also on the others:
  /// a rank stops computing when it is set); threads (> 0) is the threads of every rank.
  RunOptions run;
  /// Rank 0's StopReport carries it as the command that resumes the run.
  std::string resume_command;
  /// Called, on the rank concerned, when the run ends early (a signal, or an error that ends the
  /// job) instead of returning; it must end the process and not return: MPI cannot be finalised
  /// (a lost rank leaves the job broken) and rank 0's trial thread is still running. Required.
  /// The `quadtune` program prints rank 0's report and exits with 143 (stopped) or ends every
  /// rank with MPI_Abort (code 2, failed); another rank waits up to 10 s to be stopped by the
  /// runtime, then exits with 143.
  std::function<void(const StopReport&)> on_stop;
  /// Rank 0: true when the process `pid` (of a rank on rank 0's host) has ended; a stopped run
  /// names such ranks as lost. Empty: none is named. The `quadtune` program reads /proc.
  std::function<bool(long pid)> process_ended;
  FaultInjection fault;
};

/// Runs `experiment` over every rank of `mpi` (a collective call). Rank 0 returns the run's
/// summary (every trial; flights, re-solves and worlds of all ranks); other ranks return their
/// share. Problems found before the run starts (e.g. resuming another configuration) throw
/// ConfigError on rank 0 and PeerError on the others. A run that ends early (an error during
/// the run, a signal such as the runtime's SIGTERM when a rank was lost) does not return: each
/// rank hands its StopReport to `options.on_stop`, which ends the process. Throws
/// InvariantError when `options.on_stop` is empty.
RunSummary RunDistributed(const MpiSession& mpi, const Experiment& experiment,
                          const DistributedOptions& options);

}  // namespace quadtune::engine
