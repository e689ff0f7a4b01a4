#include "quadtune/optimizers/random_search.hpp"

#include <gtest/gtest.h>

#include "test_functions.hpp"

namespace quadtune::optimizers {
namespace {

TEST(RandomSearch, KeepsTheLowestValue) {
  RandomSearch rs(testing::BoxSpace(2, -1.0, 1.0), {});
  const auto c = rs.Ask(50);
  std::vector<double> v;
  for (const auto& x : c) {
    EXPECT_TRUE(rs.Space().Contains(x.x));
    v.push_back(testing::Sphere(x.x));
  }
  rs.Tell(c, v);
  const auto it = std::min_element(v.begin(), v.end());
  EXPECT_DOUBLE_EQ(rs.Best()->value, *it);
  EXPECT_EQ(rs.Best()->x, c[static_cast<std::size_t>(it - v.begin())].x);
  EXPECT_EQ(rs.NumTold(), 50u);
}

TEST(RandomSearch, SameSeedSameCandidatesAndRestore) {
  RandomSearchOptions o;
  o.seed = 8;
  RandomSearch a(testing::BoxSpace(3, 0.0, 1.0), o), b(testing::BoxSpace(3, 0.0, 1.0), o);
  const auto ca = a.Ask(4);
  const auto cb = b.Ask(4);
  for (std::size_t i = 0; i < 4; ++i) EXPECT_EQ(ca[i].x, cb[i].x);
  a.Tell(ca[0].id, 1.0);
  RandomSearch c(testing::BoxSpace(3, 0.0, 1.0), {});
  c.RestoreState(nlohmann::json::parse(a.SaveState().dump()));
  EXPECT_EQ(a.Ask(3)[2].x, c.Ask(3)[2].x);
  EXPECT_EQ(c.NumPending(), 6u);
  EXPECT_EQ(c.Best()->id, ca[0].id);
}

}  // namespace
}  // namespace quadtune::optimizers
