// Failures inside single evaluations of the real (Ipopt) planner, each provoked through inputs
// an experiment file accepts, end up as stored rows that say what went wrong, and the run still
// completes its budget: a world whose wind blows the drone past World::HasDiverged's bounds, a
// goal below the ground that no flight can reach (stall), a flight time limit too short for the
// mission (timeout), and an acceleration limit no trajectory can keep (every solve rejected).
// Each row's state (EvalState) names the failure; its message gives the reason in words.
#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "quadtune/engine/planners/planners.hpp"
#include "quadtune/engine/store/result_store.hpp"
#include "quadtune/engine/tuning/tuner.hpp"
#include "test_util.hpp"

namespace quadtune::engine {
namespace {

// experiments/tiny.yaml with `quadtune run --set` assignments, no held-out validation.
Experiment TinyWith(std::vector<std::string> assignments) {
  assignments.push_back("validation.maps=0");
  return Experiment::LoadFile(std::string(QUADTUNE_SOURCE_DIR) + "/experiments/tiny.yaml",
                              assignments);
}

struct StoredRun {
  RunSummary summary;
  std::vector<EvaluationRow> rows;
  std::vector<TrialRow> trials;
};

StoredRun RunStored(const Experiment& e, const std::string& name) {
  RunOptions o;
  o.store_path = test::TempDir(name) + "/r.sqlite";
  StoredRun run;
  run.summary = RunExperiment(e, o);
  ResultStore store(o.store_path);
  run.rows = store.Evaluations();
  run.trials = store.Trials();
  return run;
}

std::vector<EvaluationRow> RowsOfKind(const StoredRun& run, EvalKind kind) {
  std::vector<EvaluationRow> out;
  for (const auto& r : run.rows) {
    if (r.kind == kind) out.push_back(r);
  }
  return out;
}

// The run ended normally and every trial was finished, not abandoned.
void ExpectRunCompleted(const StoredRun& run, std::size_t trials) {
  EXPECT_EQ(run.summary.status, RunStatus::kCompleted) << run.summary.message;
  ASSERT_EQ(run.trials.size(), trials);
  for (const auto& t : run.trials) EXPECT_EQ(t.status, TrialStatus::kDone) << ToString(t.method);
}

// tiny.yaml's failure_value.
constexpr double kFailureValue = 1000.0;

// A 10⁶ m/s side wind (any finite wind is accepted) pushes the drone through drag past the
// 10 km box within a second: World::HasDiverged ends each flight, the row is "failed" with the
// divergence named, and both methods still fly their whole budget.
TEST(RealPlannerFailureRows, DivergedFlightIsAFailedRowAndTheRunGoesOn) {
  const StoredRun run = RunStored(TinyWith({"planner.world={wind: [0, 1.0e6, 0]}",
                                            "methods=[default, random]", "budget.flights=2"}),
                                  "failure_diverged");
  ExpectRunCompleted(run, 2);
  const std::vector<EvaluationRow> flights = RowsOfKind(run, EvalKind::kLong);
  ASSERT_EQ(flights.size(), 4u);  // 2 methods x 2 flights
  for (const auto& r : flights) {
    EXPECT_EQ(r.status, EvalStatus::kFailed) << ToString(r.method);
    EXPECT_EQ(r.state, EvalState::kDiverged) << ToString(r.method);
    EXPECT_EQ(r.message, "diverged: the simulation diverged") << ToString(r.method);
    EXPECT_EQ(r.value, kFailureValue);
    EXPECT_EQ(nlohmann::json::parse(r.terms)["completed"], 0.0);
  }
  for (const auto& t : run.summary.trials) EXPECT_EQ(t.failed, 2) << t.method;
}

// A goal 1 m below the ground: the drone flies to the ground above it and hovers there. The
// stall check (no progress within FlightOptions::stall_time, 15 s) ends the flight long before
// max_time (40 s); the row says so and scores the failure value.
TEST(RealPlannerFailureRows, StalledFlightIsStoredWithItsReasonAndTheRunGoesOn) {
  const StoredRun run =
      RunStored(TinyWith({"planner.layout.mission.goal=[8.0, 0.0, -1.0]", "planner.mission=go_to",
                          "methods=[default]", "budget.flights=2"}),
                "failure_stalled");
  ExpectRunCompleted(run, 1);
  const std::vector<EvaluationRow> flights = RowsOfKind(run, EvalKind::kLong);
  ASSERT_EQ(flights.size(), 2u);
  for (const auto& r : flights) {
    EXPECT_EQ(r.status, EvalStatus::kOk);  // the flight ran; it just could not finish
    EXPECT_EQ(r.state, EvalState::kStalled);
    EXPECT_EQ(r.message.rfind("stalled: no progress: moved ", 0), 0u) << r.message;
    EXPECT_EQ(r.value, kFailureValue);
    const nlohmann::json terms = nlohmann::json::parse(r.terms);
    EXPECT_EQ(terms["completed"], 0.0);
    EXPECT_LT(terms["t_f"].get<double>(), 40.0) << "ended by max_time, not by the stall check";
    EXPECT_GE(terms["t_f"].get<double>(), 15.0);  // at least one stall window
  }
}

// max_time 2 s for a 16 m go-and-return: every flight is cut, stored as a timeout after 2 s.
TEST(RealPlannerFailureRows, TimedOutFlightIsStoredWithItsReasonAndTheRunGoesOn) {
  const StoredRun run =
      RunStored(TinyWith({"planner.max_time=2", "methods=[default, random]", "budget.flights=2"}),
                "failure_timeout");
  ExpectRunCompleted(run, 2);
  const std::vector<EvaluationRow> flights = RowsOfKind(run, EvalKind::kLong);
  ASSERT_EQ(flights.size(), 4u);
  for (const auto& r : flights) {
    EXPECT_EQ(r.status, EvalStatus::kOk);
    EXPECT_EQ(r.state, EvalState::kTimeout);
    EXPECT_EQ(r.message, "timeout: mission not finished within max_time");
    EXPECT_EQ(r.value, kFailureValue);
    EXPECT_NEAR(nlohmann::json::parse(r.terms)["t_f"].get<double>(), 2.0, 0.02);
  }
}

// a_max = 0.001 m/s² (any positive limit is accepted): no trajectory to the local goal keeps it,
// so every back-end attempt is rejected. In flight each re-plan falls back to stop-and-go; the
// short-term re-solves of the recorded queries fail on every attempt. The rows record it in
// their terms (success 0, n_s = max_attempts) and the optimisers are still told a value.
TEST(RealPlannerFailureRows, RejectedSolvesAreCountedInTheRowsAndTheRunGoesOn) {
  const Experiment e =
      TinyWith({"planner.fixed={a_max: 0.001}", "methods=[bo_pso]", "budget.flights=1"});
  // The back end's own verdict on one recorded query.
  {
    WorkerSlot slot;
    std::vector<Opaque> queries;
    (void)test::FlyRecordingQueries(e.planner, e.MapSeed(0), slot, &queries);
    ASSERT_FALSE(queries.empty());
    const ResolveRecord r = e.planner.Resolve(queries.front(), {});
    EXPECT_FALSE(r.success);
    EXPECT_EQ(r.failed_attempts, 3);  // PlannerParams::max_attempts
    EXPECT_NE(r.message.find("exceed the limits"), std::string::npos) << r.message;
  }
  const StoredRun run = RunStored(e, "failure_solver");
  ExpectRunCompleted(run, 1);
  const std::vector<EvaluationRow> flights = RowsOfKind(run, EvalKind::kLong);
  ASSERT_EQ(flights.size(), 1u);
  const nlohmann::json flight = nlohmann::json::parse(flights[0].terms);
  EXPECT_GT(flight["plans"].get<double>(), 0.0);
  EXPECT_EQ(flight["fallback_plans"], flight["plans"]);  // no plan of the back end was accepted
  EXPECT_EQ(flight["failed_attempts"].get<double>(), 3.0 * flight["plans"].get<double>());
  EXPECT_EQ(flight["completed"], 0.0);
  EXPECT_EQ(flights[0].state, EvalState::kSolverFailure) << flights[0].message;
  const std::vector<EvaluationRow> solves = RowsOfKind(run, EvalKind::kShort);
  ASSERT_EQ(solves.size(), 4u);  // short_evals_per_flight
  for (const auto& r : solves) {
    const nlohmann::json terms = nlohmann::json::parse(r.terms);
    EXPECT_EQ(terms["success"], 0.0) << r.params;
    EXPECT_EQ(terms["n_s"], 3.0) << r.params;
    // The failure is the planner's answer, not an engine error.
    EXPECT_EQ(r.status, EvalStatus::kOk);
    EXPECT_EQ(r.state, EvalState::kSolverFailure);
    EXPECT_TRUE(std::isfinite(r.value));
  }
}

}  // namespace
}  // namespace quadtune::engine
