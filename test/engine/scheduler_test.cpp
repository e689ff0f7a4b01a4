#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <set>
#include <stdexcept>
#include <vector>

#include "quadtune/engine/tuning/scheduler.hpp"

namespace quadtune::engine {
namespace {

TEST(Scheduler, RunsEveryJobAtSeveralThreadCounts) {
  for (int threads : {1, 2, 8}) {
    Scheduler s(threads);
    TaskGroup g;
    std::atomic<int> sum{0};
    for (int i = 1; i <= 200; ++i) {
      s.Submit(g, i % 3 == 0 ? Priority::kFlight : Priority::kShort, [&sum, i] { sum += i; });
    }
    s.Wait(g);
    EXPECT_EQ(sum.load(), 200 * 201 / 2) << threads;
    EXPECT_EQ(s.Stats().jobs_run, 200);
  }
}

TEST(Scheduler, RunsAsManyJobsAtOnceAsItHasThreads) {
  for (int threads : {2, 4, 8}) {
    Scheduler s(threads);
    TaskGroup g;
    std::mutex m;
    std::condition_variable cv;
    int inside = 0;
    int most = 0;
    for (int i = 0; i < threads; ++i) {
      s.Submit(g, Priority::kShort, [&] {
        std::unique_lock lock(m);
        most = std::max(most, ++inside);
        cv.notify_all();
        // Wait (bounded, so a failure cannot hang) until every job is inside at once.
        cv.wait_for(lock, std::chrono::seconds(10), [&] { return inside == threads; });
      });
    }
    s.Wait(g);
    EXPECT_EQ(most, threads);  // more threads than cores are still real workers
  }
}

TEST(Scheduler, WaitingFlightIsTakenBeforeQueuedShortTermJobs) {
  Scheduler s(1);
  TaskGroup g;
  std::mutex m;
  std::condition_variable cv;
  bool release = false;
  bool started = false;
  std::vector<int> order;
  // Occupy the only worker, then queue 20 short jobs and one flight.
  s.Submit(g, Priority::kShort, [&] {
    std::unique_lock lock(m);
    started = true;
    cv.notify_all();
    cv.wait(lock, [&] { return release; });
  });
  {
    std::unique_lock lock(m);
    cv.wait(lock, [&] { return started; });
  }
  for (int i = 0; i < 20; ++i) {
    s.Submit(g, Priority::kShort, [&, i] {
      std::lock_guard lock(m);
      order.push_back(i);
    });
  }
  s.Submit(g, Priority::kFlight, [&] {
    std::lock_guard lock(m);
    order.push_back(-1);
  });
  {
    std::lock_guard lock(m);
    release = true;
  }
  cv.notify_all();
  s.Wait(g);
  ASSERT_EQ(order.size(), 21u);
  EXPECT_EQ(order.front(), -1);  // the flight first
  for (int i = 0; i < 20; ++i) EXPECT_EQ(order[static_cast<std::size_t>(i) + 1], i);  // FIFO
}

TEST(Scheduler, ThrowingJobIsRecordedAndOthersRun) {
  Scheduler s(2);
  TaskGroup g;
  std::atomic<int> ran{0};
  for (int i = 0; i < 10; ++i) {
    s.Submit(g, Priority::kShort, [&ran, i] {
      if (i == 4) throw std::runtime_error("job 4 failed");
      ++ran;
    });
  }
  s.Wait(g);
  EXPECT_EQ(ran.load(), 9);
  ASSERT_EQ(g.Errors().size(), 1u);
  EXPECT_EQ(g.Errors()[0], "job 4 failed");
}

TEST(Scheduler, CancelSkipsJobsNotStarted) {
  Scheduler s(1);
  TaskGroup g;
  std::atomic<int> ran{0};
  s.Submit(g, Priority::kShort, [&] {
    s.Cancel();
    ++ran;
  });
  s.Wait(g);
  for (int i = 0; i < 5; ++i) s.Submit(g, Priority::kShort, [&] { ++ran; });
  s.Wait(g);
  EXPECT_EQ(ran.load(), 1);
  EXPECT_EQ(g.Skipped(), 5);
  EXPECT_TRUE(s.Cancelled());
}

TEST(WorldPool, LeaseReturnsItsSlotWhenDestroyed) {
  WorldPool pool;
  WorkerSlot* first = nullptr;
  {
    const WorldPool::Lease a = pool.Borrow();
    const WorldPool::Lease b = pool.Borrow();
    EXPECT_NE(a.get(), b.get());
    first = a.get();
  }
  // Both slots are back: the next two loans reuse them, and no slot is created.
  const WorldPool::Lease c = pool.Borrow();
  const WorldPool::Lease d = pool.Borrow();
  EXPECT_EQ(pool.Size(), 2);
  EXPECT_TRUE(c.get() == first || d.get() == first);
}

TEST(WorldPool, LeaseReturnsItsSlotWhenTheTaskThrows) {
  WorldPool pool;
  WorkerSlot* lent = nullptr;
  try {
    const WorldPool::Lease a = pool.Borrow();
    lent = a.get();
    throw std::runtime_error("flight failed");
  } catch (const std::runtime_error&) {
  }
  EXPECT_EQ(pool.Borrow().get(), lent);
  EXPECT_EQ(pool.Size(), 1);
}

TEST(WorldPool, MovedLeaseReturnsItsSlotOnce) {
  WorldPool pool;
  WorldPool::Lease a = pool.Borrow();
  WorkerSlot* slot = a.get();
  {
    const WorldPool::Lease b = std::move(a);
    EXPECT_EQ(b.get(), slot);
  }
  // Returned once: two loans now get that slot and one new slot.
  const WorldPool::Lease c = pool.Borrow();
  const WorldPool::Lease d = pool.Borrow();
  EXPECT_EQ(c.get(), slot);
  EXPECT_NE(d.get(), slot);
  EXPECT_EQ(pool.Size(), 2);
}

TEST(WorldPool, ReusesReleasedSlots) {
  WorldPool pool;
  std::set<WorkerSlot*> lent;
  {
    const WorldPool::Lease a = pool.Borrow();
    const WorldPool::Lease b = pool.Borrow();
    EXPECT_NE(a.get(), b.get());
    lent = {a.get(), b.get()};
  }
  const WorldPool::Lease again = pool.Borrow();
  EXPECT_EQ(lent.count(again.get()), 1u);  // a returned slot, not a new one
  EXPECT_EQ(pool.Size(), 2);
}

}  // namespace
}  // namespace quadtune::engine
