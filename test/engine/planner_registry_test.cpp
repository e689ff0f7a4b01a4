#include "quadtune/engine/api/planner_registry.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <stdexcept>
#include <string>
#include <vector>

#include "../config_error_util.hpp"
#include "quadtune/common/error.hpp"
#include "quadtune/engine/experiment/experiment.hpp"
#include "quadtune/engine/planners/planners.hpp"
#include "quadtune/engine/tuning/tuner.hpp"
#include "test_util.hpp"
#include "toy_planners.hpp"

namespace quadtune::engine {
namespace {

std::string WithType(const std::string& type) {
  std::string text = test::ToyYaml("[random, pso]");
  const std::string from = "type: toy";
  text.replace(text.find(from), from.size(), "type: " + type);
  return text;
}

std::vector<std::string> Names(const std::vector<ParameterInfo>& side) {
  std::vector<std::string> names;
  for (const auto& p : side) names.push_back(p.name);
  return names;
}

// The toy type's factory (test/support) under another name: the same plug-in, reached by a
// second registration made outside the library.
Planner BuildToyAgain(const YamlMap& planner, const std::string& base_dir) {
  return FindPlanner("toy")->factory(planner, base_dir);
}

const PlannerRegistration kStatic("registry_test_static", BuildToyAgain,
                                  PlannerSchema::Of(test::ToyPlanner{}));

TEST(PlannerRegistry, BuiltInTypesAreRegistered) {
  const std::vector<std::string> names = RegisteredPlanners();
  for (const char* n : {"ego", "ipopt"}) {
    EXPECT_NE(std::find(names.begin(), names.end(), n), names.end()) << n;
  }
  EXPECT_TRUE(std::is_sorted(names.begin(), names.end()));
  const auto ego = FindPlanner("ego");
  ASSERT_TRUE(ego.has_value());
  EXPECT_EQ(Names(ego->schema.short_term), (std::vector<std::string>{"w_col", "w_dyn", "n_pol"}));
  EXPECT_TRUE(ego->schema.short_term[2].integer);
  EXPECT_FALSE(FindPlanner("rrt").has_value());
}

// The test planners live outside the engine library (test/support) and register through the
// public registry when a program links quadtune::test_planners, as engine_tests does.
TEST(PlannerRegistry, TestPlannersRegisterThroughThePublicRegistry) {
  const std::vector<std::string> names = RegisteredPlanners();
  for (const char* n : {"sleep", "toy"}) {
    EXPECT_NE(std::find(names.begin(), names.end(), n), names.end()) << n;
  }
  const auto toy = FindPlanner("toy");
  ASSERT_TRUE(toy.has_value());
  EXPECT_EQ(Names(toy->schema.short_term), (std::vector<std::string>{"gain", "max_iter"}));
  EXPECT_EQ(Names(toy->schema.long_term), (std::vector<std::string>{"speed", "margin"}));
  const auto sleep = FindPlanner("sleep");
  ASSERT_TRUE(sleep.has_value());
  EXPECT_EQ(Names(sleep->schema.short_term), (std::vector<std::string>{"effort"}));
  EXPECT_EQ(Names(sleep->schema.long_term), (std::vector<std::string>{"pace"}));
}

// A default-constructed experiment holds NoPlanner until its `planner:` map is read: no
// parameters, and a flight or re-solve through it is a failed evaluation, never a crash.
TEST(PlannerRegistry, DefaultExperimentHoldsNoPlanner) {
  const Experiment e;
  EXPECT_EQ(e.planner.Name(), "none");
  EXPECT_TRUE(e.planner.Defaults().empty());
  WorkerSlot slot;
  FlightRequest request;
  request.map = e.planner.PrepareMap(1);
  const FlightRecord flight = e.planner.Fly(request, slot);
  EXPECT_EQ(flight.status, EvalStatus::kFailed);
  EXPECT_EQ(flight.message, "no planner");
  const ResolveRecord resolve = e.planner.Resolve(Opaque{}, {});
  EXPECT_EQ(resolve.status, EvalStatus::kFailed);
  EXPECT_EQ(resolve.message, "no planner");
}

TEST(PlannerRegistry, UnknownTypeListsTheRegisteredNames) {
  EXPECT_TRUE(quadtune::test::ThrowsConfigError(
      [] { (void)Experiment::FromString(WithType("rrt"), "exp.yaml"); }, "planner.type",
      {"'rrt'", "registered:", "ego", "ipopt", "registry_test_static", "sleep", "toy"}));
}

TEST(PlannerRegistry, StaticRegistrationIsFound) {
  const Experiment e = Experiment::FromString(WithType("registry_test_static"), "exp.yaml");
  EXPECT_EQ(e.planner_type, "registry_test_static");
  EXPECT_NE(e.planner.Extract<test::ToyPlanner>(), nullptr);
}

TEST(PlannerRegistry, SecondRegistrationTunesLikeTheFirst) {
  if (!FindPlanner("registry_test_toy")) {
    RegisterPlanner("registry_test_toy", BuildToyAgain, PlannerSchema::Of(test::ToyPlanner{}));
  }
  const RunSummary mine =
      RunExperiment(Experiment::FromString(WithType("registry_test_toy"), "exp.yaml"));
  const RunSummary toy = RunExperiment(Experiment::FromString(WithType("toy"), "exp.yaml"));
  ASSERT_EQ(mine.trials.size(), 2u);
  ASSERT_EQ(toy.trials.size(), 2u);
  EXPECT_EQ(mine.flights, toy.flights);
  EXPECT_EQ(mine.resolves, toy.resolves);
  for (std::size_t i = 0; i < mine.trials.size(); ++i) {
    EXPECT_EQ(mine.trials[i].best_value, toy.trials[i].best_value) << i;
    EXPECT_EQ(mine.trials[i].best, toy.trials[i].best) << i;
  }
}

TEST(PlannerRegistry, SchemaBoundsTheTuningBox) {
  // The toy schema allows gain in (0, 2].
  std::string text = WithType("registry_test_static");
  const std::string from = "upper: 1.5, default: 0.3";
  text.replace(text.find(from), from.size(), "upper: 2.5, default: 0.3");
  EXPECT_TRUE(quadtune::test::ThrowsConfigError([&] { (void)Experiment::FromString(text, "exp.yaml"); },
                                      "parameters.0.upper",
                                      {"registry_test_static", "gain", "(0, 2]"}));
}

// The types flown in the closed loop give the trajectory back end `quadtune fly --planner` flies;
// planners with a loop of their own give none.
TEST(PlannerRegistry, ClosedLoopTypesGiveTheirBackEnd) {
  for (const char* name : {"ipopt", "ego"}) {
    const auto type = FindPlanner(name);
    ASSERT_TRUE(type.has_value() && type->backend) << name;
    const auto backend = type->backend();
    ASSERT_NE(backend, nullptr) << name;
    EXPECT_EQ(backend->Name(), name);
  }
  for (const char* name : {"toy", "sleep", "registry_test_static"}) {
    const auto type = FindPlanner(name);
    ASSERT_TRUE(type.has_value()) << name;
    EXPECT_FALSE(type->backend) << name;
  }
}

// BuildClosedLoopBackend is how `fly --planner` and an adaptation experiment's `planner.type`
// find a back end: the closed-loop types build theirs; the others and unknown names are refused
// with the file and key given, listing the closed-loop types.
TEST(PlannerRegistry, BuildClosedLoopBackendRefusesTypesWithoutOne) {
  EXPECT_EQ(ClosedLoopPlanners(), (std::vector<std::string>{"ego", "ipopt"}));
  for (const char* name : {"ipopt", "ego"}) {
    const auto backend = BuildClosedLoopBackend(name, "f.yaml", "planner.type");
    ASSERT_NE(backend, nullptr) << name;
    EXPECT_EQ(backend->Name(), name);
  }
  for (const std::string name : {"toy", "sleep", "rrt"}) {
    EXPECT_TRUE(quadtune::test::ThrowsConfigError(
        [&] { (void)BuildClosedLoopBackend(name, "f.yaml", "planner.type"); }, "planner.type",
        {"f.yaml", "'" + name + "' is not a registered planner flown in the closed loop",
         "registered: ego, ipopt"}));
  }
}

TEST(PlannerRegistry, BadRegistrationsThrow) {
  const PlannerSchema schema = PlannerSchema::Of(test::ToyPlanner{});
  EXPECT_THROW(RegisterPlanner("toy", BuildToyAgain, schema), std::invalid_argument);
  EXPECT_THROW(RegisterPlanner("", BuildToyAgain, schema), std::invalid_argument);
  EXPECT_THROW(RegisterPlanner("Registry-Test", BuildToyAgain, schema), std::invalid_argument);
  EXPECT_THROW(RegisterPlanner("registry_test_empty", PlannerFactory{}, schema),
               std::invalid_argument);
  PlannerSchema twice = schema;
  twice.long_term.push_back(schema.short_term.front());
  EXPECT_THROW(RegisterPlanner("registry_test_twice", BuildToyAgain, twice),
               std::invalid_argument);
  EXPECT_FALSE(FindPlanner("registry_test_twice").has_value());
}

TEST(PlannerRegistry, PlugInThatDiffersFromItsSchemaIsABug) {
  if (!FindPlanner("registry_test_mismatch")) {
    RegisterPlanner("registry_test_mismatch", BuildToyAgain,
                    PlannerSchema::Of(test::SleepPlanner{}));
  }
  EXPECT_THROW((void)Experiment::FromString(WithType("registry_test_mismatch"), "exp.yaml"),
               InvariantError);
}

}  // namespace
}  // namespace quadtune::engine
