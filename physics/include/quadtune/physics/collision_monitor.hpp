#pragma once
/// \file
/// Counts the quadrotor's collisions as contact episodes, once per episode and obstacle.
///
/// An episode with obstacle X starts at the first physics step in which the drone touches X and
/// ends when the drone has been clear of X for longer than `release_time`; touching X again
/// within release_time (a bounce, a scrape along a pillar, or the several Bullet manifolds of
/// one ring) continues the same episode. Touching two obstacles at once makes two episodes.
///
/// Thread safety: a value owned by one World; not safe for concurrent mutation.

#include <cstddef>
#include <optional>
#include <span>
#include <vector>

#include "quadtune/physics/obstacles.hpp"

namespace quadtune::physics {

/// One contact episode between the drone and one obstacle.
struct CollisionEpisode {
  ObstacleId obstacle;       ///< what was hit
  double start_time = 0.0;   ///< simulation time of the first contact (s)
  double last_time = 0.0;    ///< simulation time of the latest contact so far (s)
  double impact_speed = 0.0; ///< drone speed |v_W| at the first contact (m/s)
};

/// Episode bookkeeping, fed once per physics step with the obstacles in contact.
class CollisionMonitor {
 public:
  /// `release_time` (s, >= 0): how long contact must be lost before a new episode can start.
  explicit CollisionMonitor(double release_time = 0.05);

  /// Forgets every episode.
  void Reset();

  /// Records that the drone touches every obstacle in `in_contact` at `time` (s), moving at
  /// `speed` (m/s). Duplicates in `in_contact` are allowed. Times must not decrease.
  void Update(double time, std::span<const ObstacleId> in_contact, double speed);

  /// Every episode so far, in order of start (ties: in order of ObstacleId).
  [[nodiscard]] const std::vector<CollisionEpisode>& episodes() const { return episodes_; }
  /// Number of episodes (every obstacle, the ground included).
  [[nodiscard]] std::size_t Count() const { return episodes_.size(); }
  /// Number of episodes with obstacle `id`.
  [[nodiscard]] std::size_t CountFor(const ObstacleId& id) const;
  /// Number of episodes with obstacles of `kind`.
  [[nodiscard]] std::size_t CountFor(ObstacleKind kind) const;
  /// Number of episodes with anything but the ground.
  [[nodiscard]] std::size_t CountObstacles() const;
  /// Start time (s) of the first episode, if any.
  [[nodiscard]] std::optional<double> FirstContactTime() const;
  /// True while at least one episode is open (the drone touched something within release_time).
  [[nodiscard]] bool InContact(double time) const;
  [[nodiscard]] double release_time() const { return release_time_; }

 private:
  double release_time_;
  std::vector<CollisionEpisode> episodes_;
  std::vector<std::size_t> open_;  // indices into episodes_ of episodes that may continue
};

}  // namespace quadtune::physics
