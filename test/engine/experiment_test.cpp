#include "quadtune/engine/experiment/experiment.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <string>

#include "quadtune/common/error.hpp"
#include "quadtune/engine/adaptation/online_adaptation.hpp"
#include "quadtune/engine/tuning/study.hpp"
#include "quadtune/engine/tuning/tuner.hpp"
#include "test_util.hpp"

namespace quadtune::engine {
namespace {

/// Loads `text`; expects a ConfigError whose key is `key`.
void ExpectKeyError(const std::string& text, const std::string& key) {
  try {
    (void)Experiment::FromString(text, "exp.yaml", QUADTUNE_SOURCE_DIR);
    ADD_FAILURE() << "no error for key " << key;
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.key(), key) << e.what();
    EXPECT_EQ(e.file(), "exp.yaml") << e.what();
  }
}

std::string Replace(std::string s, const std::string& from, const std::string& to) {
  const auto pos = s.find(from);
  EXPECT_NE(pos, std::string::npos) << from;
  if (pos != std::string::npos) s.replace(pos, from.size(), to);
  return s;
}

TEST(Experiment, ToyFileLoads) {
  const Experiment e = Experiment::FromString(test::ToyYaml(), "exp.yaml");
  EXPECT_EQ(e.planner.Name(), "toy");
  EXPECT_EQ(e.methods.size(), 5u);
  EXPECT_EQ(e.short_names, (std::vector<std::string>{"gain", "max_iter"}));
  EXPECT_EQ(e.long_names, (std::vector<std::string>{"speed", "margin"}));
  EXPECT_EQ(e.budget.flights, 6);
  EXPECT_EQ(e.pso.num_particles, 4);
  EXPECT_NE(e.MapSeed(0), e.MapSeed(1));
}

TEST(Experiment, ShippedFilesLoad) {
  // changing_environment*.yaml are `quadtune adapt` files (AdaptExperiment, test/adapt);
  // *_study.yaml are `quadtune study` files (Study).
  for (const char* f : {"experiments/default.yaml", "experiments/tiny.yaml", "test/support/toy.yaml",
                        "experiments/benchmark.yaml", "experiments/mpi_scaling.yaml"}) {
    EXPECT_NO_THROW((void)Experiment::LoadFile(std::string(QUADTUNE_SOURCE_DIR) + "/" + f)) << f;
  }
}

TEST(ExperimentErrors, UnknownTopLevelKey) {
  ExpectKeyError(test::ToyYaml() + "bogus: 1\n", "bogus");
}
TEST(ExperimentErrors, UnknownMethod) {
  ExpectKeyError(test::ToyYaml("[default, annealing]"), "methods");
}
TEST(ExperimentErrors, DuplicateMethod) {
  ExpectKeyError(test::ToyYaml("[bo, bo]"), "methods");
}
TEST(ExperimentErrors, BadMode) {
  ExpectKeyError(Replace(test::ToyYaml(), "mode: reproducible", "mode: fast"), "mode");
}
TEST(ExperimentErrors, ZeroThreads) {
  ExpectKeyError(Replace(test::ToyYaml(), "threads: 2", "threads: 0"), "threads");
}
TEST(ExperimentErrors, ZeroRepeats) {
  ExpectKeyError(Replace(test::ToyYaml(), "repeats: 1", "repeats: 0"), "repeats");
}
TEST(ExperimentErrors, BadPlannerType) {
  ExpectKeyError(Replace(test::ToyYaml(), "type: toy", "type: rrt"), "planner.type");
}
TEST(ExperimentErrors, UnknownToyOption) {
  ExpectKeyError(Replace(test::ToyYaml(), "gates: 4", "gates: 4, wings: 2"), "planner.toy.wings");
}
TEST(ExperimentErrors, ParameterNotOfThePlanner) {
  ExpectKeyError(Replace(test::ToyYaml(), "name: margin,", "name: v_des,"), "parameters");
}
TEST(ExperimentErrors, CrossedBounds) {
  ExpectKeyError(Replace(test::ToyYaml(), "lower: 0.5, upper: 6.0", "lower: 6.5, upper: 6.0"),
                 "parameters[2].upper");
}
TEST(ExperimentErrors, LongTermNameInShortTermList) {
  ExpectKeyError(Replace(test::ToyYaml(), "short_term: [gain, max_iter]", "short_term: [gain, speed]"),
                 "short_term");
}
TEST(ExperimentErrors, ParameterInNeitherList) {
  ExpectKeyError(Replace(test::ToyYaml(), "short_term: [gain, max_iter]", "short_term: [gain]"),
                 "parameters");
}
TEST(ExperimentErrors, InitialShortTermOutOfBounds) {
  ExpectKeyError(test::ToyYaml() + "initial_short_term: {gain: 9.0, max_iter: 10}\n",
                 "initial_short_term.gain");
}
TEST(ExperimentErrors, NonPositiveRealTimeThreshold) {
  ExpectKeyError(Replace(test::ToyYaml(), "tau_t: 0.002", "tau_t: 0"), "objective.short_term.tau_t");
}
TEST(ExperimentErrors, BadShortTermKind) {
  ExpectKeyError(Replace(test::ToyYaml(), "tau_t: 0.002", "kind: fastest"), "objective.short_term.kind");
}
TEST(ExperimentErrors, NegativeEmergencyStopWeight) {
  ExpectKeyError(Replace(test::ToyYaml(), "objective:\n", "objective:\n  long_term: {w_e: -1}\n"),
                 "objective.long_term.w_e");
}
TEST(ExperimentErrors, ZeroFlightBudget) {
  ExpectKeyError(Replace(test::ToyYaml(), "flights: 6", "flights: 0"), "budget.flights");
}
TEST(ExperimentErrors, ZeroQueriesPerEvaluation) {
  ExpectKeyError(Replace(test::ToyYaml(), "queries_per_eval: 2", "queries_per_eval: 0"),
                 "budget.queries_per_eval");
}
TEST(ExperimentErrors, UnknownBudgetKey) {
  ExpectKeyError(Replace(test::ToyYaml(), "query_window: 50", "query_window: 50, hours: 2"),
                 "budget.hours");
}
TEST(ExperimentErrors, WhileFlyingNeedsRealtimeMode) {
  ExpectKeyError(Replace(test::ToyYaml(), "query_window: 50", "query_window: 50, short_term_while_flying: true"),
                 "budget.short_term_while_flying");
}
TEST(ExperimentErrors, ThreadSizedBatchNeedsRealtimeMode) {
  ExpectKeyError(Replace(test::ToyYaml(), "flight_batch: 2", "flight_batch: 0"), "budget.flight_batch");
}
TEST(ExperimentErrors, BadPsoOption) {
  ExpectKeyError(Replace(test::ToyYaml(), "num_particles: 4", "num_particles: 0"),
                 "pso.num_particles");
}
TEST(ExperimentErrors, MissingDroneFile) {
  const std::string text = std::regex_replace(
      test::ToyYaml(), std::regex("  type: toy\n  toy: \\{[^}]*\\}\n"),
      "  type: ipopt\n  drone: drones/nope.yaml\n  layout: {spacing: 3.0}\n");
  ExpectKeyError(text, "planner.drone");
}
TEST(ExperimentErrors, MissingLayout) {
  const std::string text = std::regex_replace(test::ToyYaml(), std::regex("  type: toy\n  toy: \\{[^}]*\\}\n"),
                                              "  type: ipopt\n");
  ExpectKeyError(text, "planner.layout");
}
TEST(ExperimentErrors, ClearanceBeyondTheDistanceFieldsTruncation) {
  const std::string text = std::regex_replace(
      test::ToyYaml(), std::regex("  type: toy\n  toy: \\{[^}]*\\}\n"),
      "  type: ipopt\n  drone: drones/research_1kg.yaml\n  layout: {spacing: 3.0}\n"
      "  fixed: {clearance: 1.5}\n");
  ExpectKeyError(text, "clearance");
}
TEST(ExperimentErrors, ResumeWithAnotherConfiguration) {
  const std::string dir = test::TempDir("resume_other");
  const std::string store = dir + "/r.sqlite";
  RunOptions o;
  o.store_path = store;
  (void)RunExperiment(Experiment::FromString(test::ToyYaml("[default]"), "a.yaml"), o);
  o.resume = true;
  try {
    (void)RunExperiment(Experiment::FromString(test::ToyYaml("[random]"), "b.yaml"), o);
    ADD_FAILURE() << "resumed another configuration";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.key(), "--resume");
  }
}

