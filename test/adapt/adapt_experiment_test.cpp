// Closed-loop tests of the changing-environment experiment: adapted flights through the small
// two-zone corridor (experiments/changing_environment_small.yaml), and `quadtune adapt` end to
// end (CSVs, summary, figure, configuration errors).
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "../cli_util.hpp"
#include "quadtune/engine/adaptation/corridor_study.hpp"
#include "quadtune/engine/adaptation/online_adaptation.hpp"

namespace quadtune::engine {
namespace {

namespace fs = std::filesystem;

const std::string kSmall =
    std::string(QUADTUNE_SOURCE_DIR) + "/experiments/changing_environment_small.yaml";
const std::string kBinary = test::QuadtuneBinary();

TEST(AdaptFlight, SameSeedGivesTheSameChosenVdesSequence) {
  const AdaptExperiment e = AdaptExperiment::LoadFile(kSmall);
  const layout::Layout layout = layout::GenerateLayout(e.layout, e.seed);
  const AdaptFlight a = RunAdaptFlight(e, layout, std::nullopt);
  const AdaptFlight b = RunAdaptFlight(e, layout, std::nullopt);
  EXPECT_EQ(a.result.metrics.status, sim::FlightStatus::kCompleted) << a.result.metrics.message;
  ASSERT_FALSE(a.segments.empty());
  std::vector<double> va, vb;
  for (const auto& s : a.segments) va.push_back(s.v_des);
  for (const auto& s : b.segments) vb.push_back(s.v_des);
  EXPECT_EQ(va, vb);
  ASSERT_EQ(a.trials.size(), b.trials.size());
  for (std::size_t i = 0; i < a.trials.size(); ++i) {
    EXPECT_EQ(a.trials[i].v_des, b.trials[i].v_des);
    EXPECT_EQ(a.trials[i].f_s, b.trials[i].f_s);
  }
  EXPECT_EQ(a.result.metrics.flight_time, b.result.metrics.flight_time);
  // The v_des in force is always inside the bounds, and the adopted plans are in the flight's
  // plan records at their P_s times.
  for (const auto& row : a.result.log) {
    EXPECT_GE(row.v_des, e.adaptation.v_min);
    EXPECT_LE(row.v_des, e.adaptation.v_max);
  }
  int adopted = 0;
  for (const auto& s : a.segments) {
    if (s.outcome != AdaptationSegment::Outcome::kAdopted) continue;
    ++adopted;
    bool found = false;
    for (const auto& r : a.result.plans) found = found || (r.ok && r.time == s.split_time);
    EXPECT_TRUE(found) << "segment " << s.index;
  }
  EXPECT_GE(adopted, 3);
}

// Trials slower than the drone at P_s are planned as brakings (PlanningQuery::
// braking_deceleration): none fails over the acceleration limit, and some pass the braking
// envelope. Held to their v_des from P_s on, three of this flight's fail over a_max.
TEST(AdaptFlight, SlowerTrialsArePlannedAsBrakings) {
  const AdaptExperiment e = AdaptExperiment::LoadFile(kSmall);
  const layout::Layout layout = layout::GenerateLayout(e.layout, e.seed);
  const AdaptFlight a = RunAdaptFlight(e, layout, std::nullopt);
  std::map<int, double> speed_s;  // segment index → speed at its P_s
  for (const auto& s : a.segments) speed_s[s.index] = s.speed_s;
  int slower = 0;
  int braking = 0;
  for (const auto& t : a.trials) {
    const auto s = speed_s.find(t.segment);
    if (s == speed_s.end() || !(t.v_des < s->second)) continue;
    ++slower;
    EXPECT_NE(t.status, "over_a_max") << "segment " << t.segment << " trial " << t.trial;
    braking += t.status == "braking" ? 1 : 0;
  }
  EXPECT_GE(slower, 5);
  EXPECT_GE(braking, 3);
}

// The experiment flies the registered planner its `planner.type` names: with `ego`, the flight
// and the adapter's trials fly the EGO back end, which adapts v_des too.
TEST(AdaptFlight, AdaptsWithTheEgoPlanner) {
  std::string text = test::ReadText(kSmall);
  const std::string planner = "planner: {v_des: 2.0}";
  ASSERT_NE(text.find(planner), std::string::npos);
  text.replace(text.find(planner), planner.size(), "planner: {type: ego, v_des: 2.0}");
  const AdaptExperiment ego =
      AdaptExperiment::FromString(text, "ego.yaml", fs::path(kSmall).parent_path().string());
  ASSERT_EQ(ego.planner_type, "ego");
  const layout::Layout layout = layout::GenerateLayout(ego.layout, ego.seed);
  const AdaptFlight a = RunAdaptFlight(ego, layout, std::nullopt);
  EXPECT_EQ(a.result.metrics.status, sim::FlightStatus::kCompleted) << a.result.metrics.message;
  int adopted = 0;
  for (const auto& s : a.segments) adopted += s.outcome == AdaptationSegment::Outcome::kAdopted;
  EXPECT_GE(adopted, 2);
  for (const auto& row : a.result.log) {
    EXPECT_GE(row.v_des, ego.adaptation.v_min);
    EXPECT_LE(row.v_des, ego.adaptation.v_max);
  }
  // Not the Ipopt planner's flight: the same file with the default type flies another one.
  const AdaptFlight ipopt = RunAdaptFlight(AdaptExperiment::LoadFile(kSmall), layout, std::nullopt);
  ASSERT_FALSE(a.trials.empty());
  ASSERT_FALSE(ipopt.trials.empty());
  EXPECT_NE(a.trials.front().jerk_integral, ipopt.trials.front().jerk_integral);
}

using test::ReadCsv;

TEST(AdaptCli, SmallExperimentWritesCsvsSummaryAndFigure) {
  const fs::path out = fs::temp_directory_path() / "quadtune_adapt_cli";
  fs::remove_all(out);
  const std::string cmd = kBinary + " --log-level warn adapt '" + kSmall + "' --out '" +
                          out.string() + "' --seed 3 > '" + out.string() + ".log' 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;

  // One directory per flight with the files `quadtune plot flight` reads.
  for (const char* dir : {"adapted", "fixed_2"}) {
    for (const char* f :
         {"flight.csv", "plans.csv", "obstacles.json", "summary.json", "path.csv"}) {
      EXPECT_TRUE(fs::exists(out / dir / f)) << dir << "/" << f;
    }
  }
  // Their content: both flights flew the same obstacles; the fixed flight's v_des is 2 m/s all
  // along; each flight log ends at its summary's flight time, which the top summary repeats.
  const nlohmann::json top = nlohmann::json::parse(std::ifstream(out / "summary.json"));
  const nlohmann::json adapted_obstacles =
      nlohmann::json::parse(std::ifstream(out / "adapted" / "obstacles.json"));
  const nlohmann::json fixed_obstacles =
      nlohmann::json::parse(std::ifstream(out / "fixed_2" / "obstacles.json"));
  EXPECT_GT(fixed_obstacles["cylinders"].size(), 0u);
  EXPECT_EQ(fixed_obstacles, adapted_obstacles);
  const auto fixed_path = ReadCsv(out / "fixed_2" / "path.csv");
  ASSERT_GT(fixed_path.size(), 50u);
  for (const auto& r : fixed_path) EXPECT_DOUBLE_EQ(std::stod(r.at("v_des")), 2.0);
  for (const char* dir : {"adapted", "fixed_2"}) {
    const nlohmann::json flight_summary =
        nlohmann::json::parse(std::ifstream(out / dir / "summary.json"));
    const auto log = ReadCsv(out / dir / "flight.csv");
    ASSERT_FALSE(log.empty()) << dir;
    EXPECT_NEAR(std::stod(log.back().at("t")), flight_summary["flight_time"].get<double>(), 0.1)
        << dir;
    EXPECT_FALSE(ReadCsv(out / dir / "plans.csv").empty()) << dir;
    bool listed = false;
    for (const auto& f : top["flights"]) {
      listed = listed || f["flight_time"] == flight_summary["flight_time"];
    }
    EXPECT_TRUE(listed) << dir << " flight time not in summary.json";
  }

  const auto path = ReadCsv(out / "adapted" / "path.csv");
  ASSERT_GT(path.size(), 50u);
  for (const auto& r : path) {
    const double v = std::stod(r.at("v_des"));
    EXPECT_GE(v, 1.0);
    EXPECT_LE(v, 6.0);
    EXPECT_TRUE(std::isfinite(std::stod(r.at("speed"))));
    const int zone = std::stoi(r.at("zone"));
    EXPECT_GE(zone, -1);
    EXPECT_LE(zone, 1);
  }
  EXPECT_GT(std::stod(path.back().at("s")), 14.0);  // most of the 16 m corridor

  const auto trials = ReadCsv(out / "adapted" / "trials.csv");
  ASSERT_FALSE(trials.empty());
  int chosen = 0;
  for (const auto& t : trials) {
    const double v = std::stod(t.at("v_des"));
    EXPECT_GE(v, 1.0);
    EXPECT_LE(v, 6.0);
    for (const char* k : {"t_exe", "jerk_integral", "min_clearance", "J_c", "f_s"}) {
      EXPECT_TRUE(std::isfinite(std::stod(t.at(k)))) << k;
    }
    chosen += std::stoi(t.at("chosen"));
  }
  const auto segments = ReadCsv(out / "adapted" / "segments.csv");
  int adopted = 0;
  for (const auto& s : segments) adopted += s.at("outcome") == "adopted";
  EXPECT_EQ(chosen, adopted);
  EXPECT_GE(adopted, 3);

  nlohmann::json summary = nlohmann::json::parse(std::ifstream(out / "summary.json"));
  ASSERT_EQ(summary["flights"].size(), 2u);
  EXPECT_EQ(summary["zones"].size(), 2u);
  for (const auto& f : summary["flights"]) {
    ASSERT_EQ(f["zones"].size(), 2u);
    EXPECT_TRUE(f.contains("flight_time"));
    EXPECT_TRUE(f.contains("collisions"));
    EXPECT_TRUE(f.contains("emergency_stops"));
    for (const auto& z : f["zones"]) {
      EXPECT_GT(z["time"].get<double>(), 0.0);
      EXPECT_GE(z["mean_v_des"].get<double>(), 1.0);
      EXPECT_LE(z["mean_v_des"].get<double>(), 6.0);
    }
  }
  EXPECT_TRUE(summary["flights"][0]["adapted"].get<bool>());
  EXPECT_GT(fs::file_size(out / "summary.md"), 100u);
  ASSERT_TRUE(fs::exists(out / "adapt.png"));
  EXPECT_GT(fs::file_size(out / "adapt.png"), 20000u);
}

TEST(AdaptCli, BadKeyStopsBeforeAnyWorkNamingFileAndKey) {
  const fs::path dir = fs::temp_directory_path() / "quadtune_adapt_bad";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path yaml = dir / "bad.yaml";
  std::ofstream(yaml) << "layout_file: layouts/changing_density_thin.yaml\n"
                         "adaptation: {lookahed: 2.0}\n";
  const fs::path log = dir / "log.txt";
  const std::string cmd = kBinary + " adapt '" + yaml.string() + "' --out '" +
                          (dir / "out").string() + "' > '" + log.string() + "' 2>&1";
  const int status = std::system(cmd.c_str());
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 2);
  std::stringstream text;
  text << std::ifstream(log).rdbuf();
  EXPECT_NE(text.str().find(yaml.string()), std::string::npos) << text.str();
  EXPECT_NE(text.str().find("adaptation.lookahed"), std::string::npos) << text.str();
  EXPECT_FALSE(fs::exists(dir / "out"));
}

// `--set planner.type=ego` adapts with the EGO planner; a type that cannot fly in the closed
// loop stops the command before any work, naming the file, the key and the planners that can.
TEST(AdaptCli, PlannerTypeSelectsTheClosedLoopPlanner) {
  const fs::path dir = test::FreshTempDir("quadtune_adapt_planner");
  const std::string common = "--log-level warn adapt '" + kSmall + "' --no-plot --out '";
  ASSERT_EQ(test::RunQuadtune(common + (dir / "ego").string() + "' --set planner.type=ego",
                              dir / "ego.log"),
            0)
      << test::ReadText(dir / "ego.log");
  EXPECT_FALSE(ReadCsv(dir / "ego" / "adapted" / "trials.csv").empty());
  EXPECT_EQ(test::RunQuadtune(common + (dir / "toy").string() + "' --set planner.type=toy",
                              dir / "toy.log"),
            2);
  const std::string log = test::ReadText(dir / "toy.log");
  for (const char* words :
       {"changing_environment_small.yaml", "planner.type",
        "'toy' is not a registered planner flown in the closed loop", "registered: ego, ipopt"}) {
    EXPECT_NE(log.find(words), std::string::npos) << words << " in: " << log;
  }
  EXPECT_FALSE(fs::exists(dir / "toy"));
}

// --set edits the adaptation file (a third flight from one more baseline); --threads flies the
// flights at once, and each flight is the same as when they fly one after another.
TEST(AdaptCli, SetAddsABaselineAndThreadsKeepEveryFlight) {
  const fs::path dir = test::FreshTempDir("quadtune_adapt_threads");
  const std::string common = "--log-level warn adapt '" + kSmall + "' --seed 3 --no-plot " +
                             "--set 'baselines=[2.0, 3.0]' --out '";
  ASSERT_EQ(test::RunQuadtune(common + (dir / "one").string() + "' --threads 1", dir / "one.log"),
            0)
      << test::ReadText(dir / "one.log");
  ASSERT_EQ(
      test::RunQuadtune(common + (dir / "three").string() + "' --threads 3", dir / "three.log"), 0)
      << test::ReadText(dir / "three.log");
  for (const char* flight : {"adapted", "fixed_2", "fixed_3"}) {
    const std::string one = test::ReadText(dir / "one" / flight / "flight.csv");
    EXPECT_GT(one.size(), 1000U) << flight;
    EXPECT_EQ(one, test::ReadText(dir / "three" / flight / "flight.csv")) << flight;
  }
  // A key the file does not have is refused, naming it.
  EXPECT_EQ(test::RunQuadtune(common + (dir / "bad").string() + "' --set adaptation.nope=1",
                              dir / "bad.log"),
            2);
  EXPECT_NE(test::ReadText(dir / "bad.log").find("nope"), std::string::npos)
      << test::ReadText(dir / "bad.log");
}

// `adapt --corridors N` flies every policy on N corridors (the file's policy adds `context`)
// and writes one row per flight with the columns the corridor study promises; a second run with
// twice the threads writes the same table.
TEST(AdaptCli, CorridorsWriteOneRowPerFlightAndPolicy) {
  const fs::path dir = test::FreshTempDir("quadtune_adapt_corridors");
  const std::string policy =
      "--set 'adaptation.policy={points: [{free_range: 1.0, v_des: 1.5}, "
      "{free_range: 5.0, v_des: 3.0}]}'";
  const std::string common = "--log-level warn adapt '" + kSmall + "' --seed 3 --corridors 2 " +
                             policy + " --set 'baselines=[2.0, 3.0]' --out '";
  ASSERT_EQ(test::RunQuadtune(common + (dir / "one").string() + "' --threads 1", dir / "1.log"), 0)
      << test::ReadText(dir / "1.log");
  ASSERT_EQ(test::RunQuadtune(common + (dir / "two").string() + "' --threads 2", dir / "2.log"), 0)
      << test::ReadText(dir / "2.log");
  const std::string csv = test::ReadText(dir / "one" / "corridors.csv");
  EXPECT_EQ(csv.substr(0, csv.find('\n')),
            "corridor_seed,policy,f_l,flight_time,collisions,emergency_stops,status,mean_speed,"
            "v_des_dense,v_des_sparse,segments");
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 1 + 2 * 4);  // 2 corridors × 4 policies
  for (const char* row : {"\n3,adapted,", "\n3,context,", "\n4,fixed_2,", "\n4,fixed_3,"}) {
    EXPECT_NE(csv.find(row), std::string::npos) << row << "\n" << csv;
  }
  EXPECT_EQ(csv, test::ReadText(dir / "two" / "corridors.csv"));
  const std::string md = test::ReadText(dir / "one" / "corridors.md");
  EXPECT_NE(md.find("best fixed (leave-one-out)"), std::string::npos) << md;
}

