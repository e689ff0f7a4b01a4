// The progress line's ETA (experiments/eta.hpp): the cost fit, the bookkeeping of progress
// reports and the plan of an experiment file, on given numbers (no clock).
#include "eta.hpp"

#include <gtest/gtest.h>

#include <string>

namespace quadtune::cli {
namespace {

engine::Progress Report(const std::string& method, int repeat, int flights_done,
                        int flights_total, long resolves, double elapsed_s) {
  return engine::Progress{.method = method, .repeat = repeat, .flights_done = flights_done,
                          .flights_total = flights_total, .short_evals = resolves,
                          .elapsed_s = elapsed_s};
}

TEST(CostFit, SeparatesFlightAndResolveCostsFromTwoMixes) {
  // Made with 2 s per flight and 0.01 s per re-solve.
  CostFit fit;
  fit.Add(4.0, 2.0, 0.0);
  fit.Add(12.0, 2.0, 800.0);
  fit.Add(6.0, 1.0, 400.0);
  EXPECT_NEAR(fit.FlightCost(), 2.0, 1e-9);
  EXPECT_NEAR(fit.ResolveCost(), 0.01, 1e-12);
  const Eta eta = fit.Cost(10.0, 1000.0);
  EXPECT_NEAR(eta.seconds, 30.0, 1e-9);
  EXPECT_FALSE(eta.lower_bound);
  EXPECT_EQ(eta.Text(), "ETA 30 s");
}

TEST(CostFit, LeastSquaresOverNoisyIncrements) {
  // ΔT = 3·ΔF + 0.5·ΔR, the first two ± 1 s.
  CostFit fit;
  fit.Add(4.0, 1.0, 0.0);  // 3 + 1
  fit.Add(2.0, 1.0, 0.0);  // 3 - 1
  fit.Add(4.0, 1.0, 2.0);  // 4
  fit.Add(5.0, 0.0, 10.0);  // 5
  // Σf² = 3, Σfr = 2, Σr² = 104, Σft = 10, Σrt = 58; det = 308;
  // a = (10·104 - 58·2) / 308 = 3, b = (3·58 - 2·10) / 308 = 0.5.
  EXPECT_NEAR(fit.FlightCost(), 3.0, 1e-12);
  EXPECT_NEAR(fit.ResolveCost(), 0.5, 1e-12);
}

TEST(CostFit, UnmeasuredKindMakesALowerBound) {
  CostFit fit;
  EXPECT_LT(fit.FlightCost(), 0.0);
  EXPECT_TRUE(fit.Cost(1.0, 0.0).lower_bound);
  fit.Add(9.0, 3.0, 0.0);
  EXPECT_NEAR(fit.FlightCost(), 3.0, 1e-12);
  EXPECT_LT(fit.ResolveCost(), 0.0);
  const Eta eta = fit.Cost(5.0, 100.0);
  EXPECT_NEAR(eta.seconds, 15.0, 1e-12);
  EXPECT_TRUE(eta.lower_bound);
  EXPECT_EQ(eta.Text(), "ETA > 15 s");
  EXPECT_FALSE(fit.Cost(5.0, 0.0).lower_bound);  // nothing of the unknown kind is left
}

TEST(CostFit, OneMixSplitsTheTimeInHalves) {
  // Every increment: 2 flights and 100 re-solves in 10 s (a bo_pso-only run).
  CostFit fit;
  fit.Add(10.0, 2.0, 100.0);
  fit.Add(20.0, 4.0, 200.0);
  EXPECT_NEAR(fit.FlightCost(), 2.5, 1e-12);
  EXPECT_NEAR(fit.ResolveCost(), 0.05, 1e-12);
  EXPECT_NEAR(fit.Cost(4.0, 200.0).seconds, 20.0, 1e-9);  // exact for the same mix
}

TEST(CostFit, NegativeCostIsClampedToTheOneVariableFit) {
  // Re-solves that look free: the unconstrained fit gives b < 0, so b = 0 and a = Σft/Σf².
  CostFit fit;
  fit.Add(10.0, 2.0, 0.0);
  fit.Add(8.0, 2.0, 100.0);
  EXPECT_NEAR(fit.ResolveCost(), 0.0, 1e-12);
  EXPECT_NEAR(fit.FlightCost(), (20.0 + 16.0) / 8.0, 1e-12);
  // Ignored: no work, or no time.
  fit.Add(0.0, 3.0, 0.0);
  fit.Add(5.0, 0.0, 0.0);
  EXPECT_NEAR(fit.FlightCost(), 4.5, 1e-12);
}

TEST(EtaEstimator, ChargesFlightsResolvesRechecksAndValidationLeft) {
  WorkPlan plan;
  plan.trials = {{"default", 0, 2, 0, 0}, {"bo_pso", 0, 4, 2, 400}};
  plan.validations = {{0, 6, 2.0}};
  EtaEstimator eta(plan);
  // The defaults: 2 flights in 4 s → 2 s per flight; re-solves not measured yet.
  eta.Observe(Report("default", 0, 2, 2, 0, 4.0), 4.0);
  EXPECT_NEAR(eta.Pooled().FlightCost(), 2.0, 1e-12);
  Eta left = eta.Remaining();
  // bo_pso not measured: its 4 flights and 2 re-check flights at the pooled 2 s per flight,
  // 6 validation flights × 2 s / 2, re-solves not charged.
  EXPECT_NEAR(left.seconds, 12.0 + 6.0, 1e-9);
  EXPECT_TRUE(left.lower_bound);
  EXPECT_EQ(left.Text(), "ETA > 18 s");
  // bo_pso's first round: 2 flights and 200 re-solves in 6 s (a handover: not in bo_pso's own
  // fit). The pooled fit separates the kinds: 2 s per flight (the defaults) and
  // (6 - 2·2) / 200 = 0.01 s per re-solve.
  eta.Observe(Report("bo_pso", 0, 2, 4, 200, 10.0), 10.0);
  EXPECT_NEAR(eta.Pooled().ResolveCost(), 0.01, 1e-12);
  EXPECT_EQ(eta.MethodFit("bo_pso"), nullptr);
  left = eta.Remaining();
  EXPECT_NEAR(left.seconds, (2 + 2) * 2.0 + 200 * 0.01 + 6.0, 1e-9);
  EXPECT_FALSE(left.lower_bound);
  // Its next round, 2 flights and 200 re-solves in 6 s: its own fit has one mix, 3 s per flight
  // with its 100 re-solves, half to each kind.
  eta.Observe(Report("bo_pso", 0, 4, 4, 400, 16.0), 16.0);
  ASSERT_NE(eta.MethodFit("bo_pso"), nullptr);
  EXPECT_NEAR(eta.MethodFit("bo_pso")->FlightCost(), 1.5, 1e-12);
  EXPECT_NEAR(eta.Remaining().seconds, 4.0 + 6.0, 1e-9);  // its re-checks, then validation
  EXPECT_NEAR(eta.FlightsDone(), 6.0, 1e-12);
  // The first validation flights (after the re-checks): validation's rate is not measured yet.
  eta.Observe(Report("validation", -1, 2, 6, 0, 7.0), 23.0);
  EXPECT_NEAR(eta.FlightsDone(), 2 + 4 + 2 + 2, 1e-12);
  EXPECT_NEAR(eta.Remaining().seconds, 4 * 2.0 / 2.0, 1e-9);
  eta.Observe(Report("validation", -1, 4, 6, 0, 10.0), 26.0);  // 2 flights in 3 s
  EXPECT_NEAR(eta.Remaining().seconds, 2 * 1.5, 1e-9);
  eta.Observe(Report("validation", -1, 6, 6, 0, 13.0), 29.0);
  EXPECT_NEAR(eta.Remaining().seconds, 0.0, 1e-12);
}

TEST(EtaEstimator, ChargesEachMethodItsOwnMeasuredRate) {
  // random flies 1 s flights, bo 5 s flights (its acquisition and slower parameters); the
  // pooled rate (3 s per flight) would charge the 12 flights of repeat 1 36 s instead of 28 s.
  WorkPlan plan;
  plan.trials = {{"random", 0, 4, 0, 0}, {"bo", 0, 4, 0, 0}, {"random", 1, 8, 0, 0},
                 {"bo", 1, 4, 0, 0}};
  EtaEstimator eta(plan);
  eta.Observe(Report("random", 0, 2, 4, 0, 2.0), 2.0);
  eta.Observe(Report("random", 0, 4, 4, 0, 4.0), 4.0);
  // bo not measured yet: the pooled 1 s per flight, a known cost (flights only).
  EXPECT_NEAR(eta.Remaining().seconds, 4 + 8 + 4, 1e-9);
  EXPECT_FALSE(eta.Remaining().lower_bound);
  eta.Observe(Report("bo", 0, 2, 4, 0, 14.0), 14.0);
  eta.Observe(Report("bo", 0, 4, 4, 0, 24.0), 24.0);
  ASSERT_NE(eta.MethodFit("random"), nullptr);
  EXPECT_NEAR(eta.MethodFit("random")->FlightCost(), 1.0, 1e-12);
  EXPECT_NEAR(eta.MethodFit("bo")->FlightCost(), 5.0, 1e-12);
  EXPECT_NEAR(eta.Pooled().FlightCost(), 3.0, 1e-12);
  // Repeat 1: 8 random flights at 1 s and 4 bo flights at 5 s.
  EXPECT_NEAR(eta.Remaining().seconds, 8.0 + 20.0, 1e-9);
  eta.Observe(Report("random", 1, 8, 8, 0, 32.0), 32.0);
  EXPECT_NEAR(eta.Remaining().seconds, 20.0, 1e-9);
}

TEST(EtaEstimator, ChargesEachTrialItsMethodsMeasuredTail) {
  // bo: 1 s per flight; after its budget the re-checks (at least 2 flights) took 6 s.
  WorkPlan plan;
  plan.trials = {{"bo", 0, 4, 2, 0}, {"bo", 1, 4, 2, 0}};
  EtaEstimator eta(plan);
  // Repeat `repeat` of bo has flown `flights` of its 4 flights at `t` s.
  const auto bo = [&eta](int repeat, int flights, double t) {
    eta.Observe(Report("bo", repeat, flights, 4, 0, t), t);
  };
  bo(0, 2, 2.0);
  bo(0, 4, 4.0);
  // No tail measured: the fewest re-check flights at the pooled 1 s, for both trials.
  EXPECT_NEAR(eta.Remaining().seconds, 2.0 + 4.0 + 2.0, 1e-9);
  // Repeat 1's first 2 flights (2 s at bo's rate) came 8 s after repeat 0's last report: a 6 s
  // tail, charged to repeat 1 too.
  bo(1, 2, 12.0);
  EXPECT_NEAR(eta.Remaining().seconds, 2.0 + 6.0, 1e-9);
  bo(1, 4, 14.0);
  EXPECT_NEAR(eta.Remaining().seconds, 6.0, 1e-9);
  EXPECT_NEAR(eta.MethodFit("bo")->FlightCost(), 1.0, 1e-12);
}

TEST(EtaEstimator, ReportsWithoutNewWorkLeaveTheTimeToTheNextIncrement) {
  WorkPlan plan;
  plan.trials = {{"pso", 0, 8, 0, 0}};
  EtaEstimator eta(plan);
  eta.Observe(Report("pso", 0, 2, 8, 0, 2.0), 2.0);     // the job's start: not projected
  eta.Observe(Report("pso", 0, 4, 8, 0, 6.0), 6.0);     // 2 flights in 4 s
  eta.Observe(Report("pso", 0, 4, 8, 0, 7.0), 7.0);     // no new work: no increment
  eta.Observe(Report("bo", 0, 1, 8, 0, 8.0), 8.0);      // not in the plan
  eta.Observe(Report("pso", 0, 2, 8, 0, 1.0), 8.5, 3);  // a run the plan does not hold
  eta.Observe(Report("pso", 0, 6, 8, 0, 10.0), 10.0);   // 2 flights in 4 s, from 6 s
  EXPECT_NEAR(eta.FlightsDone(), 6.0, 1e-12);
  ASSERT_NE(eta.MethodFit("pso"), nullptr);
  EXPECT_NEAR(eta.MethodFit("pso")->FlightCost(), 2.0, 1e-12);
  EXPECT_NEAR(eta.Remaining().seconds, 4.0, 1e-9);
}

TEST(EtaEstimator, CountsTheResolvesOfTrialsFinishedOnOtherRanks) {
  WorkPlan plan;
  plan.trials = {{"bo_pso", 0, 2, 0, 100}, {"bo_pso", 1, 2, 0, 100}};
  EtaEstimator eta(plan);
  // Rank 0 runs repeat 0: 1 flight and 50 re-solves in 3 s.
  eta.Observe(Report("bo_pso", 0, 1, 2, 50, 3.0), 3.0);
  // Rank 1 reports repeat 1 finished: its 2 flights and 100 re-solves are done; rank 0's
  // counter still says 50 re-solves.
  engine::Progress remote = Report("bo_pso", 1, 2, 2, 50, 5.0);
  remote.rank = 1;
  eta.Observe(remote, 5.0);
  EXPECT_NEAR(eta.FlightsDone(), 3.0, 1e-12);
  // The pooled fit from now on: increments (3 s, 1 flight, 50 re-solves) and (2 s, 2 flights,
  // 100 re-solves), one mix (50 re-solves per flight), Σ f·t / Σ f² = 7 / 5 = 1.4 s per flight
  // with its re-solves; left: 1 flight and its 50 re-solves.
  EXPECT_NEAR(eta.Remaining().seconds, 1.4, 1e-9);
}

TEST(EtaEstimator, StudyRunsKeepTheirOwnResolveCountersAndValidations) {
  // Two runs (a study's two stages), each a bo_pso trial of 2 flights and 100 re-solves; the
  // point's validation after the second: 4 flights.
  WorkPlan plan;
  plan.trials = {{"bo_pso", 0, 2, 0, 100, 0}, {"bo_pso", 0, 2, 0, 100, 1}};
  plan.validations = {{1, 4, 1.0}};
  EtaEstimator eta(plan);
  eta.Observe(Report("bo_pso", 0, 2, 2, 100, 10.0), 10.0, 0);  // 10 s per trial
  EXPECT_NEAR(eta.Remaining().seconds, 10.0 + 4 * 2.5, 1e-9);
  // Run 1's counter starts at 0 again: 50 of its re-solves, not -50.
  eta.Observe(Report("bo_pso", 0, 1, 2, 50, 5.0), 15.0, 1);
  EXPECT_NEAR(eta.Remaining().seconds, 5.0 + 4 * 2.5, 1e-9);
  eta.Observe(Report("bo_pso", 0, 2, 2, 100, 10.0), 20.0, 1);
  eta.Observe(Report("validation", -1, 1, 4, 0, 0.0), 23.0, 1);
  eta.Observe(Report("validation", -1, 2, 4, 0, 0.0), 26.0, 1);  // 3 s per validation flight
  EXPECT_NEAR(eta.Remaining().seconds, 2 * 3.0, 1e-9);
  EXPECT_NEAR(eta.FlightsDone(), 6.0, 1e-12);
  EXPECT_NEAR(eta.FlightsPlanned(), 2 + 2 + 4, 1e-12);
}

TEST(EtaEstimator, ChargesTheFiguresAndTheReportUntilTheyAreDrawn) {
  WorkPlan plan;
  plan.trials = {{"random", 0, 4, 0, 0}};
  plan.drawing = {true, 3, 2.0};
  EtaEstimator eta(plan);
  eta.Observe(Report("random", 0, 2, 4, 0, 4.0), 4.0);
  eta.Observe(Report("random", 0, 4, 4, 0, 8.0), 8.0);  // 2 flights in 4 s each: 2 s per flight
  // The trials are done; left: the report's 3 flights flown again one at a time (each as long
  // as the 2 flights a round flies at once) and the scripts.
  EXPECT_NEAR(eta.Remaining().seconds, 3 * 2.0 * 2.0 + kScriptSeconds, 1e-9);
  EXPECT_FALSE(eta.Remaining().lower_bound);
  eta.Finished();
  EXPECT_NEAR(eta.Remaining().seconds, 12.0 + kScriptSeconds, 1e-9);
  // Before any flight cost is measured the report's flights are of unknown cost.
  EXPECT_TRUE(EtaEstimator(plan).Remaining().lower_bound);
  // --no-plot: nothing is drawn, nothing left.
  plan.drawing = {};
  EtaEstimator bare(plan);
  bare.Observe(Report("random", 0, 2, 4, 0, 4.0), 4.0);
  bare.Observe(Report("random", 0, 4, 4, 0, 8.0), 8.0);
  EXPECT_NEAR(bare.Remaining().seconds, 0.0, 1e-12);
}

TEST(EtaEstimator, LeavesNothingWhenAResumedJobHasDoneItsWork) {
  // A bo_pso trial (4 flights, 400 re-solves) and 6 validation flights, resumed after its first
  // round (2 flights, 200 re-solves) and 4 validation flights were stored.
  WorkPlan plan;
  plan.trials = {{"bo_pso", 0, 4, 0, 400}};
  plan.validations = {{0, 6, 1.0}};
  EtaEstimator eta(plan);
  // The replayed round reports its flights but no re-solves (stored ones are not re-solved).
  eta.Observe(Report("bo_pso", 0, 2, 4, 0, 0.5), 0.5);
  eta.Observe(Report("bo_pso", 0, 4, 4, 200, 4.5), 4.5);  // a new round
  // Pooled fit over (0.5 s, 2, 0) and (4 s, 2, 200): a = 0.25 s per flight, b = 0.0175 s per
  // re-solve. The trial's 200 replayed re-solves are not left; the 6 planned validation flights
  // are (at 0.25 s).
  EXPECT_NEAR(eta.Pooled().FlightCost(), 0.25, 1e-12);
  EXPECT_NEAR(eta.Remaining().seconds, 6 * 0.25, 1e-9);
  // Validation flies only the 2 flights not stored.
  eta.Observe(Report("validation", -1, 1, 2, 0, 1.0), 5.5);
  EXPECT_NEAR(eta.Remaining().seconds, 0.25, 1e-9);
  eta.Observe(Report("validation", -1, 2, 2, 0, 2.0), 6.5);
  EXPECT_NEAR(eta.Remaining().seconds, 0.0, 1e-12);
  EXPECT_FALSE(eta.Remaining().lower_bound);
  // Every validation flight stored: no validation report comes; the job's end says it is done.
  EtaEstimator stored(plan);
  stored.Observe(Report("bo_pso", 0, 2, 4, 0, 0.5), 0.5);
  stored.Observe(Report("bo_pso", 0, 4, 4, 200, 4.5), 4.5);
  EXPECT_GT(stored.Remaining().seconds, 1.0);
  stored.Finished();
  EXPECT_NEAR(stored.Remaining().seconds, 0.0, 1e-12);
  EXPECT_NEAR(stored.FlightsDone(), stored.FlightsPlanned(), 1e-12);
}

TEST(WorkPlan, PlansTheReportsFlightsFlownAgain) {
  // tiny.yaml: one method, 2 flights a round on 2 threads.
  const engine::Experiment e = engine::Experiment::LoadFile(
      std::string(QUADTUNE_SOURCE_DIR) + "/experiments/tiny.yaml");
  WorkPlan plan = WorkPlan::Of(e, 2);
  EXPECT_FALSE(plan.drawing.on);
  plan.AddDrawing(e, 2, 1);
  EXPECT_TRUE(plan.drawing.on);
  EXPECT_EQ(plan.drawing.replay_flights, 1);  // the best flight of its one method
  EXPECT_NEAR(plan.drawing.flights_at_once, 2.0, 1e-12);
  plan.AddDrawing(e, 1, 5);  // 5 stores (a study's stages): `report`'s default 3 flights
  EXPECT_EQ(plan.drawing.replay_flights, 3);
  EXPECT_NEAR(plan.drawing.flights_at_once, 1.0, 1e-12);
}

TEST(WorkPlan, CountsAnExperimentFilesWork) {
  const engine::Experiment e = engine::Experiment::LoadFile(
      std::string(QUADTUNE_SOURCE_DIR) + "/experiments/tiny.yaml",
      {"methods=[default, bo, bo_pso]", "repeats=2", "recommend.candidates=3",
       "recommend.flights=2", "budget.default_flights=5", "budget.flight_batch=1"});
  const WorkPlan plan = WorkPlan::Of(e, 4);
  ASSERT_EQ(plan.trials.size(), 6U);
  EXPECT_EQ(plan.trials[0].method, "default");
  EXPECT_EQ(plan.trials[0].flights, 5);
  EXPECT_EQ(plan.trials[0].recheck_flights, 0);
  EXPECT_EQ(plan.trials[1].method, "bo");
  EXPECT_EQ(plan.trials[1].flights, 3);
  EXPECT_EQ(plan.trials[1].recheck_flights, 2);
  EXPECT_EQ(plan.trials[1].resolves, 0);
  EXPECT_EQ(plan.trials[5].method, "bo_pso");
  EXPECT_EQ(plan.trials[5].repeat, 1);
  EXPECT_EQ(plan.trials[5].run, 0);
  EXPECT_EQ(plan.trials[5].resolves, 4 * 3 * 2);  // short_evals_per_flight × flights × queries
  ASSERT_EQ(plan.validations.size(), 1U);
  EXPECT_EQ(plan.validations[0].flights, 2 * (1 + 4));   // maps × (defaults + tuned trials)
  EXPECT_NEAR(plan.validations[0].speedup, 4.0, 1e-12);  // 4 threads against 1 flight at once
}

TEST(WorkPlan, CountsAStudysStagesAndValidationPerPoint) {
  // Two drones (points) × two stages (30 then 20 bo flights), 20 validation flights of each
  // stage's tuned trial and of the defaults per point.
  const engine::Study s = engine::Study::LoadFile(
      std::string(QUADTUNE_SOURCE_DIR) + "/experiments/refinement_study.yaml",
      {"override.recommend.candidates=0"});
  const WorkPlan plan = WorkPlan::Of(s, 2);
  ASSERT_EQ(plan.trials.size(), 4U);
  for (int i = 0; i < 4; ++i) {
    EXPECT_EQ(plan.trials[static_cast<std::size_t>(i)].run, i);
    EXPECT_EQ(plan.trials[static_cast<std::size_t>(i)].method, "bo");
    EXPECT_EQ(plan.trials[static_cast<std::size_t>(i)].recheck_flights, 0);
  }
  EXPECT_EQ(plan.trials[0].flights, 30);
  EXPECT_EQ(plan.trials[1].flights, 20);
  ASSERT_EQ(plan.validations.size(), 2U);
  EXPECT_EQ(plan.validations[0].run, 1);  // after point 0's last stage
  EXPECT_EQ(plan.validations[1].run, 3);
  EXPECT_EQ(plan.validations[0].flights, 20 * (2 + 1));
}

}  // namespace
}  // namespace quadtune::cli
