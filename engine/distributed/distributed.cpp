// Distributed experiments over MPI (see distributed.hpp): rank 0 serves a work queue of trials
// and owns the SQLite store, the other ranks run the trials they are handed and forward their
// rows in batches. Rows travel in the binary form of row_codec.hpp, control messages as JSON
// texts; doubles travel as their bit patterns either way, so they arrive exactly.
// Without MPI (no QUADTUNE_HAVE_MPI) only MpiLaunchSize() and CheckMpiLaunch() work and the rest
// reports that quadtune was built without MPI.
//
// Thread safety: MPI runs on the thread that built the MpiSession only; on rank 0 a second
// thread runs trials and reaches the store through LockedStore.
//
// Debian's sequential MUMPS (linked through Ipopt) exports dummy MPI_Init, MPI_Comm_rank,
// MPI_Finalize and MPI_Wtime, which can shadow MPI's own (every rank would be rank 0). Those four
// are called here through their PMPI_ names, which only the MPI library defines.
#include "quadtune/engine/distributed/distributed.hpp"
#include "quadtune/engine/tuning/validation.hpp"

#include <cstdlib>
#include <string>

#include "quadtune/common/error.hpp"

#if defined(QUADTUNE_HAVE_MPI)
#include <mpi.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <chrono>
#include <climits>
#include <cstdint>
#include <deque>
#include <filesystem>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <thread>
#include <tuple>
#include <utility>
#include <vector>

#include "quadtune/engine/store/column_json.hpp"
#include "quadtune/engine/store/result_store.hpp"
#include "quadtune/engine/store/row_codec.hpp"
#endif

namespace quadtune::engine {
namespace {

/// A positive integer from the environment, 0 when unset or not one.
int EnvCount(const char* name) {
  const char* text = std::getenv(name);
  if (text == nullptr || *text == '\0') return 0;
  char* end = nullptr;
  const long n = std::strtol(text, &end, 10);
  return (*end == '\0' && n > 0 && n < (1L << 24)) ? static_cast<int>(n) : 0;
}

}  // namespace

int MpiLaunchSize() {
  if (const int n = EnvCount("OMPI_COMM_WORLD_SIZE")) return n;
  if (const int n = EnvCount("PMI_SIZE")) return n;
  if (std::getenv("SLURM_PROCID") != nullptr) {
    if (const int n = EnvCount("SLURM_STEP_NUM_TASKS")) return n;
  }
  return 1;
}

void CheckMpiLaunch(int processes, bool mpi_built) {
  if (processes <= 1 || mpi_built) return;
  throw ConfigError("", "mpirun",
                    "started as one of " + std::to_string(processes) +
                        " MPI processes, but this quadtune was built without MPI "
                        "(QUADTUNE_WITH_MPI=OFF or MPI not found); run it without mpirun/srun "
                        "or rebuild with MPI");
}

void CheckSingleProcessLaunch(int processes, const std::string& command) {
  if (processes <= 1) return;
  throw ConfigError("", "mpirun",
                    "`quadtune " + command + "` runs in one process but was started as one of " +
                        std::to_string(processes) +
                        " MPI processes; start it without mpirun/srun (only `quadtune run` "
                        "spreads an experiment over MPI ranks)");
}

#if !defined(QUADTUNE_HAVE_MPI)

namespace {
[[noreturn]] void NotBuilt() {
  throw std::runtime_error(
      "quadtune was built without MPI (QUADTUNE_WITH_MPI=OFF or MPI not found): distributed runs "
      "are not available");
}
}  // namespace

bool MpiBuilt() { return false; }
MpiSession::MpiSession(const std::atomic<bool>*) { NotBuilt(); }
MpiSession::~MpiSession() = default;
void MpiSession::Abort(int code) const { std::_Exit(code); }
Experiment LoadExperimentShared(const MpiSession&, const std::string&,
                                const std::vector<std::string>&) {
  NotBuilt();
}
RunSummary RunDistributed(const MpiSession&, const Experiment&, const DistributedOptions&) {
  NotBuilt();
}

#else  // QUADTUNE_HAVE_MPI

namespace {

using Json = nlohmann::json;
using Clock = std::chrono::steady_clock;

// rank → 0: batches of rows (binary, row_codec.hpp) and JSON control messages: next (asks for
// work, reporting the finished trial), finish, error, bye. One tag keeps them in sending order.
constexpr int kTagToRoot = 11;
// 0 → rank: a trial to run, or stop.
constexpr int kTagToRank = 12;
// 0 → rank: the highest sequence number of that rank's batches committed so far (8 bytes).
constexpr int kTagAck = 13;

// Batching of a rank's rows: a batch is sent when it holds kBatchRows rows, when a row is added
// kBatchAge after its first one, or before any control message; at most kMaxInFlight batches
// wait for their acknowledgement (then the rank waits: rank 0 sets the pace).
constexpr std::uint32_t kBatchRows = 256;
constexpr auto kBatchAge = std::chrono::milliseconds(50);
constexpr std::size_t kMaxInFlight = 8;
// Rank 0 receives up to kDrainMessages messages before it commits what they carried.
constexpr int kDrainMessages = 64;

// ---- messages -----------------------------------------------------------------------------

/// True when `cancel` (the run's or the session's flag, set by signals; may be null) is set.
bool CancelSet(const std::atomic<bool>* cancel) { return cancel != nullptr && cancel->load(); }

/// Paces a polling wait without spinning in MPI (OpenMPI's blocking calls spin and would take a
/// core from the computing threads): a few polls back to back, then sleeps from 20 µs doubling
/// to 1 ms. A reply that comes soon costs microseconds, an idle wait takes no core. Reset()
/// after progress.
class Backoff {
 public:
  void Pause() {
    if (++polls_ <= 8) return;
    std::this_thread::sleep_for(sleep_);
    sleep_ = std::min(2 * sleep_, kMaxSleep);
  }
  void Reset() {
    polls_ = 0;
    sleep_ = kMinSleep;
  }