// The leave-one-out choice: corridor i's best fixed v_des is the one with the lowest mean f_l on
// the other corridors, even when another one is better on corridor i itself.
TEST(CompareCorridors, BestFixedIsChosenOnTheOtherCorridors) {
  auto row = [](std::uint64_t seed, const char* policy, double f_l, int collisions = 0,
                double dense = 0.0, double sparse = 0.0) {
    CorridorFlight r;
    r.corridor_seed = seed;
    r.policy = policy;
    r.f_l = f_l;
    r.collisions = collisions;
    r.v_des_dense = dense;
    r.v_des_sparse = sparse;
    return r;
  };
  const std::vector<CorridorFlight> rows = {
      row(1, "adapted", 20.0, 0, 2.0, 3.0), row(1, "fixed_2", 30.0), row(1, "fixed_3", 10.0),
      row(2, "adapted", 22.0, 1, 3.0, 2.0), row(2, "fixed_2", 30.0), row(2, "fixed_3", 25.0),
      row(3, "adapted", 24.0, 0, 2.5, 3.5), row(3, "fixed_2", 30.0), row(3, "fixed_3", 40.0, 2)};
  const CorridorComparison c = CompareCorridors(rows);
  ASSERT_EQ(c.corridors.size(), 3U);
  // Corridor 1: fixed_3 has mean 32.5 on {2, 3}, fixed_2 30 → fixed_2, although fixed_3 wins on 1.
  EXPECT_EQ(c.corridors[0].best_fixed, "fixed_2");
  EXPECT_DOUBLE_EQ(c.corridors[0].best_fixed_f_l, 30.0);
  EXPECT_EQ(c.corridors[1].best_fixed, "fixed_3");  // fixed_3: 25 on {1, 3}; fixed_2: 30
  EXPECT_DOUBLE_EQ(c.corridors[1].best_fixed_f_l, 25.0);
  EXPECT_EQ(c.corridors[2].best_fixed, "fixed_3");  // fixed_3: 17.5 on {1, 2}
  EXPECT_EQ(c.best_fixed_collisions, 2);
  EXPECT_DOUBLE_EQ(c.best_fixed_mean_f_l, (30.0 + 25.0 + 40.0) / 3.0);
  ASSERT_EQ(c.adaptive.size(), 1U);
  EXPECT_EQ(c.adaptive[0].policy, "adapted");
  EXPECT_DOUBLE_EQ(c.adaptive[0].mean_f_l, 22.0);
  EXPECT_EQ(c.adaptive[0].collisions, 1);
  EXPECT_EQ(c.adaptive[0].lower_in_dense, 2);
}