// The field lists' Write of a loaded experiment reads back as the same experiment: writing the
// reread one gives the same text.
std::string Written(const Experiment& e) {
  YAML::Emitter out;
  SetExactDoubles(out);
  ExperimentFields().Write(out, e);
  return out.c_str();
}

TEST(ExperimentFields, WriteThenReadGivesTheSameExperiment) {
  const std::string root = QUADTUNE_SOURCE_DIR;
  std::vector<Experiment> loaded{
      Experiment::FromString(test::ToyYaml() + "start: {speed: 1.5}\n", "exp.yaml"),
      Experiment::LoadFile(root + "/experiments/default.yaml"),
      Experiment::LoadFile(root + "/experiments/tiny.yaml")};
  for (const Experiment& e : loaded) {
    const std::string text = Written(e);
    const Experiment again = Experiment::FromString(text, "w.yaml", e.base_dir);
    EXPECT_EQ(Written(again), text) << e.file;
    EXPECT_EQ(again.methods, e.methods);
    EXPECT_EQ(again.space.Names(), e.space.Names());
    EXPECT_EQ(again.start, e.start);
    EXPECT_EQ(again.budget.default_flights, e.budget.default_flights);
    EXPECT_EQ(again.objective.w_c, e.objective.w_c);
    EXPECT_EQ(again.maps.mode, e.maps.mode);
    EXPECT_EQ(again.pso.num_particles, e.pso.num_particles);
  }
}

