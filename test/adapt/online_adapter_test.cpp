// Tests of the online v_des adaptation (engine::OnlineAdapter) in kinematic flights (the drone is
// where the reference says, the map holds a small forest), and of the experiment file.
#include "quadtune/engine/adaptation/online_adaptation.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>

#include "../config_error_util.hpp"
#include "quadtune/engine/api/planner_registry.hpp"
#include "quadtune/engine/planners/planners.hpp"
#include "quadtune/planning/ego/ego_optimizer.hpp"
#include "../planning/scene_util.hpp"

namespace quadtune::engine {
namespace {

using quadtune::test::ThrowsConfigError;

using planning::PlannerParams;

AdaptationOptions SmallOptions(int trials = 4) {
  AdaptationOptions o;
  o.trials_per_segment = trials;
  o.seed = 7;
  return o;
}

/// The Replanner with an OnlineAdapter, both planning with `backend` (default: the Ipopt back
/// end), flying with perfect tracking through a mapped forest.
struct AdaptedKinematicFlight {
  explicit AdaptedKinematicFlight(
      const AdaptationOptions& options,
      std::shared_ptr<const planning::TrajectoryBackend> flight_backend = MakeIpoptBackend())
      : backend(std::move(flight_backend)),
        replanner(*backend, PlannerParams{}),
        adapter(*backend, sim::FlightPlannerOptions{}, options),
        map(planning::LocalMapOptions::FromPlannerParams(PlannerParams{}),
            Eigen::Vector3d(3, 0, 1.2)) {
    replanner.SetAdapter(&adapter);
    map.Insert(Eigen::Vector3d(0, 0, 1.2),
               planning::testing::SurfacePoints(planning::testing::SmallForest()));
  }
  void Fly(const Eigen::Vector3d& goal, double max_time) {
    replanner.StartMission({goal}, p, 0.0, 0.0);
    while (!replanner.Done() && t < max_time) {
      replanner.Tick(t, p, v, map);
      t += 0.01;
      const physics::TrackingReference ref = replanner.Reference(t);
      p = ref.p_W;
      v = ref.v_W;
    }
  }