// A policy learned from two densities keeps each density's v_des at the free range measured in
// its forest: the denser forest shows the shorter free range, and the points come sorted.
TEST(LearnContextPolicy, MeasuresEachDensitysFreeRange) {
  const AdaptExperiment e = AdaptExperiment::LoadFile(kSmall);
  const std::string layouts = std::string(QUADTUNE_SOURCE_DIR) + "/assets/layouts/";
  const std::vector<DensityPoint> densities = {
      {"3.0", layout::LayoutOptions::LoadFile(layouts + "forest_3p0.yaml"), 4.0},
      {"0.9", layout::LayoutOptions::LoadFile(layouts + "forest_0p9.yaml"), 2.0}};
  const ContextPolicy policy = LearnContextPolicy(e, densities, 2, 2);
  ASSERT_EQ(policy.points.size(), 2U);
  EXPECT_EQ(policy.points[0].label, "0.9");
  EXPECT_DOUBLE_EQ(policy.points[0].v_des, 2.0);
  EXPECT_EQ(policy.points[1].label, "3.0");
  EXPECT_DOUBLE_EQ(policy.points[1].v_des, 4.0);
  EXPECT_LT(policy.points[0].free_range, policy.points[1].free_range);
  EXPECT_LE(policy.points[1].free_range, policy.measure.range);
  EXPECT_EQ(LearnContextPolicy(e, densities, 2, 1), policy);  // threads do not change it
}

