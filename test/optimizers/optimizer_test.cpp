// Checks of the shared ask/tell contract (optimizer.hpp) on every optimizer.
#include "quadtune/optimizers/optimizer.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <memory>

#include "../config_error_util.hpp"
#include "quadtune/optimizers/bayes_opt.hpp"
#include "quadtune/optimizers/pso.hpp"
#include "quadtune/optimizers/random_search.hpp"
#include "test_functions.hpp"

namespace quadtune::optimizers {
namespace {

using quadtune::test::ThrowsWithMessage;

using Factory = std::function<std::unique_ptr<Optimizer>()>;

class OptimizerContract : public ::testing::TestWithParam<int> {
 protected:
  std::unique_ptr<Optimizer> Make() const {
    const ParameterSpace space = testing::BoxSpace(2, 0.0, 1.0);
    switch (GetParam()) {
      case 0: return std::make_unique<RandomSearch>(space);
      case 1: return std::make_unique<Pso>(space, PsoOptions{});
      default: return std::make_unique<BayesOpt>(space, BayesOptOptions{});
    }
  }
};

TEST_P(OptimizerContract, RejectsNonPositiveAsk) {
  auto opt = Make();
  EXPECT_TRUE(
      ThrowsWithMessage<std::invalid_argument>([&] { opt->Ask(0); }, {"k must be >= 1", "got 0"}));
}

TEST_P(OptimizerContract, RejectsNaNValue) {
  auto opt = Make();
  const auto c = opt->Ask(1);
  EXPECT_TRUE(ThrowsWithMessage<std::invalid_argument>([&] { opt->Tell(c[0].id, std::nan("")); },
                                                       {"must be finite", "got nan"}));
  EXPECT_TRUE(ThrowsWithMessage<std::invalid_argument>([&] { opt->Tell(c[0].id, INFINITY); },
                                                       {"must be finite", "got inf"}));
  EXPECT_EQ(opt->NumPending(), 1u);  // nothing applied
}

TEST_P(OptimizerContract, RejectsBadNoiseVariance) {
  auto opt = Make();
  const auto c = opt->Ask(1);
  EXPECT_TRUE(ThrowsWithMessage<std::invalid_argument>([&] { opt->Tell(c[0].id, 1.0, -1.0); },
                                                       {"noise variance must be finite and >= 0"}));
  EXPECT_TRUE(ThrowsWithMessage<std::invalid_argument>(
      [&] { opt->Tell(c[0].id, 1.0, std::nan("")); }, {"noise variance is NaN"}));
}

TEST_P(OptimizerContract, RejectsUnknownCandidateId) {
  auto opt = Make();
  const auto c = opt->Ask(1);
  EXPECT_TRUE(ThrowsWithMessage<std::invalid_argument>([&] { opt->Tell(c[0].id + 1000, 1.0); },
                                                       {"unknown candidate id"}));
  EXPECT_TRUE(ThrowsWithMessage<std::invalid_argument>([&] { opt->Cancel(c[0].id + 1000); },
                                                       {"unknown candidate id"}));
  opt->Tell(c[0].id, 1.0);
  EXPECT_TRUE(ThrowsWithMessage<std::invalid_argument>(
      [&] { opt->Tell(c[0].id, 1.0); }, {"unknown candidate id", "already told"}));  // told twice
}

TEST_P(OptimizerContract, RejectsWrongVectorSizes) {
  auto opt = Make();
  const auto c = opt->Ask(2);
  EXPECT_TRUE(ThrowsWithMessage<std::invalid_argument>([&] { opt->Tell(c, {1.0}); },
                                                       {"2 ids but 1 values"}));
  EXPECT_TRUE(ThrowsWithMessage<std::invalid_argument>(
      [&] {
        opt->Tell(c, {1.0, 2.0}, {0.1});
      },
      {"2 values but 1 noise variances"}));
  EXPECT_EQ(opt->NumPending(), 2u);
}

TEST_P(OptimizerContract, RejectsDuplicateIdsAtomically) {
  auto opt = Make();
  const auto c = opt->Ask(2);
  EXPECT_TRUE(ThrowsWithMessage<std::invalid_argument>(
      [&] {
        opt->Tell(std::vector<CandidateId>{c[0].id, c[0].id}, {1.0, 2.0});
      },
      {"appears twice"}));
  EXPECT_TRUE(ThrowsWithMessage<std::invalid_argument>(
      [&] {
        opt->Tell(std::vector<CandidateId>{c[0].id, c[1].id}, {1.0, std::nan("")});
      },
      {"must be finite", "got nan"}));
  EXPECT_EQ(opt->NumPending(), 2u);
  EXPECT_EQ(opt->NumTold(), 0u);
  opt->Tell(c, {1.0, 2.0});
  EXPECT_EQ(opt->NumTold(), 2u);
}

TEST_P(OptimizerContract, RejectsMalformedState) {
  auto opt = Make();
  EXPECT_TRUE(ThrowsWithMessage<std::invalid_argument>(
      [&] { opt->RestoreState(nlohmann::json::object()); }, {"not a saved optimizer state"}));
  EXPECT_TRUE(ThrowsWithMessage<std::invalid_argument>(
      [&] {
        opt->RestoreState(nlohmann::json{{"method", "other"}, {"dim", 2}});
      },
      {"saved by 'other'", "cannot restore"}));
}

TEST_P(OptimizerContract, BestIsEmptyBeforeResults) {
  auto opt = Make();
  EXPECT_FALSE(opt->Best().has_value());
  const auto c = opt->Ask(1);
  opt->Tell(c[0].id, 4.0);
  ASSERT_TRUE(opt->Best().has_value());
  EXPECT_EQ(opt->Best()->x, c[0].x);
}

INSTANTIATE_TEST_SUITE_P(AllOptimizers, OptimizerContract, ::testing::Values(0, 1, 2));

}  // namespace
}  // namespace quadtune::optimizers