 private:
  static constexpr auto kMinSleep = std::chrono::microseconds(20);
  static constexpr auto kMaxSleep = std::chrono::microseconds(1000);
  int polls_ = 0;
  std::chrono::microseconds sleep_ = kMinSleep;
};

/// Waits for `request` (Backoff pacing). Gives up when `cancel` is set (a peer may be gone):
/// the caller then stops.
void WaitFor(MPI_Request& request, const std::atomic<bool>* cancel) {
  Backoff backoff;
  for (;;) {
    int done = 0;
    MPI_Test(&request, &done, MPI_STATUS_IGNORE);
    if (done != 0 || CancelSet(cancel)) return;
    backoff.Pause();
  }
}

void SendBytes(int destination, int tag, const std::string& bytes,
               const std::atomic<bool>* cancel) {
  QT_DEMAND(bytes.size() < static_cast<std::size_t>(INT_MAX), "MPI message too large");
  MPI_Request request;
  MPI_Isend(bytes.data(), static_cast<int>(bytes.size()), MPI_CHAR, destination, tag,
            MPI_COMM_WORLD, &request);
  WaitFor(request, cancel);
}

void Send(int destination, int tag, const Json& message, const std::atomic<bool>* cancel) {
  SendBytes(destination, tag, message.dump(), cancel);
}

/// Hands `report` to `options.on_stop`, which ends the process (DistributedOptions::on_stop).
[[noreturn]] void Stop(const DistributedOptions& options, const StopReport& report) {
  options.on_stop(report);
  std::abort();  // on_stop must not return: MPI cannot go on
}

struct RawMessage {
  int source = 0;
  std::string bytes;
};

/// The next message with `tag` from `source` (MPI_ANY_SOURCE allowed), if one has arrived.
std::optional<RawMessage> TryReceiveBytes(int source, int tag) {
  int flag = 0;
  MPI_Message handle;
  MPI_Status status;
  MPI_Improbe(source, tag, MPI_COMM_WORLD, &flag, &handle, &status);
  if (flag == 0) return std::nullopt;
  int count = 0;
  MPI_Get_count(&status, MPI_CHAR, &count);
  std::string bytes(static_cast<std::size_t>(count), '\0');
  MPI_Mrecv(bytes.data(), count, MPI_CHAR, &handle, MPI_STATUS_IGNORE);
  return RawMessage{status.MPI_SOURCE, std::move(bytes)};
}

struct Message {
  int source = 0;
  Json body;
};

/// The next JSON message with `tag` from `source`, if one has arrived.
std::optional<Message> TryReceive(int source, int tag) {
  auto m = TryReceiveBytes(source, tag);
  if (!m) return std::nullopt;
  return Message{m->source, Json::parse(m->bytes)};
}

std::uint64_t Bits(double v) { return std::bit_cast<std::uint64_t>(v); }
double FromBits(const Json& j) { return std::bit_cast<double>(j.get<std::uint64_t>()); }

Json ToJson(const EvaluationRow& r) { return ToJson(r, EvaluationColumns(), JsonReals::kBits); }
EvaluationRow RowFromJson(const Json& j) { return FromJson(j, EvaluationColumns()); }
Json ToJson(const TrialSummary& s) { return ToJson(s, TrialSummaryColumns(), JsonReals::kBits); }
TrialSummary SummaryFromJson(const Json& j) { return FromJson(j, TrialSummaryColumns()); }

// ---- stores -------------------------------------------------------------------------------

/// Rank 0's store, shared by its serving thread and its trial thread. Trial/Insert/FinishTrial
/// lock a mutex; Find and StoredRows read rows loaded at open time (never changed), unlocked.
/// A null ResultStore (no store path) keeps nothing.
class LockedStore final : public EvaluationStore {
 public:
  explicit LockedStore(ResultStore* store) : store_(store) {}
  std::int64_t Trial(const std::string& method, int repeat, std::uint64_t map_seed) override {
    std::lock_guard lock(mutex_);
    return store_ != nullptr ? store_->Trial(method, repeat, map_seed) : 0;
  }
  [[nodiscard]] const EvaluationRow* Find(std::int64_t trial_id, EvalKind kind,
                                          int iteration, int index) const override {
    return store_ != nullptr ? store_->Find(trial_id, kind, iteration, index) : nullptr;
  }
  void Insert(const EvaluationRow& row) override {
    std::lock_guard lock(mutex_);
    if (store_ != nullptr) store_->Insert(row);
  }
  /// Commits `rows` in one transaction.
  void InsertBatch(const std::vector<EvaluationRow>& rows) {
    std::lock_guard lock(mutex_);
    if (store_ != nullptr) store_->InsertBatch(rows);
  }
  void FinishTrial(std::int64_t trial_id, TrialStatus status, const std::string& best_params,
                   double best_value) override {
    std::lock_guard lock(mutex_);
    if (store_ != nullptr) store_->FinishTrial(trial_id, status, best_params, best_value);
  }
  [[nodiscard]] std::vector<EvaluationRow> StoredRows(std::int64_t trial_id) const {
    return store_ != nullptr ? store_->StoredRows(trial_id) : std::vector<EvaluationRow>{};
  }
  /// Evaluations committed so far.
  [[nodiscard]] std::size_t Count() const {
    std::lock_guard lock(mutex_);
    return store_ != nullptr ? store_->Evaluations().size() : 0;
  }