// In context mode the policy's choice governs the planner's own plans: nothing is planned from
// P_s, and once measured the v_des in force is the policy's (here 2 m/s at a disc free range
// of 10 m, 3.5 m/s at 40 m), so over the shipped corridor the drone flies slower over the
// dense zones.
TEST(AdaptFlight, ContextModeSetsTheVdesOfEveryPlan) {
  AdaptExperiment e = AdaptExperiment::LoadFile(std::string(QUADTUNE_SOURCE_DIR) +
                                                "/experiments/changing_environment.yaml");
  ContextPolicy policy;
  policy.measure.kind = FreeRangeKind::kDisc;
  policy.points = {{10.0, 2.0, "dense"}, {40.0, 3.5, "sparse"}};
  e.adaptation.policy = policy;
  e.adaptation.mode = AdaptationMode::kContext;
  e.adaptation.braking_fraction = 0.25;
  const layout::Layout layout = layout::GenerateLayout(e.layout, e.seed);
  const AdaptFlight a = RunAdaptFlight(e, layout, FlightPolicy{});
  EXPECT_EQ(a.label, "context");
  EXPECT_TRUE(a.trials.empty());
  ASSERT_GE(a.segments.size(), 3U);
  for (const AdaptationSegment& s : a.segments) {
    EXPECT_EQ(s.outcome, AdaptationSegment::Outcome::kAdopted);
    EXPECT_GE(s.v_des, 2.0);
    EXPECT_LE(s.v_des, 3.5);
    EXPECT_DOUBLE_EQ(s.v_des, s.policy_v_des);
  }
  // The v_des in force is always the start value or one the policy chose, and no plan failed
  // for keeping a speed above a lowered v_des.
  std::vector<double> chosen = {e.params.v_des};
  for (const AdaptationSegment& s : a.segments) chosen.push_back(s.v_des);
  for (const sim::FlightLogRow& row : a.result.log) {
    ASSERT_NE(std::find(chosen.begin(), chosen.end(), row.v_des), chosen.end()) << row.t;
  }
  for (const sim::PlanRecord& rec : a.result.plans) {
    EXPECT_NE(rec.status, planning::PlanStatus::kDynamicsViolated) << rec.time;
  }
  const auto [dense, sparse] = DenseSparseVDes(a.result, layout.options, e.dense_below);
  EXPECT_LT(dense, sparse);
  EXPECT_EQ(a.result.metrics.status, sim::FlightStatus::kCompleted);
}

