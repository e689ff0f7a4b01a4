// quadtune::planning without physics: this executable links quadtune::planning alone, with
// --no-as-needed, so every shared library on its link line (planning's own dependencies and
// whatever they bring) is loaded. Bullet among them means planning links physics again.

#include <gtest/gtest.h>
#include <link.h>

#include <string>
#include <vector>

#include "quadtune/planning/quintic.hpp"

namespace quadtune::planning {
namespace {

std::vector<std::string> LoadedLibraries() {
  std::vector<std::string> names;
  dl_iterate_phdr(
      [](dl_phdr_info* info, std::size_t /*size*/, void* data) {
        if (info->dlpi_name != nullptr && info->dlpi_name[0] != '\0') {
          static_cast<std::vector<std::string>*>(data)->push_back(info->dlpi_name);
        }
        return 0;
      },
      &names);
  return names;
}

bool AnyContains(const std::vector<std::string>& names, const std::string& part) {
  for (const auto& n : names) {
    if (n.find(part) != std::string::npos) return true;
  }
  return false;
}

TEST(PlanningStandalone, LoadsItsOwnDependenciesButNoBullet) {
  const std::vector<std::string> libraries = LoadedLibraries();
  // The check sees the link line: Ipopt is a private dependency of planning's static library.
  ASSERT_TRUE(AnyContains(libraries, "libipopt")) << "Ipopt not loaded; the check sees nothing";
  for (const char* bullet : {"libBullet", "libLinearMath"}) {
    EXPECT_FALSE(AnyContains(libraries, bullet))
        << bullet << " is loaded: quadtune::planning links physics (Bullet)";
  }
}

TEST(PlanningStandalone, PlansWithoutAWorld) {
  const Eigen::Vector3d p0(1.0, 2.0, 1.5);
  const Eigen::Vector3d v0(2.0, 0.0, 0.0);
  const Trajectory brake = BrakingTrajectory(p0, v0, Eigen::Vector3d::Zero(), 4.0);
  EXPECT_NEAR(brake.Duration(), 1.0, 1e-12);  // max(2·|v0|/decel, 0.2 s)
  EXPECT_LT(brake.Velocity(brake.Duration()).norm(), 1e-9);
  EXPECT_GT(brake.Position(brake.Duration()).x(), p0.x());
}

}  // namespace
}  // namespace quadtune::planning