 private:
  ResultStore* store_;
  mutable std::mutex mutex_;
};

/// The store of a rank ≠ 0: the current trial's stored rows (sent with its assignment) for
/// replay; new rows travel to rank 0 in batches (Insert collects, Flush sends without waiting,
/// rank 0 acknowledges each batch once it is committed); finished trials follow their rows.
/// Driver thread only (it is the MPI thread).
class RemoteStore final : public EvaluationStore {
 public:
  RemoteStore(int rank, const FaultInjection& fault, const std::atomic<bool>* cancel)
      : rank_(rank),
        fault_(fault),
        fault_after_(fault.rank == rank && fault.trigger ? fault.after : 0),
        cancel_(cancel) {}

  void Begin(std::int64_t trial_id, std::string method, int repeat,
             const std::vector<EvaluationRow>& rows) {
    trial_id_ = trial_id;
    method_ = std::move(method);
    repeat_ = repeat;
    trials_ += (trials_.empty() ? "" : ",") + std::to_string(trial_id);
    rows_.clear();
    for (const auto& r : rows) rows_.emplace(std::make_tuple(r.kind, r.iteration, r.index), r);
  }
  std::int64_t Trial(const std::string& method, int repeat, std::uint64_t) override {
    QT_DEMAND(method == method_ && repeat == repeat_,
              "trial " + method + " r" + std::to_string(repeat) + " was not assigned");
    return trial_id_;
  }
  [[nodiscard]] const EvaluationRow* Find(std::int64_t trial_id, EvalKind kind,
                                          int iteration, int index) const override {
    if (trial_id != trial_id_) return nullptr;
    const auto it = rows_.find(std::make_tuple(kind, iteration, index));
    return it == rows_.end() ? nullptr : &it->second;
  }
  void Insert(const EvaluationRow& row) override {
    if (batch_.Rows() == 0) batch_started_ = Clock::now();
    batch_.Add(row);
    if (++added_ == fault_after_) FaultWithBatchInFlight();  // fault injection (the header)
    if (batch_.Rows() >= kBatchRows || Clock::now() - batch_started_ >= kBatchAge) {
      Flush();
    } else if (!in_flight_.empty()) {
      Progress();
    }
  }
  void FinishTrial(std::int64_t trial_id, TrialStatus status, const std::string& best_params,
                   double best_value) override {
    Flush();
    Send(0, kTagToRoot,
         Json{{"type", "finish"},
              {"trial_id", trial_id},
              {"status", ToString(status)},
              {"best_params", best_params},
              {"best_value", Bits(best_value)}},
         cancel_);
  }

  /// Sends the collected rows, if any, without waiting for them to arrive; first waits while
  /// kMaxInFlight batches are unacknowledged.
  void Flush() {
    if (batch_.Rows() == 0) return;
    AwaitInFlight(kMaxInFlight - 1);
    InFlight& f = in_flight_.emplace_back();
    f.sequence = batch_.Sequence();
    f.rows = batch_.Rows();
    f.bytes = batch_.Bytes();
    QT_DEMAND(f.bytes.size() < static_cast<std::size_t>(INT_MAX), "MPI message too large");
    MPI_Isend(f.bytes.data(), static_cast<int>(f.bytes.size()), MPI_CHAR, 0, kTagToRoot,
              MPI_COMM_WORLD, &f.request);
    batch_ = RowBatch(batch_.Sequence() + 1);
  }