// `quadtune policy --grid` chooses each density's v_des by flying the grid (its table beside the
// policy file), and `adapt --policy` flies the file it wrote; a broken policy file is refused
// naming the file.
TEST(PolicyCli, GridPolicyIsWrittenAndFlown) {
  const fs::path dir = test::FreshTempDir("quadtune_policy_grid");
  const fs::path study = dir / "study";
  fs::create_directories(study);
  std::ofstream(study / "study.json")
      << R"({"file": ")" << QUADTUNE_SOURCE_DIR << R"(/experiments/density_study.yaml",)"
      << R"( "points": [{"label": "3.0", "value": "layouts/forest_3p0.yaml"},)"
      << R"( {"label": "0.9", "value": "layouts/forest_0p9.yaml"}]})";
  std::ofstream(study / "validation.csv")
      << "point,label,source_stage,method,repeat,flight,map_seed,status,completed,flight_time,"
         "collisions,emergency_stops,plans,failed_plans,f_l,params\n"
      << "0,3.0,,bo_pso,0,0,1,ok,1,20,0,0,10,0,20,\"{\"\"v_des\"\":4.0}\"\n"
      << "1,0.9,,bo_pso,0,0,1,ok,1,30,0,0,10,0,30,\"{\"\"v_des\"\":3.0}\"\n";
  const fs::path out = dir / "policy.yaml";
  ASSERT_EQ(test::RunQuadtune("--log-level warn policy '" + kSmall + "' --study '" +
                                  study.string() + "' --grid 2,3 --maps 1 --threads 2 --out '" +
                                  out.string() + "'",
                              dir / "policy.log"),
            0)
      << test::ReadText(dir / "policy.log");
  const std::string grid = test::ReadText(dir / "policy_grid.csv");
  EXPECT_EQ(grid.substr(0, grid.find('\n')),
            "label,v_des,flights,mean_f_l,collisions,unfinished,chosen");
  EXPECT_EQ(std::count(grid.begin(), grid.end(), '\n'), 1 + 2 * 2) << grid;
  const std::string yaml = test::ReadText(out);
  EXPECT_NE(yaml.find("--grid 2,3"), std::string::npos) << yaml;
  EXPECT_NE(yaml.find("label: \"0.9\""), std::string::npos) << yaml;
  ASSERT_EQ(test::RunQuadtune("--log-level warn adapt '" + kSmall + "' --policy '" + out.string() +
                                  "' --set adaptation.mode=context --set 'baselines=[]' --out '" +
                                  (dir / "run").string() + "'",
                              dir / "adapt.log"),
            0)
      << test::ReadText(dir / "adapt.log");
  EXPECT_TRUE(fs::exists(dir / "run" / "context" / "segments.csv"));
  std::ofstream(dir / "bad.yaml") << "points: [{free_range: 2, v_des: 3}]\n";
  EXPECT_NE(test::RunQuadtune("adapt '" + kSmall + "' --policy '" + (dir / "bad.yaml").string() +
                                  "' --out '" + (dir / "bad").string() + "'",
                              dir / "bad.log"),
            0);
  const std::string log = test::ReadText(dir / "bad.log");
  EXPECT_NE(log.find("bad.yaml"), std::string::npos) << log;
  EXPECT_NE(log.find("policy.points"), std::string::npos) << log;
}

