#pragma once
/// \file
/// A piecewise-polynomial 3-D trajectory in the world frame W: one quintic per piece, each piece
/// in its own local time τ ∈ [0, T_i]. The planner's minimum-jerk optimiser produces it; the
/// controller, the collision check and the metrics evaluate it.
///
/// Thread safety: an immutable value type once constructed; concurrent const calls are safe.

#include <Eigen/Core>
#include <string>
#include <vector>

namespace quadtune::planning {

/// One time sample of a trajectory (world frame W, SI units).
struct TrajectorySample {
  double t = 0.0;                                   ///< time since the trajectory start (s)
  Eigen::Vector3d p_W = Eigen::Vector3d::Zero();    ///< position (m)
  Eigen::Vector3d v_W = Eigen::Vector3d::Zero();    ///< velocity (m/s)
  Eigen::Vector3d a_W = Eigen::Vector3d::Zero();    ///< acceleration (m/s^2)
};

/// Piecewise quintic trajectory p_W(t), t ∈ [0, Duration()].
class Trajectory {
 public:
  /// Column k multiplies τ^k (τ: local time of the piece, s); rows are x, y, z (m).
  using Coefficients = Eigen::Matrix<double, 3, 6>;

  /// An empty trajectory (no pieces); Duration() = 0. Evaluating it throws InvariantError.
  Trajectory() = default;

  /// Pieces with the given durations (s, each finite and > 0) and coefficients (finite); the
  /// two vectors must have equal, non-zero length. Throws std::invalid_argument otherwise.
  /// Continuity across joints is not enforced here (the optimiser produces C^4 splines).
  Trajectory(std::vector<double> durations, std::vector<Coefficients> coefficients);

  /// True when the trajectory has no pieces.
  [[nodiscard]] bool Empty() const { return durations_.empty(); }
  /// Number of polynomial pieces.
  [[nodiscard]] int NumPieces() const { return static_cast<int>(durations_.size()); }
  /// Total duration (s).
  [[nodiscard]] double Duration() const { return total_duration_; }
  /// Duration of piece i (s), 0 <= i < NumPieces().
  [[nodiscard]] double PieceDuration(int i) const;
  /// Coefficients of piece i in its local time.
  [[nodiscard]] const Coefficients& PieceCoefficients(int i) const;
  /// All piece durations (s).
  [[nodiscard]] const std::vector<double>& Durations() const { return durations_; }

  /// The `order`-th time derivative (0 position m, 1 velocity m/s, 2 acceleration m/s^2,
  /// 3 jerk m/s^3, 4 snap, 5 crackle) at t (s). t is clamped to [0, Duration()]; at a joint the
  /// later piece is used. Throws InvariantError for an empty trajectory or order outside [0, 5].
  [[nodiscard]] Eigen::Vector3d Evaluate(double t, int order) const;
  /// Position p_W(t) (m).
  [[nodiscard]] Eigen::Vector3d Position(double t) const { return Evaluate(t, 0); }
  /// Velocity v_W(t) (m/s).
  [[nodiscard]] Eigen::Vector3d Velocity(double t) const { return Evaluate(t, 1); }
  /// Acceleration a_W(t) (m/s^2).
  [[nodiscard]] Eigen::Vector3d Acceleration(double t) const { return Evaluate(t, 2); }
  /// Jerk j_W(t) (m/s^3).
  [[nodiscard]] Eigen::Vector3d Jerk(double t) const { return Evaluate(t, 3); }
  /// Position, velocity and acceleration at t (s) with one piece lookup: the same values as
  /// Position(t), Velocity(t) and Acceleration(t).
  void State(double t, Eigen::Vector3d* p_W, Eigen::Vector3d* v_W, Eigen::Vector3d* a_W) const;

  /// Index of the piece containing t (clamped) and the local time in it (s).
  [[nodiscard]] int LocatePiece(double t, double* local_t) const;

  /// Jerk energy ∫_0^T |j_W(t)|^2 dt (m^2/s^5) in closed form.
  [[nodiscard]] double JerkEnergy() const;

  /// Samples at t = 0, dt, 2 dt, ... and always at Duration() (dt > 0, s).
  [[nodiscard]] std::vector<TrajectorySample> Sample(double dt) const;
  /// Largest |v_W| (m/s) on samples spaced dt (s).
  [[nodiscard]] double MaxSpeed(double dt) const;
  /// Largest |a_W| (m/s^2) on samples spaced dt (s).
  [[nodiscard]] double MaxAcceleration(double dt) const;
  /// Path length (m) of the polyline through samples spaced dt (s).
  [[nodiscard]] double Length(double dt) const;

  friend bool operator==(const Trajectory& a, const Trajectory& b) {
    return a.durations_ == b.durations_ && a.coefficients_ == b.coefficients_;
  }

 private:
  std::vector<double> durations_;
  std::vector<Coefficients> coefficients_;
  std::vector<double> start_times_;  // start time of each piece (s)
  double total_duration_ = 0.0;
};

/// The braking envelope of a plan that starts at speed v_start above its v_des: it may exceed
/// v_des (never v_start) only for the time a braking at braking_fraction · a_max takes,
/// (v_start − v_des) / (braking_fraction · a_max), and never a_max; each limit with a relative
/// `tolerance`, on samples spaced check_dt (s). Returns "" when `trajectory` stays inside, else
/// why not: "no_trajectory", "braking_too_slow" or "over_a_max".
[[nodiscard]] std::string BrakingEnvelopeViolation(const Trajectory& trajectory, double v_start,
                                                   double v_des, double a_max,
                                                   double braking_fraction, double tolerance,
                                                   double check_dt);

}  // namespace quadtune::planning