  /// Completes finished sends and takes rank 0's acknowledgements, without waiting; true when
  /// anything moved.
  bool Progress() {
    bool moved = false;
    for (auto& f : in_flight_) {
      if (f.sent) continue;
      int done = 0;
      MPI_Test(&f.request, &done, MPI_STATUS_IGNORE);
      if (done == 0) break;
      f.sent = true;
      moved = true;
    }
    for (;;) {
      int flag = 0;
      MPI_Iprobe(0, kTagAck, MPI_COMM_WORLD, &flag, MPI_STATUS_IGNORE);
      if (flag == 0) break;
      std::uint64_t sequence = 0;
      MPI_Recv(&sequence, 1, MPI_UINT64_T, 0, kTagAck, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
      acked_ = std::max(acked_, sequence);
      moved = true;
    }
    while (!in_flight_.empty() && in_flight_.front().sequence <= acked_) {
      InFlight& f = in_flight_.front();
      if (!f.sent) WaitFor(f.request, cancel_);  // acknowledged, so received: completes at once
      acked_rows_ += f.rows;
      in_flight_.pop_front();
    }
    return moved;
  }

  /// Sends the collected rows and waits until rank 0 has acknowledged every batch (or the run
  /// is cancelled).
  void Drain() {
    Flush();
    AwaitInFlight(0);
  }

  /// Waits until at most `count` batches are unacknowledged (or the run is cancelled).
  void AwaitInFlight(std::size_t count) {
    Backoff backoff;
    while (in_flight_.size() > count && !CancelSet(cancel_)) {
      if (Progress()) {
        backoff.Reset();
      } else {
        backoff.Pause();
      }
    }
  }

 private:
  /// A batch sent and not yet acknowledged; its bytes stay put until the send completes
  /// (std::deque keeps elements in place when the ends change).
  struct InFlight {
    std::uint64_t sequence = 0;
    std::uint32_t rows = 0;
    std::string bytes;
    MPI_Request request = MPI_REQUEST_NULL;
    bool sent = false;
  };

  /// The injected fault: every earlier batch acknowledged, then the batch holding this
  /// evaluation sent (its send completed, so rank 0 has it or is receiving it), then the fault's
  /// trigger (a SIGKILL arrives before the acknowledgement), told what rank 0 acknowledged and
  /// what is in flight.
  void FaultWithBatchInFlight() {
    AwaitInFlight(0);
    const std::uint32_t rows = batch_.Rows();
    Flush();
    InFlight& last = in_flight_.back();
    WaitFor(last.request, cancel_);
    last.sent = true;
    fault_.trigger(FaultReport{rank_, acked_rows_, static_cast<long>(rows), trials_});
  }

  int rank_;
  const FaultInjection& fault_;
  int fault_after_;
  const std::atomic<bool>* cancel_;
  long added_ = 0;
  long acked_rows_ = 0;
  std::uint64_t acked_ = 0;
  RowBatch batch_{1};
  Clock::time_point batch_started_;
  std::deque<InFlight> in_flight_;
  std::string trials_;  // ids of the trials assigned to this rank, for the fault report
  std::int64_t trial_id_ = -1;
  std::string method_;
  int repeat_ = -1;
  std::map<std::tuple<EvalKind, int, int>, EvaluationRow> rows_;
};

// ---- rank 0 -------------------------------------------------------------------------------

/// A trial to hand out: its position in the single-process order and its stored id.
struct Task {
  int index = 0;
  Method method = Method::kDefault;
  int repeat = 0;
  std::int64_t trial_id = 0;
};

/// What rank 0 knows about another rank.
struct RankState {
  long pid = 0;
  std::string host;
  int task = -1;  // index of the trial it runs, -1 when none
  long flights = 0;
  long resolves = 0;
  int worlds = 0;
  bool done = false;  // said bye
};

class Root {
 public:
  Root(const MpiSession& mpi, const Experiment& e, const DistributedOptions& o)
      : mpi_(mpi), e_(e), o_(o), ranks_(static_cast<std::size_t>(mpi.Size())) {}