// ResolvePath looks next to the file, then in the folders SetAssetDirs gives, in their order,
// and never in $QUADTUNE_ASSETS: the library reads no environment.
TEST(ResolvePath, SearchesTheAssetFoldersItIsGivenAndNotTheEnvironment) {
  namespace fs = std::filesystem;
  const fs::path root =
      fs::temp_directory_path() / ("quadtune_asset_dirs_" + std::to_string(getpid()));
  for (const char* dir : {"a", "b"}) fs::create_directories(root / dir / "drones");
  std::ofstream(root / "a" / "drones" / "both.yaml") << "a\n";
  std::ofstream(root / "b" / "drones" / "both.yaml") << "b\n";
  std::ofstream(root / "b" / "drones" / "only_b.yaml") << "b\n";
  const std::vector<std::string> saved = AssetDirs();
  ASSERT_EQ(setenv("QUADTUNE_ASSETS", (root / "b").c_str(), 1), 0);
  SetAssetDirs({});
  EXPECT_EQ(ResolvePath("drones/only_b.yaml", "."), "drones/only_b.yaml");
  SetAssetDirs({(root / "a").string(), (root / "b").string()});
  EXPECT_EQ(ResolvePath("drones/only_b.yaml", "."), (root / "b" / "drones/only_b.yaml").string());
  EXPECT_EQ(ResolvePath("drones/both.yaml", "."), (root / "a" / "drones/both.yaml").string());
  EXPECT_EQ(ResolvePath("drones/both.yaml", (root / "b").string()),
            (root / "b" / "drones/both.yaml").string());
  unsetenv("QUADTUNE_ASSETS");
  SetAssetDirs(saved);
  fs::remove_all(root);
}

TEST(ExperimentFields, EveryKeyHasATypeAndAMeaning) {
  const auto check = [](const std::vector<FieldDoc>& rows, const std::string& list) {
    EXPECT_FALSE(rows.empty()) << list;
    for (const FieldDoc& row : rows) {
      EXPECT_FALSE(row.type.empty()) << list << "." << row.key;
      EXPECT_FALSE(row.meaning.empty()) << list << "." << row.key;
    }
  };
  check(ExperimentFields().Docs(), "experiment");
  check(MapsFields().Docs(), "maps");
  check(ValidationFields().Docs(), "validation");
  check(RecommendFields().Docs(), "recommend");
  check(BudgetFields().Docs(), "budget");
  check(ClosedLoopFields().Docs(), "planner");
  check(ObjectiveFields().Docs(), "objective");
  check(ObjectiveShortTermFields().Docs(), "objective.short_term");
  check(ObjectiveLongTermFields().Docs(), "objective.long_term");
  check(StudyFields().Docs(), "study");
  check(StudySweepFields().Docs(), "study.sweep");
  check(StudyStageFields().Docs(), "study.stages");
  check(StudyValidationFields().Docs(), "study.validation");
  check(AdaptExperimentFields().Docs(), "adaptation experiment");
  check(AdaptationFields().Docs(), "adaptation");
  EXPECT_EQ(BudgetFields().Docs()[1].fallback, "`flights`");
  EXPECT_EQ(ExperimentFields().Docs()[3].allowed, "`reproducible`, `realtime`");
}

TEST(EnumNames, EngineSpellingsAreTheStoredOnes) {
  EXPECT_STREQ(ToString(Method::kBoPso), "bo_pso");
  EXPECT_EQ(FromString<Method>("default"), Method::kDefault);
  EXPECT_FALSE(FromString<Method>("annealing").has_value());
  EXPECT_STREQ(ToString(MapMode::kPerRepeat), "per_repeat");
  EXPECT_STREQ(ToString(TimingMode::kRealtime), "realtime");
  EXPECT_STREQ(ToString(ObjectiveOptions::ShortKind::kChangingEnvironment), "changing_environment");
  EXPECT_STREQ(ToString(EvalStatus::kCancelled), "cancelled");
  EXPECT_STREQ(ToString(RunStatus::kCompleted), "completed");
  EXPECT_STREQ(ToString(AdaptationSegment::Outcome::kNoSuccess), "no_success");
}

}  // namespace
}  // namespace quadtune::engine
