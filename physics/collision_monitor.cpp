#include "quadtune/physics/collision_monitor.hpp"

#include <algorithm>

#include "quadtune/common/error.hpp"

namespace quadtune::physics {

CollisionMonitor::CollisionMonitor(double release_time) : release_time_(release_time) {
  QT_DEMAND(release_time >= 0.0, "release_time must be >= 0");
}

void CollisionMonitor::Reset() {
  episodes_.clear();
  open_.clear();
}

void CollisionMonitor::Update(double time, std::span<const ObstacleId> in_contact, double speed) {
  // Close episodes whose obstacle has been clear for longer than release_time.
  std::erase_if(open_, [&](std::size_t i) { return time - episodes_[i].last_time > release_time_; });
  if (in_contact.empty()) return;
  // Deterministic order for episodes that start in the same step.
  ObstacleId sorted[16];
  std::vector<ObstacleId> heap;
  std::span<ObstacleId> ids;
  if (in_contact.size() <= 16) {
    std::copy(in_contact.begin(), in_contact.end(), sorted);
    ids = std::span<ObstacleId>(sorted, in_contact.size());
  } else {
    heap.assign(in_contact.begin(), in_contact.end());
    ids = heap;
  }
  std::sort(ids.begin(), ids.end());
  for (std::size_t k = 0; k < ids.size(); ++k) {
    if (k > 0 && ids[k] == ids[k - 1]) continue;
    const ObstacleId& id = ids[k];
    bool continued = false;
    for (std::size_t i : open_) {
      if (episodes_[i].obstacle == id) {
        episodes_[i].last_time = time;
        continued = true;
        break;
      }
    }
    if (!continued) {
      episodes_.push_back({id, time, time, speed});
      open_.push_back(episodes_.size() - 1);
    }
  }
}

std::size_t CollisionMonitor::CountFor(const ObstacleId& id) const {
  return static_cast<std::size_t>(std::count_if(
      episodes_.begin(), episodes_.end(), [&](const CollisionEpisode& e) { return e.obstacle == id; }));
}

std::size_t CollisionMonitor::CountFor(ObstacleKind kind) const {
  return static_cast<std::size_t>(std::count_if(episodes_.begin(), episodes_.end(),
                                                [&](const CollisionEpisode& e) {
                                                  return e.obstacle.kind == kind;
                                                }));
}

std::size_t CollisionMonitor::CountObstacles() const {
  return Count() - CountFor(ObstacleKind::kGround);
}

std::optional<double> CollisionMonitor::FirstContactTime() const {
  if (episodes_.empty()) return std::nullopt;
  return episodes_.front().start_time;
}

bool CollisionMonitor::InContact(double time) const {
  return std::any_of(open_.begin(), open_.end(), [&](std::size_t i) {
    return time - episodes_[i].last_time <= release_time_;
  });
}

}  // namespace quadtune::physics