  /// Opens the store, creates every trial row (single-process order) and the local runner.
  void Start() {
    threads_ = o_.run.threads > 0 ? o_.run.threads : e_.threads;
    if (!o_.run.store_path.empty()) {
      store_ = std::make_unique<ResultStore>(o_.run.store_path, e_, threads_, o_.run.resume);
    }
    locked_ = std::make_unique<LockedStore>(store_.get());
    int index = 0;
    for (int repeat = 0; repeat < e_.repeats; ++repeat) {
      for (Method method : e_.methods) {
        // The trial's map seed as a single process stores it (EvaluationLog in tuner.cpp).
        const std::uint64_t map_seed = e_.FlightMapSeed(repeat, 0);
        tasks_.push_back(
            Task{index++, method, repeat, locked_->Trial(ToString(method), repeat, map_seed)});
      }
    }
    results_.resize(tasks_.size());
    // Hand out the expensive trials (bo_pso re-solves queries besides flying) first.
    std::vector<Task> order = tasks_;
    std::stable_partition(order.begin(), order.end(),
                          [](const Task& t) { return t.method == Method::kBoPso; });
    queue_.assign(order.begin(), order.end());
    local_options_ = o_.run;
    local_options_.cancel = &stop_local_;
    if (o_.run.on_progress) {
      local_options_.on_progress = [this](const Progress& p) { Report(p); };
    }
    runner_ = std::make_unique<TrialRunner>(e_, local_options_, threads_,
                                            store_ != nullptr ? locked_.get() : nullptr);
    runner_->SetTrialCounts(0, static_cast<int>(tasks_.size()));
  }

  RunSummary Serve() {
    std::thread local([this] { LocalTrials(); });
    active_ = mpi_.Size() - 1;
    acks_.assign(static_cast<std::size_t>(mpi_.Size()), 0);
    Backoff idle;
    while (active_ > 0 || !local_done_.load()) {
      if (CancelSet(o_.run.cancel)) Stopped();
      {
        std::lock_guard lock(mutex_);
        if (!local_error_.empty()) Fail("rank 0: " + local_error_);
      }
      // Take what has arrived, then commit its rows in one transaction and acknowledge them.
      bool any = false;
      for (int n = 0; n < kDrainMessages; ++n) {
        auto m = TryReceiveBytes(MPI_ANY_SOURCE, kTagToRoot);
        if (!m) break;
        any = true;
        if (!m->bytes.empty() && m->bytes.front() == kBatchTag) {
          try {
            acks_[static_cast<std::size_t>(m->source)] = DecodeBatch(m->bytes, pending_);
          } catch (const CodecError& ex) {
            Fail("rank " + std::to_string(m->source) + " sent " + ex.what());
          }
          dirty_.push_back(m->source);
          continue;
        }
        Commit();  // the rows sent before a control message are stored before it is acted on
        Handle(m->source, Json::parse(m->bytes));
      }
      Commit();
      if (any) {
        idle.Reset();
      } else {
        idle.Pause();
      }
    }
    local.join();
    RunSummary summary;
    summary.threads = threads_;
    summary.ranks = mpi_.Size();
    summary.flights = runner_->Flights();
    summary.resolves = runner_->Resolves();
    summary.worlds = runner_->Worlds();
    for (const auto& r : ranks_) {
      summary.flights += r.flights;
      summary.resolves += r.resolves;
      summary.worlds += r.worlds;
    }
    for (auto& t : results_) {
      if (t) summary.trials.push_back(std::move(*t));
    }
    // Held-out validation on rank 0's threads, once every trial is stored (as RunExperiment).
    if (o_.run.validate && e_.validation.maps > 0 &&
        summary.trials.size() == results_.size()) {
      std::vector<std::int64_t> ids;
      for (const auto& t : summary.trials) ids.push_back(t.trial_id);
      long flown = 0;
      summary.validation = RunValidation(e_, summary.trials, ids,
                                         store_ != nullptr ? locked_.get() : nullptr, threads_,
                                         o_.run, &flown);
      summary.flights += flown;
    }
    summary.wall_s = runner_->ElapsedSeconds();
    return summary;
  }

 private:
  /// Commits the rows received since the last commit (one transaction), then acknowledges each
  /// sender's last batch: what a rank sees acknowledged is in the store.
  void Commit() {
    if (!pending_.empty()) {
      locked_->InsertBatch(pending_);
      pending_.clear();
    }
    std::sort(dirty_.begin(), dirty_.end());
    dirty_.erase(std::unique(dirty_.begin(), dirty_.end()), dirty_.end());
    for (const int source : dirty_) {
      MPI_Request request;
      MPI_Isend(&acks_[static_cast<std::size_t>(source)], 1, MPI_UINT64_T, source, kTagAck,
                MPI_COMM_WORLD, &request);
      WaitFor(request, o_.run.cancel);
    }
    dirty_.clear();
  }