// The disc's free range falls with density and stays below its cap.
TEST(LearnContextPolicy, DiscSeparatesDensities) {
  AdaptExperiment e = AdaptExperiment::LoadFile(kSmall);
  ContextPolicy measure;
  measure.measure.kind = FreeRangeKind::kDisc;
  measure.points = {{1.0, 2.0, ""}, {2.0, 2.0, ""}};
  e.adaptation.policy = measure;
  const std::string layouts = std::string(QUADTUNE_SOURCE_DIR) + "/assets/layouts/";
  const std::vector<DensityPoint> densities = {
      {"3.0", layout::LayoutOptions::LoadFile(layouts + "forest_3p0.yaml"), 3.0},
      {"1.3", layout::LayoutOptions::LoadFile(layouts + "forest_1p3.yaml"), 3.0},
      {"0.9", layout::LayoutOptions::LoadFile(layouts + "forest_0p9.yaml"), 2.0}};
  const ContextPolicy policy = LearnContextPolicy(e, densities, 2, 2);
  ASSERT_EQ(policy.points.size(), 3U);
  EXPECT_EQ(policy.points[0].label, "0.9");
  EXPECT_EQ(policy.points[1].label, "1.3");
  EXPECT_EQ(policy.points[2].label, "3.0");
  EXPECT_GT(policy.points[1].free_range, 1.2 * policy.points[0].free_range);
  EXPECT_GT(policy.points[2].free_range, 1.2 * policy.points[1].free_range);
  EXPECT_LE(policy.points[2].free_range, 10.0 * policy.measure.range);
}