  std::shared_ptr<const planning::TrajectoryBackend> backend;
  sim::Replanner replanner;
  OnlineAdapter adapter;
  planning::LocalMap map;
  double t = 0.0;
  Eigen::Vector3d p = Eigen::Vector3d(0, 0, 1.2);
  Eigen::Vector3d v = Eigen::Vector3d::Zero();
};

const Eigen::Vector3d kGoal(9.0, 0.0, 1.2);

TEST(OnlineAdapter, AdaptsSegmentsAndReachesTheGoal) {
  AdaptedKinematicFlight f(SmallOptions());
  f.Fly(kGoal, 40.0);
  ASSERT_TRUE(f.replanner.Done()) << sim::ToString(f.replanner.state());
  EXPECT_FALSE(f.adapter.HoldsPeriodicReplan());
  int adopted = 0;
  for (const auto& s : f.adapter.segments()) {
    adopted += s.outcome == AdaptationSegment::Outcome::kAdopted;
  }
  EXPECT_GE(adopted, 2);
}

TEST(OnlineAdapter, TrialRecordsAreCompleteAndFinite) {
  const AdaptationOptions o = SmallOptions();
  AdaptedKinematicFlight f(o);
  f.Fly(kGoal, 40.0);
  const auto& trials = f.adapter.trials();
  const auto& segments = f.adapter.segments();
  ASSERT_FALSE(segments.empty());
  std::size_t k = 0;
  for (const auto& s : segments) {
    if (s.outcome != AdaptationSegment::Outcome::kSuperseded) {
      EXPECT_EQ(s.trials, o.trials_per_segment) << "segment " << s.index;
    }
    EXPECT_LE(s.t0, s.split_time);
    int successes = 0;
    for (int i = 0; i < s.trials; ++i, ++k) {
      ASSERT_LT(k, trials.size());
      const AdaptationTrial& t = trials[k];
      EXPECT_EQ(t.segment, s.index);
      EXPECT_EQ(t.trial, i);
      EXPECT_GE(t.time, s.t0 - 1e-9);
      EXPECT_LE(t.time, s.split_time + 0.011);  // the tick at or just after t_s
      EXPECT_TRUE(t.p_s_W.isApprox(s.p_s_W));
      EXPECT_GE(t.v_des, o.v_min);
      EXPECT_LE(t.v_des, o.v_max);
      for (double x : {t.time, t.t_exe, t.jerk_integral, t.min_clearance, t.j_c, t.f_s,
                       t.compute_units}) {
        EXPECT_TRUE(std::isfinite(x));
      }
      EXPECT_FALSE(t.status.empty());
      if (t.success) {
        ++successes;
        const double gap = o.objective.clearance - t.min_clearance;
        EXPECT_DOUBLE_EQ(t.j_c, t.min_clearance < o.objective.clearance ? gap * gap : 0.0);
        EXPECT_NEAR(t.f_s, o.objective.w_t * t.t_exe + o.objective.w_p * t.jerk_integral +
                               o.objective.w_c * t.j_c, 1e-9 * (1.0 + t.f_s));
        EXPECT_GT(t.t_exe, 0.0);
      } else {
        EXPECT_EQ(t.f_s, o.objective.failure_value);
      }
    }
    EXPECT_EQ(s.successes, successes);
  }
  EXPECT_EQ(k, trials.size());
}

TEST(OnlineAdapter, ExecutesTheBestScoredTrialFromPs) {
  AdaptedKinematicFlight f(SmallOptions());
  f.Fly(kGoal, 40.0);
  const auto& trials = f.adapter.trials();
  const auto& records = f.replanner.records();
  std::size_t k = 0;
  int checked = 0;
  for (const auto& s : f.adapter.segments()) {
    const std::size_t first = k;
    k += static_cast<std::size_t>(s.trials);
    if (s.outcome != AdaptationSegment::Outcome::kAdopted) continue;
    // The chosen trial has the smallest f_s among the successful ones (first one on ties).
    int best = -1;
    for (int i = 0; i < s.trials; ++i) {
      const AdaptationTrial& t = trials[first + static_cast<std::size_t>(i)];
      if (t.success && (best < 0 || t.f_s < trials[first + static_cast<std::size_t>(best)].f_s)) {
        best = i;
      }
      EXPECT_EQ(t.chosen, i == s.best_trial);
    }
    ASSERT_EQ(best, s.best_trial);
    const AdaptationTrial& chosen = trials[first + static_cast<std::size_t>(best)];
    EXPECT_EQ(s.v_des, chosen.v_des);
    // The Replanner executed that plan from P_s at t_s.
    const auto it = std::find_if(records.begin(), records.end(), [&](const auto& r) {
      return r.ok && r.time == s.split_time;
    });
    ASSERT_NE(it, records.end()) << "segment " << s.index;
    EXPECT_EQ(it->duration, chosen.t_exe);
    EXPECT_EQ(it->jerk, chosen.jerk_integral);
    EXPECT_LT((it->trajectory.Position(0.0) - s.p_s_W).norm(), 1e-9);
    ++checked;
  }
  EXPECT_GE(checked, 2);
}

TEST(OnlineAdapter, SameSeedGivesTheSameChoices) {
  AdaptedKinematicFlight a(SmallOptions()), b(SmallOptions());
  a.Fly(kGoal, 40.0);
  b.Fly(kGoal, 40.0);
  ASSERT_EQ(a.adapter.segments().size(), b.adapter.segments().size());
  for (std::size_t i = 0; i < a.adapter.segments().size(); ++i) {
    EXPECT_EQ(a.adapter.segments()[i].v_des, b.adapter.segments()[i].v_des);
    EXPECT_EQ(a.adapter.segments()[i].split_time, b.adapter.segments()[i].split_time);
  }
  ASSERT_EQ(a.adapter.trials().size(), b.adapter.trials().size());
  for (std::size_t i = 0; i < a.adapter.trials().size(); ++i) {
    EXPECT_EQ(a.adapter.trials()[i].v_des, b.adapter.trials()[i].v_des);
    EXPECT_EQ(a.adapter.trials()[i].f_s, b.adapter.trials()[i].f_s);
  }
  EXPECT_EQ(a.replanner.mission_end_time(), b.replanner.mission_end_time());
}

// The adapter plans its trials with the flight's back end: with the EGO back end (occupancy
// snapshots) it adapts too, executes its chosen EGO plan from P_s, and its trials differ from
// the Ipopt back end's.
TEST(OnlineAdapter, PlansItsTrialsWithTheFlightsBackEnd) {
  AdaptedKinematicFlight ego(SmallOptions(),
                             std::make_shared<const planning::EgoBackend>(planning::EgoOptions{}));
  ego.Fly(kGoal, 40.0);
  int adopted = 0;
  std::size_t first = 0;
  for (const auto& s : ego.adapter.segments()) {
    if (s.outcome == AdaptationSegment::Outcome::kAdopted) {
      ++adopted;
      const AdaptationTrial& chosen =
          ego.adapter.trials()[first + static_cast<std::size_t>(s.best_trial)];
      const auto& records = ego.replanner.records();
      const auto it = std::find_if(records.begin(), records.end(),
                                   [&](const auto& r) { return r.ok && r.time == s.split_time; });
      ASSERT_NE(it, records.end()) << "segment " << s.index;
      EXPECT_EQ(it->duration, chosen.t_exe);
      EXPECT_EQ(it->jerk, chosen.jerk_integral);
    }
    first += static_cast<std::size_t>(s.trials);
  }
  EXPECT_GE(adopted, 1);

  AdaptedKinematicFlight ipopt(SmallOptions());
  ipopt.Fly(kGoal, 40.0);
  ASSERT_FALSE(ego.adapter.trials().empty());
  ASSERT_FALSE(ipopt.adapter.trials().empty());
  // The trials' plans are the back end's own.
  EXPECT_NE(ego.adapter.trials().front().jerk_integral,
            ipopt.adapter.trials().front().jerk_integral);
}

// ---- the experiment file ----------------------------------------------------------------------

std::string WriteTemp(const std::string& name, const std::string& text) {
  const auto path = std::filesystem::temp_directory_path() / ("quadtune_adapt_" + name + ".yaml");
  std::ofstream(path) << text;
  return path.string();
}

const char* kMinimal =
    "layout_file: layouts/changing_density_thin.yaml\n"
    "baselines: [2.0]\n";

/// Loads kMinimal + `extra` from a file; expects a ConfigError naming that file and `key`, whose
/// message contains `fragment`.
void ExpectFileKeyError(const std::string& name, const std::string& extra, const std::string& key,
                        const std::string& fragment) {
  const std::string path = WriteTemp(name, std::string(kMinimal) + extra);
  try {
    (void)AdaptExperiment::LoadFile(path);
    FAIL() << "expected a ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.file(), path);
    EXPECT_EQ(e.key(), key);
    EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
  }
}

TEST(AdaptExperiment, UnknownKeyNamesFileAndKey) {
  ExpectFileKeyError("unknown", "adaptation: {trials_per_segmnt: 8}\n",
                     "adaptation.trials_per_segmnt", "trials_per_segment");
}

TEST(AdaptExperiment, ClearanceBeyondTheDistanceFieldsTruncationNamesFileAndKey) {
  ExpectFileKeyError("clearance", "planner: {clearance: 1.5}\n", "clearance", "max_distance");
}

TEST(AdaptExperiment, OutOfRangeValuesNameKeyAndRange) {
  ExpectFileKeyError("range", "adaptation: {lookahead: -1}\n", "adaptation.lookahead", "(0, 20]");
  const auto parse = [](const std::string& text) {
    return [text] { (void)AdaptExperiment::FromString(text, "x.yaml"); };
  };
  EXPECT_TRUE(
      ThrowsConfigError(parse(std::string(kMinimal) + "adaptation: {v_des_bounds: [6, 1]}\n"),
                        "adaptation.v_des_bounds", {"x.yaml", "0 < lo < hi <= 15"}));
  EXPECT_TRUE(ThrowsConfigError(
      parse(std::string(kMinimal) + "adaptation: {objective: {short_term: {kind: solve_time}}}\n"),
      "adaptation.objective.short_term.kind", {"x.yaml", "must be changing_environment"}));
  EXPECT_TRUE(
      ThrowsConfigError(parse("layout_file: layouts/changing_density_thin.yaml\nbaselines: [0]\n"),
                        "baselines", {"x.yaml", "(0, 15]"}));
  EXPECT_TRUE(ThrowsConfigError(parse("baselines: [2.0]\n"), "layout_file",
                                {"x.yaml", "exactly one of layout"}));
}

TEST(AdaptExperiment, PlannerTypeNamesAClosedLoopPlanner) {
  const AdaptExperiment ipopt = AdaptExperiment::FromString(kMinimal, "x.yaml");
  EXPECT_EQ(ipopt.planner_type, "ipopt");
  const AdaptExperiment ego = AdaptExperiment::FromString(
      std::string(kMinimal) + "planner: {type: ego, v_des: 2.5, h_pl: 6}\n", "x.yaml");
  EXPECT_EQ(ego.planner_type, "ego");
  EXPECT_EQ(ego.params.v_des, 2.5);
  EXPECT_EQ(ego.params.h_pl, 6.0);
  // A planner parameter beside `type` is still checked.
  EXPECT_TRUE(ThrowsConfigError(
      [] {
        (void)AdaptExperiment::FromString(
            std::string(kMinimal) + "planner: {type: ego, v_dse: 2}\n", "x.yaml");
      },
      "planner.v_dse", {"x.yaml"}));
}

// A planner type that cannot fly in the closed loop (not registered, or registered without a
// back end, as the test planners toy and sleep are) is refused on load, naming the file and key
// and listing the planners that can.
TEST(AdaptExperiment, PlannerWithoutAClosedLoopBackEndNamesFileKeyAndTheUsablePlanners) {
  static const bool registered = [] {
    RegisterPlanner(
        "adapt_test_loopless",
        [](const YamlMap&, const std::string&) { return Planner{NoPlanner{}}; }, PlannerSchema{});
    return true;
  }();
  ASSERT_TRUE(registered);
  for (const std::string type : {"adapt_test_loopless", "rrt"}) {
    ExpectFileKeyError("planner_" + type, "planner: {type: " + type + "}\n", "planner.type",
                       "'" + type + "' is not a registered planner flown in the closed loop");
    EXPECT_TRUE(ThrowsConfigError(
        [&] {
          (void)AdaptExperiment::FromString(
              std::string(kMinimal) + "planner: {type: " + type + "}\n", "x.yaml");
        },
        "planner.type", {"x.yaml", "registered: ego, ipopt"}));
  }
}

TEST(AdaptExperiment, ObjectiveKeysWithoutKindKeepTheChangingEnvironmentDefaults) {
  // short_term.kind may be left out of an adaptation file: the given w_c is kept, and an absent
  // one is the changing-environment default, not the solve-time f_s's 0.
  const AdaptExperiment given = AdaptExperiment::FromString(
      std::string(kMinimal) + "adaptation: {objective: {short_term: {w_c: 7}}}\n", "x.yaml");
  EXPECT_EQ(given.adaptation.objective.w_c, 7.0);
  const AdaptExperiment absent = AdaptExperiment::FromString(
      std::string(kMinimal) + "adaptation: {objective: {short_term: {w_t: 2}}}\n", "x.yaml");
  EXPECT_EQ(absent.adaptation.objective.w_c, ObjectiveOptions::kDefaultClearanceWeight);
  EXPECT_EQ(absent.adaptation.objective.w_t, 2.0);
  EXPECT_EQ(absent.adaptation.objective.short_kind,
            ObjectiveOptions::ShortKind::kChangingEnvironment);
}

TEST(AdaptExperiment, ShippedFileHoldsThePapersSettings) {
  const AdaptExperiment e = AdaptExperiment::LoadFile(std::string(QUADTUNE_SOURCE_DIR) +
                                                      "/experiments/changing_environment.yaml");
  EXPECT_EQ(e.adaptation.lookahead, 2.0);
  EXPECT_EQ(e.adaptation.v_min, 1.0);
  EXPECT_EQ(e.adaptation.v_max, 6.0);
  EXPECT_EQ(e.adaptation.trials_per_segment, 8);
  EXPECT_EQ(e.adaptation.objective.w_t, 1.0);
  EXPECT_EQ(e.adaptation.objective.w_p, 0.01);
  EXPECT_EQ(e.adaptation.objective.w_c, 100.0);
  EXPECT_GT(e.adaptation.bo.noise_growth, 0.0);
  ASSERT_EQ(e.layout.zones.size(), 4u);
  const double spacing[] = {3.0, 1.3, 2.1, 0.9};
  for (int i = 0; i < 4; ++i) EXPECT_EQ(e.layout.zones[static_cast<std::size_t>(i)].spacing, spacing[i]);
  EXPECT_FALSE(e.baselines.empty());
  // The small test experiment loads too.
  EXPECT_NO_THROW((void)AdaptExperiment::LoadFile(
      std::string(QUADTUNE_SOURCE_DIR) + "/experiments/changing_environment_small.yaml"));
}

}  // namespace
}  // namespace quadtune::engine