  /// A control message (JSON) from `source`.
  void Handle(int source, const Json& body) {
    RankState& rank = ranks_[static_cast<std::size_t>(source)];
    const std::string type = body.at("type").get<std::string>();
    if (type == "finish") {
      const auto status = FromString<TrialStatus>(body.at("status").get<std::string>());
      QT_DEMAND(status.has_value(), "a rank finished a trial with an unknown status");
      locked_->FinishTrial(body.at("trial_id").get<std::int64_t>(), *status,
                           body.at("best_params").get<std::string>(),
                           FromBits(body.at("best_value")));
    } else if (type == "next") {
      Next(source, rank, body);
    } else if (type == "error") {
      Fail("rank " + std::to_string(source) + ": " + body.at("message").get<std::string>());
    } else if (type == "bye") {
      rank.worlds = body.at("worlds").get<int>();
      rank.done = true;
      --active_;
    }
  }

  std::optional<Task> NextTask() {
    std::lock_guard lock(mutex_);
    if (queue_.empty()) return std::nullopt;
    Task t = queue_.front();
    queue_.pop_front();
    return t;
  }

  /// Records a finished trial; returns the number of trials done.
  int Record(int index, TrialSummary summary) {
    std::lock_guard lock(mutex_);
    results_[static_cast<std::size_t>(index)] = std::move(summary);
    ++trials_done_;
    runner_->SetTrialCounts(trials_done_, static_cast<int>(tasks_.size()));
    return trials_done_;
  }

  void Report(const Progress& p) {
    std::lock_guard lock(progress_mutex_);
    o_.run.on_progress(p);
  }

  /// Rank 0's own share: trials from the same queue, on its trial thread.
  void LocalTrials() {
    try {
      while (!stop_local_.load()) {
        const auto task = NextTask();
        if (!task) break;
        TrialSummary summary;
        if (!runner_->Run(task->method, task->repeat, summary)) break;
        Record(task->index, std::move(summary));
      }
    } catch (const std::exception& ex) {
      std::lock_guard lock(mutex_);
      local_error_ = ex.what();
    }
    local_done_.store(true);
  }

  /// A rank asks for work, having finished the trial it reports (if any).
  void Next(int source, RankState& rank, const Json& body) {
    if (body.contains("pid")) {
      rank.pid = body.at("pid").get<long>();
      rank.host = body.at("host").get<std::string>();
    }
    rank.flights = body.value("flights", rank.flights);
    rank.resolves = body.value("resolves", rank.resolves);
    if (body.contains("summary")) {
      TrialSummary s = SummaryFromJson(body.at("summary"));
      const int index = body.at("index").get<int>();
      if (o_.run.on_progress) {
        Progress p;
        p.method = s.method;
        p.repeat = s.repeat;
        p.flights_done = s.flights;
        p.flights_total = std::max(1, s.flights);  // the trial is finished
        p.best_long = s.best_value;
        p.short_evals = runner_->Resolves();
        p.elapsed_s = runner_->ElapsedSeconds();
        p.rank = source;
        p.trials_total = static_cast<int>(tasks_.size());
        p.trials_done = Record(index, std::move(s)) - 1;
        Report(p);
      } else {
        Record(index, std::move(s));
      }
      rank.task = -1;
    }
    const auto task = NextTask();
    if (!task) {
      Send(source, kTagToRank, Json{{"stop", true}}, o_.run.cancel);
      return;
    }
    Json rows = Json::array();
    for (const auto& r : locked_->StoredRows(task->trial_id)) rows.push_back(ToJson(r));
    Send(source, kTagToRank,
         Json{{"stop", false},
              {"index", task->index},
              {"method", ToString(task->method)},
              {"repeat", task->repeat},
              {"trial_id", task->trial_id},
              {"rows", std::move(rows)}},
         o_.run.cancel);
    rank.task = task->index;
  }

  /// An error ended the run (`message` names the rank it happened on): the report goes to
  /// on_stop, which ends every rank.
  [[noreturn]] void Fail(const std::string& message) {
    stop_local_.store(true);
    StopReport report;
    report.end = DistributedEnd::kFailed;
    report.error = message;
    report.store_path = store_ != nullptr ? o_.run.store_path : std::string();
    report.resume_command = o_.resume_command;
    Stop(o_, report);
  }

  std::string TrialName(int index) const {
    if (index < 0) return "no trial";
    const Task& t = tasks_[static_cast<std::size_t>(index)];
    return std::string("trial ") + ToString(t.method) + " r" + std::to_string(t.repeat);
  }

  /// A signal stopped the run (the runtime's SIGTERM after a rank was lost, or the user): the
  /// report (the lost ranks, the state of the store, how to resume) goes to on_stop.
  [[noreturn]] void Stopped() {
    stop_local_.store(true);
    StopReport report;
    for (std::size_t r = 1; r < ranks_.size(); ++r) {
      const RankState& s = ranks_[r];
      if (s.done || s.pid <= 0 || s.host != mpi_.Host()) continue;
      if (o_.process_ended && o_.process_ended(s.pid)) {
        report.lost.push_back(LostRank{static_cast<int>(r), s.pid, s.host, TrialName(s.task)});
      }
    }
    {
      std::lock_guard lock(mutex_);
      report.trials_done = trials_done_;
    }
    report.trials_total = static_cast<int>(tasks_.size());
    if (store_ != nullptr) {
      report.store_path = o_.run.store_path;
      report.committed = locked_->Count();
    }
    report.resume_command = o_.resume_command;
    Stop(o_, report);
  }

