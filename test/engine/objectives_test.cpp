#include <gtest/gtest.h>

#include "quadtune/engine/experiment/objectives.hpp"

namespace quadtune::engine {
namespace {

TEST(Objectives, LongTermIsFlightTimePlusCollisionAndStopPenalties) {
  ObjectiveOptions o;
  o.w_e = 5.0;
  FlightRecord f;
  f.completed = true;
  f.flight_time = 10.0;
  f.collisions = 2;
  f.emergency_stops = 1;
  const ObjectiveValue v = LongTermObjective(f, o);
  EXPECT_DOUBLE_EQ(v.value, 10.0 + 10.0 * 2 + 5.0 * 1);  // t_f + t_f n_c + w_e n_e
  EXPECT_DOUBLE_EQ(v.terms.at("t_f"), 10.0);
  EXPECT_DOUBLE_EQ(v.terms.at("n_c"), 2.0);
}

TEST(Objectives, FailedOrIncompleteFlightGetsFailureValue) {
  ObjectiveOptions o;
  o.failure_value = 777.0;
  FlightRecord f;
  f.status = EvalStatus::kFailed;
  EXPECT_DOUBLE_EQ(LongTermObjective(f, o).value, 777.0);
  f.status = EvalStatus::kOk;
  f.completed = false;
  f.flight_time = 3.0;
  EXPECT_DOUBLE_EQ(LongTermObjective(f, o).value, 777.0);
}

TEST(Objectives, ShortTermSolveTimeUsesComputeUnitsInReproducibleMode) {
  ObjectiveOptions o;
  o.w_t = 2.0;
  o.w_s = 0.5;
  o.w_tau = 100.0;
  o.tau_t = 0.01;
  o.unit_time = 1e-4;
  ResolveRecord s;
  s.success = true;
  s.compute_units = 200.0;  // 0.02 s
  s.solve_time_s = 123.0;   // ignored in reproducible mode
  s.failed_attempts = 1;
  const double t_c = 0.02;
  const double j_t = t_c + 100.0 * (t_c - 0.01) * (t_c - 0.01);
  EXPECT_DOUBLE_EQ(ShortTermObjective(s, o, TimingMode::kReproducible).value, 2.0 * j_t + 0.5 * 1);
  // Realtime: t_c is the wall clock.
  s.solve_time_s = 0.005;
  EXPECT_DOUBLE_EQ(ShortTermObjective(s, o, TimingMode::kRealtime).value, 2.0 * 0.005 + 0.5);
}

TEST(Objectives, SolveTimeClearanceTermIsOffUnlessGiven) {
  ResolveRecord s;
  s.success = true;
  s.compute_units = 30.0;  // 3 ms
  s.failed_attempts = 0;
  s.min_clearance = 0.3;
  const ObjectiveOptions paper =
      ObjectiveOptions::FromYaml(YamlMap::FromString("short_term: {kind: solve_time}\n", "o.yaml"));
  EXPECT_DOUBLE_EQ(ShortTermObjective(s, paper, TimingMode::kReproducible).value, 0.003);
  const ObjectiveOptions with_c = ObjectiveOptions::FromYaml(YamlMap::FromString(
      "short_term: {kind: solve_time, w_c: 0.1, clearance: 0.5}\n", "o.yaml"));
  const auto v = ShortTermObjective(s, with_c, TimingMode::kReproducible);
  EXPECT_DOUBLE_EQ(v.terms.at("J_c"), 0.2 * 0.2);
  EXPECT_DOUBLE_EQ(v.value, 0.003 + 0.1 * 0.04);
  s.min_clearance = 0.6;  // beyond C: no penalty
  EXPECT_DOUBLE_EQ(ShortTermObjective(s, with_c, TimingMode::kReproducible).value, 0.003);
}

TEST(Objectives, ChangingEnvironmentPenalisesClearanceBelowDesired) {
  ObjectiveOptions o;
  o.short_kind = ObjectiveOptions::ShortKind::kChangingEnvironment;
  o.w_t = 1.0;
  o.w_p = 0.01;
  o.w_c = 100.0;
  o.clearance = 0.5;
  ResolveRecord s;
  s.success = true;
  s.duration = 3.0;
  s.jerk_integral = 10.0;
  s.min_clearance = 0.3;
  EXPECT_NEAR(ShortTermObjective(s, o, TimingMode::kReproducible).value,
              3.0 + 0.1 + 100.0 * 0.04, 1e-12);
  s.min_clearance = 0.8;
  EXPECT_NEAR(ShortTermObjective(s, o, TimingMode::kReproducible).value, 3.1, 1e-12);
}

}  // namespace
}  // namespace quadtune::engine