// The grid flies every v_des on every map and picks the lowest mean f_l among the clean ones.
TEST(ChooseVDesByGrid, PicksTheBestCleanVdesPerDensity) {
  const AdaptExperiment e = AdaptExperiment::LoadFile(kSmall);
  const std::string layouts = std::string(QUADTUNE_SOURCE_DIR) + "/assets/layouts/";
  std::vector<DensityPoint> densities = {
      {"3.0", layout::LayoutOptions::LoadFile(layouts + "forest_3p0.yaml"), 0.0}};
  const std::vector<double> grid = {1.0, 2.0, 3.0};
  const std::vector<GridCell> cells = ChooseVDesByGrid(e, densities, grid, 2, 2);
  ASSERT_EQ(cells.size(), 3U);
  int chosen = 0;
  for (const GridCell& c : cells) {
    EXPECT_EQ(c.flights, 2);
    EXPECT_GT(c.mean_f_l, 0.0);
    chosen += c.chosen ? 1 : 0;
    if (c.chosen) {
      EXPECT_DOUBLE_EQ(densities[0].v_des, c.v_des);
    }
  }
  EXPECT_EQ(chosen, 1);
  // 1 m/s over 24 m is far slower than 3 m/s through the sparse forest.
  EXPECT_GT(cells[0].mean_f_l, cells[2].mean_f_l);
  EXPECT_NE(densities[0].v_des, 1.0);
  std::vector<DensityPoint> again = {densities[0]};
  EXPECT_EQ(ChooseVDesByGrid(e, again, grid, 2, 1).size(), cells.size());
  EXPECT_DOUBLE_EQ(again[0].v_des, densities[0].v_des);  // threads do not change it
  EXPECT_THROW((void)ChooseVDesByGrid(e, again, {}, 2, 1), ConfigError);
  EXPECT_THROW((void)ChooseVDesByGrid(e, again, {9.0}, 2, 1), ConfigError);
}

}  // namespace
}  // namespace quadtune::engine