  const MpiSession& mpi_;
  const Experiment& e_;
  const DistributedOptions& o_;
  int threads_ = 1;
  std::unique_ptr<ResultStore> store_;
  std::unique_ptr<LockedStore> locked_;
  std::vector<Task> tasks_;       // single-process order
  std::vector<RankState> ranks_;  // serving thread only
  RunOptions local_options_;
  std::atomic<bool> stop_local_{false};
  std::atomic<bool> local_done_{false};
  std::unique_ptr<TrialRunner> runner_;  // rank 0's own trials (trial thread)
  std::mutex mutex_;                     // guards queue_, results_, trials_done_, local_error_
  std::deque<Task> queue_;
  std::vector<std::optional<TrialSummary> > results_;
  int trials_done_ = 0;
  std::string local_error_;
  std::mutex progress_mutex_;
  // Serving thread only: ranks still running, rows received and not yet committed, each rank's
  // last batch received (its acknowledgement once committed), ranks owed an acknowledgement.
  int active_ = 0;
  std::vector<EvaluationRow> pending_;
  std::vector<std::uint64_t> acks_;
  std::vector<int> dirty_;
};

// ---- ranks ≠ 0 ----------------------------------------------------------------------------

/// This rank stopped (kStopped) or failed and told rank 0 (kFailed, `error`): the report goes to
/// on_stop, which ends the process (the `quadtune` program waits to be stopped by the runtime,
/// so that rank 0 can tell the lost rank from the stopped ones).
[[noreturn]] void WorkerStopped(const MpiSession& mpi, const DistributedOptions& o,
                                DistributedEnd end, const std::string& error = {}) {
  StopReport report;
  report.end = end;
  report.rank = mpi.Rank();
  report.error = error;
  report.resume_command = o.resume_command;
  Stop(o, report);
}

RunSummary RunWorker(const MpiSession& mpi, const Experiment& e, const DistributedOptions& o) {
  const auto cancelled = [&o] { return CancelSet(o.run.cancel); };
  const auto stopped = [&] { WorkerStopped(mpi, o, DistributedEnd::kStopped); };
  RunSummary summary;
  summary.threads = o.run.threads > 0 ? o.run.threads : e.threads;
  summary.ranks = mpi.Size();
  std::unique_ptr<RemoteStore> store;
  std::unique_ptr<TrialRunner> runner;
  try {
    store = std::make_unique<RemoteStore>(mpi.Rank(), o.fault, o.run.cancel);
    RunOptions options = o.run;
    options.on_progress = {};
    runner = std::make_unique<TrialRunner>(e, options, summary.threads, store.get());
    Json next{{"type", "next"}, {"pid", static_cast<long>(getpid())}, {"host", mpi.Host()}};
    for (;;) {
      Send(0, kTagToRoot, next, o.run.cancel);
      std::optional<Message> m;
      Backoff backoff;
      while (!(m = TryReceive(0, kTagToRank))) {
        if (cancelled()) stopped();
        if (store->Progress()) {
          backoff.Reset();
        } else {
          backoff.Pause();
        }
      }
      const Json& a = m->body;
      if (a.at("stop").get<bool>()) break;
      std::vector<EvaluationRow> rows;
      for (const auto& r : a.at("rows")) rows.push_back(RowFromJson(r));
      const std::string method = a.at("method").get<std::string>();
      const int repeat = a.at("repeat").get<int>();
      store->Begin(a.at("trial_id").get<std::int64_t>(), method, repeat, rows);
      TrialSummary trial;
      if (!runner->Run(*FromString<Method>(method), repeat, trial)) stopped();
      next = Json{{"type", "next"},
                  {"index", a.at("index").get<int>()},
                  {"summary", ToJson(trial)},
                  {"flights", runner->Flights()},
                  {"resolves", runner->Resolves()}};
      summary.trials.push_back(std::move(trial));
    }
  } catch (const std::exception& ex) {
    Send(0, kTagToRoot, Json{{"type", "error"}, {"message", ex.what()}}, o.run.cancel);
    WorkerStopped(mpi, o, DistributedEnd::kFailed, ex.what());  // rank 0 ends the job
  }
  summary.flights = runner->Flights();
  summary.resolves = runner->Resolves();
  summary.worlds = runner->Worlds();
  summary.wall_s = runner->ElapsedSeconds();
  store->Drain();
  if (cancelled()) stopped();
  Send(0, kTagToRoot, Json{{"type", "bye"}, {"worlds", summary.worlds}}, o.run.cancel);
  return summary;
}

/// MPI_Ibcast of `count` items at `data` from rank 0, waited for without spinning; throws when
/// `cancel` is set first.
void Broadcast(void* data, int count, MPI_Datatype type, const std::atomic<bool>* cancel) {
  MPI_Request request;
  MPI_Ibcast(data, count, type, 0, MPI_COMM_WORLD, &request);
  WaitFor(request, cancel);
  if (CancelSet(cancel)) throw std::runtime_error("stopped by a signal before the run started");
}

/// The lowest rank whose `failed` is true (Size() when none), agreed by every rank.
int FirstFailed(const MpiSession& mpi, bool failed) {
  int mine = failed ? mpi.Rank() : mpi.Size();
  int first = mpi.Size();
  MPI_Request request;
  MPI_Iallreduce(&mine, &first, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD, &request);
  WaitFor(request, mpi.Cancel());
  return first;
}

}  // namespace

bool MpiBuilt() { return true; }

MpiSession::MpiSession(const std::atomic<bool>* cancel) : cancel_(cancel) {
  int initialized = 0;
  MPI_Initialized(&initialized);
  if (initialized != 0) throw std::runtime_error("MPI is already initialised");
  int provided = 0;
  if (MPI_Init_thread(nullptr, nullptr, MPI_THREAD_FUNNELED, &provided) != MPI_SUCCESS) {
    throw std::runtime_error("MPI_Init_thread failed");
  }
  if (provided < MPI_THREAD_FUNNELED) {
    PMPI_Finalize();
    throw std::runtime_error("the MPI library does not support MPI_THREAD_FUNNELED");
  }
  PMPI_Comm_rank(MPI_COMM_WORLD, &rank_);
  MPI_Comm_size(MPI_COMM_WORLD, &size_);
  char name[MPI_MAX_PROCESSOR_NAME] = {0};
  int length = 0;
  MPI_Get_processor_name(name, &length);
  host_.assign(name, static_cast<std::size_t>(std::max(0, length)));
}

MpiSession::~MpiSession() {
  // MPI_Finalize synchronises the ranks by spinning; meet in a barrier polled with sleeps first.
  MPI_Request request;
  MPI_Ibarrier(MPI_COMM_WORLD, &request);
  WaitFor(request, cancel_);
  PMPI_Finalize();
}

void MpiSession::Abort(int code) const {
  MPI_Abort(MPI_COMM_WORLD, code);
  std::_Exit(code);
}

Experiment LoadExperimentShared(const MpiSession& mpi, const std::string& path,
                                const std::vector<std::string>& assignments) {
  std::optional<Experiment> experiment;
  std::exception_ptr error;
  std::string text;
  if (mpi.Rank() == 0) {
    try {
      experiment = Experiment::LoadFile(path, assignments);
      text = experiment->text;
    } catch (...) {
      error = std::current_exception();
    }
  }
  long long length = error ? -1 : static_cast<long long>(text.size());
  Broadcast(&length, 1, MPI_LONG_LONG, mpi.Cancel());
  if (length < 0) {
    if (error) std::rethrow_exception(error);
    throw PeerError("rank 0 could not load " + path);
  }
  QT_DEMAND(length < INT_MAX, "experiment file too large");
  text.resize(static_cast<std::size_t>(length));
  Broadcast(text.data(), static_cast<int>(length), MPI_CHAR, mpi.Cancel());
  if (mpi.Rank() != 0) {
    try {
      const std::string dir = std::filesystem::path(path).parent_path().string();
      experiment = Experiment::FromString(text, path, dir.empty() ? "." : dir);
    } catch (...) {
      error = std::current_exception();
    }
  }
  const int first = FirstFailed(mpi, static_cast<bool>(error));
  if (first < mpi.Size()) {
    if (error) std::rethrow_exception(error);
    throw PeerError("rank " + std::to_string(first) + " could not load " + path);
  }
  return std::move(*experiment);
}

RunSummary RunDistributed(const MpiSession& mpi, const Experiment& experiment,
                          const DistributedOptions& options) {
  QT_DEMAND(static_cast<bool>(options.on_stop), "RunDistributed needs DistributedOptions::on_stop");
  if (mpi.Rank() != 0) {
    int ok = 0;
    Broadcast(&ok, 1, MPI_INT, options.run.cancel);
    if (ok == 0) throw PeerError("rank 0 could not start the run");
    return RunWorker(mpi, experiment, options);
  }
  Root root(mpi, experiment, options);
  std::exception_ptr error;
  try {
    root.Start();
  } catch (...) {
    error = std::current_exception();
  }
  int ok = error ? 0 : 1;
  Broadcast(&ok, 1, MPI_INT, options.run.cancel);
  if (error) std::rethrow_exception(error);
  return root.Serve();
}

#endif  // QUADTUNE_HAVE_MPI

}  // namespace quadtune::engine
