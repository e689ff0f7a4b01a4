#pragma once
/// \file
/// The task scheduler (oneTBB) and the world pool.
///
/// Scheduler: a tbb::task_arena of N worker threads fed from two FIFO queues, flights first.
/// Submit() puts a job in its priority's queue and enqueues one arena task; each arena task runs
/// the highest-priority job waiting at that moment. So a flight never waits behind the flood of
/// short-term re-solves: whenever a worker frees up, a waiting flight is taken before any
/// short-term job. An exception escaping a job is caught and recorded in its TaskGroup (jobs
/// normally catch their own and record them against their evaluation). Cancel() makes jobs not
/// yet started skip (they are marked cancelled) and is visible to running ones via Cancelled().
///
/// WorldPool: reusable WorkerSlots (each holds a planner's per-task state, e.g. a Bullet world),
/// handed to one task at a time.
///
/// Thread safety: Submit, Wait, Cancel and the pool's Borrow (and Acquire/Release) are
/// thread-safe; a lease is used by one task at a time.

#include <atomic>
#include <condition_variable>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "quadtune/engine/api/planner.hpp"

namespace quadtune::engine {

/// Job priority: flights (long-term evaluations) are always taken before short-term jobs.
enum class Priority { kFlight = 0, kShort = 1 };

/// A set of jobs to wait for.
class TaskGroup {
 public:
  TaskGroup() = default;
  TaskGroup(const TaskGroup&) = delete;
  TaskGroup& operator=(const TaskGroup&) = delete;
  /// Messages of exceptions that escaped jobs of this group.
  [[nodiscard]] std::vector<std::string> Errors() const;
  /// Jobs skipped because the scheduler was cancelled.
  [[nodiscard]] int Skipped() const { return skipped_.load(); }
  /// True when no job of the group is queued or running.
  [[nodiscard]] bool Done() const;

 private:
  friend class Scheduler;
  mutable std::mutex mutex_;
  std::condition_variable done_;
  int pending_ = 0;
  std::vector<std::string> errors_;
  std::atomic<int> skipped_{0};
};

/// Scheduler statistics.
struct SchedulerStats {
  long jobs_run = 0;          ///< jobs executed
  long jobs_skipped = 0;      ///< jobs skipped after Cancel()
  double job_seconds = 0.0;   ///< wall time inside jobs, summed (s)
};

/// See the file comment.
class Scheduler {
 public:
  /// `threads` >= 1 worker threads.
  explicit Scheduler(int threads);
  ~Scheduler();
  Scheduler(const Scheduler&) = delete;
  Scheduler& operator=(const Scheduler&) = delete;

  [[nodiscard]] int Threads() const { return threads_; }
  /// Queues `job` in `group`. Never blocks.
  void Submit(TaskGroup& group, Priority priority, std::function<void()> job);
  /// Blocks until every job of `group` has run (or been skipped).
  void Wait(TaskGroup& group);
  /// Stops starting jobs; running jobs see Cancelled().
  void Cancel() { cancelled_.store(true); }
  [[nodiscard]] bool Cancelled() const { return cancelled_.load(); }
  [[nodiscard]] SchedulerStats Stats() const;

 private:
  struct Job {
    TaskGroup* group;
    std::function<void()> fn;
  };
  void RunOne();

  struct Arena;  // tbb::global_control + tbb::task_arena (oneTBB stays out of the header)
  int threads_;
  std::unique_ptr<Arena> arena_;
  std::mutex mutex_;
  std::deque<Job> queues_[2];
  std::atomic<bool> cancelled_{false};
  std::atomic<long> jobs_run_{0};
  std::atomic<long> jobs_skipped_{0};
  std::atomic<long long> job_ns_{0};
};

/// Reusable worker slots (the world pool). Slots are created on demand and never destroyed
/// before the pool.
class WorldPool {
 public:
  /// A slot on loan to one task: it goes back to the pool when the lease is destroyed (also
  /// when the task throws). Movable, not copyable; a moved-from lease holds no slot. Must not
  /// outlive its pool.
  class Lease {
   public:
    Lease(Lease&& other) noexcept;
    Lease& operator=(Lease&& other) noexcept;
    Lease(const Lease&) = delete;
    Lease& operator=(const Lease&) = delete;
    ~Lease();
    WorkerSlot& operator*() const { return *slot_; }
    WorkerSlot* operator->() const { return slot_; }
    [[nodiscard]] WorkerSlot* get() const { return slot_; }

   private:
    friend class WorldPool;
    Lease(WorldPool* pool, WorkerSlot* slot) : pool_(pool), slot_(slot) {}
    WorldPool* pool_;
    WorkerSlot* slot_;
  };

  /// Lends a free slot (a new one when none is free) until the lease ends.
  [[nodiscard]] Lease Borrow();
  /// Slots created so far.
  [[nodiscard]] int Size() const;
  /// Σ uses over all slots (flights flown).
  [[nodiscard]] int Uses() const;

 private:
  WorkerSlot* Acquire();             // Borrow's two halves; only a Lease gives a slot back
  void Release(WorkerSlot* slot);
  mutable std::mutex mutex_;
  std::vector<std::unique_ptr<WorkerSlot>> slots_;
  std::vector<WorkerSlot*> free_;
};

/// Flies `request` with `planner` on a slot borrowed from `pool` for the flight. An exception
/// from the planner becomes a failed FlightRecord (message "exception: …"), resets the slot's
/// state (the world may be in any state) and sets `*threw` when given. Never throws.
/// Thread-safe as the pool and the plug-in are.
FlightRecord FlyOnPool(const Planner& planner, WorldPool& pool, const FlightRequest& request,
                       bool* threw = nullptr);

}  // namespace quadtune::engine
