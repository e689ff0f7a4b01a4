#include "quadtune/engine/tuning/scheduler.hpp"

#include <tbb/global_control.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <chrono>
#include <exception>
#include <thread>
#include <utility>

namespace quadtune::engine {

std::vector<std::string> TaskGroup::Errors() const {
  std::lock_guard lock(mutex_);
  return errors_;
}

bool TaskGroup::Done() const {
  std::lock_guard lock(mutex_);
  return pending_ == 0;
}

struct Scheduler::Arena {
  explicit Arena(int threads)
      // Allow more workers than cores when asked: the arena holds exactly `threads` workers (no
      // slot reserved for the calling thread, which only waits).
      : control(tbb::global_control::max_allowed_parallelism,
                std::max<std::size_t>(
                    tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism),
                    static_cast<std::size_t>(threads) + 1)),
        arena(threads, 0) {}
  tbb::global_control control;
  tbb::task_arena arena;
};

Scheduler::Scheduler(int threads)
    : threads_(threads < 1 ? 1 : threads), arena_(std::make_unique<Arena>(threads_)) {}

Scheduler::~Scheduler() {
  // Drain: wait until every queued job has been taken (jobs hold pointers to groups).
  for (;;) {
    {
      std::lock_guard lock(mutex_);
      if (queues_[0].empty() && queues_[1].empty()) break;
    }
    std::this_thread::yield();
  }
  arena_->arena.terminate();
}

void Scheduler::Submit(TaskGroup& group, Priority priority, std::function<void()> job) {
  {
    std::lock_guard lock(group.mutex_);
    ++group.pending_;
  }
  {
    std::lock_guard lock(mutex_);
    queues_[static_cast<int>(priority)].push_back(Job{&group, std::move(job)});
  }
  arena_->arena.enqueue([this] { RunOne(); });
}

void Scheduler::RunOne() {
  Job job;
  {
    std::lock_guard lock(mutex_);
    auto& q = !queues_[0].empty() ? queues_[0] : queues_[1];
    if (q.empty()) return;  // cannot happen: one arena task per job
    job = std::move(q.front());
    q.pop_front();
  }
  std::string error;
  bool skipped = false;
  if (cancelled_.load()) {
    skipped = true;
    jobs_skipped_.fetch_add(1);
    job.group->skipped_.fetch_add(1);
  } else {
    const auto t0 = std::chrono::steady_clock::now();
    try {
      job.fn();
    } catch (const std::exception& e) {
      error = e.what();
    } catch (...) {
      error = "unknown exception";
    }
    job_ns_.fetch_add(std::chrono::duration_cast<std::chrono::nanoseconds>(
                          std::chrono::steady_clock::now() - t0).count());
    jobs_run_.fetch_add(1);
  }
  (void)skipped;
  std::lock_guard lock(job.group->mutex_);
  if (!error.empty()) job.group->errors_.push_back(error);
  if (--job.group->pending_ == 0) job.group->done_.notify_all();
}

void Scheduler::Wait(TaskGroup& group) {
  std::unique_lock lock(group.mutex_);
  group.done_.wait(lock, [&] { return group.pending_ == 0; });
}

SchedulerStats Scheduler::Stats() const {
  SchedulerStats s;
  s.jobs_run = jobs_run_.load();
  s.jobs_skipped = jobs_skipped_.load();
  s.job_seconds = static_cast<double>(job_ns_.load()) * 1e-9;
  return s;
}

WorkerSlot* WorldPool::Acquire() {
  std::lock_guard lock(mutex_);
  if (!free_.empty()) {
    WorkerSlot* s = free_.back();
    free_.pop_back();
    return s;
  }
  slots_.push_back(std::make_unique<WorkerSlot>());
  slots_.back()->index = static_cast<int>(slots_.size()) - 1;
  return slots_.back().get();
}

void WorldPool::Release(WorkerSlot* slot) {
  std::lock_guard lock(mutex_);
  free_.push_back(slot);
}

WorldPool::Lease WorldPool::Borrow() { return Lease(this, Acquire()); }

WorldPool::Lease::Lease(Lease&& other) noexcept
    : pool_(std::exchange(other.pool_, nullptr)), slot_(std::exchange(other.slot_, nullptr)) {}

WorldPool::Lease& WorldPool::Lease::operator=(Lease&& other) noexcept {
  if (this != &other) {
    if (slot_ != nullptr) pool_->Release(slot_);
    pool_ = std::exchange(other.pool_, nullptr);
    slot_ = std::exchange(other.slot_, nullptr);
  }
  return *this;
}

WorldPool::Lease::~Lease() {
  if (slot_ != nullptr) pool_->Release(slot_);
}

FlightRecord FlyOnPool(const Planner& planner, WorldPool& pool, const FlightRequest& request,
                       bool* threw) {
  const WorldPool::Lease slot = pool.Borrow();
  FlightRecord rec;
  std::string error;
  try {
    rec = planner.Fly(request, *slot);
  } catch (const std::exception& ex) {
    error = ex.what();
  } catch (...) {
    error = "unknown";
  }
  const bool failed = !error.empty();
  if (failed) {
    rec = FlightRecord{};
    rec.status = EvalStatus::kFailed;
    rec.message = "exception: " + error;
    slot->ResetState();  // rebuilt by the next flight in this slot
  }
  if (threw != nullptr) *threw = failed;
  return rec;
}

int WorldPool::Size() const {
  std::lock_guard lock(mutex_);
  return static_cast<int>(slots_.size());
}

int WorldPool::Uses() const {
  std::lock_guard lock(mutex_);
  int n = 0;
  for (const auto& s : slots_) n += s->uses;
  return n;
}

}  // namespace quadtune::engine
