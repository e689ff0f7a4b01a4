#include "quadtune/planning/trajectory.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "quadtune/common/error.hpp"

namespace quadtune::planning {

Trajectory::Trajectory(std::vector<double> durations, std::vector<Coefficients> coefficients)
    : durations_(std::move(durations)), coefficients_(std::move(coefficients)) {
  if (durations_.empty() || durations_.size() != coefficients_.size()) {
    throw std::invalid_argument("Trajectory: need equal, non-zero numbers of durations (" +
                                std::to_string(durations_.size()) + ") and coefficient blocks (" +
                                std::to_string(coefficients_.size()) + ")");
  }
  start_times_.reserve(durations_.size());
  for (std::size_t i = 0; i < durations_.size(); ++i) {
    if (!std::isfinite(durations_[i]) || durations_[i] <= 0.0) {
      throw std::invalid_argument("Trajectory: duration of piece " + std::to_string(i) +
                                  " must be finite and > 0, got " + std::to_string(durations_[i]));
    }
    if (!coefficients_[i].allFinite()) {
      throw std::invalid_argument("Trajectory: coefficients of piece " + std::to_string(i) +
                                  " are not finite");
    }
    start_times_.push_back(total_duration_);
    total_duration_ += durations_[i];
  }
}

double Trajectory::PieceDuration(int i) const {
  QT_DEMAND(i >= 0 && i < NumPieces(), "piece index out of range");
  return durations_[static_cast<std::size_t>(i)];
}

const Trajectory::Coefficients& Trajectory::PieceCoefficients(int i) const {
  QT_DEMAND(i >= 0 && i < NumPieces(), "piece index out of range");
  return coefficients_[static_cast<std::size_t>(i)];
}

int Trajectory::LocatePiece(double t, double* local_t) const {
  QT_DEMAND(!Empty(), "empty trajectory");
  t = std::clamp(t, 0.0, total_duration_);
  // Last piece whose start time is <= t.
  const auto it = std::upper_bound(start_times_.begin(), start_times_.end(), t);
  int i = static_cast<int>(it - start_times_.begin()) - 1;
  i = std::clamp(i, 0, NumPieces() - 1);
  const auto ui = static_cast<std::size_t>(i);
  *local_t = std::clamp(t - start_times_[ui], 0.0, durations_[ui]);
  return i;
}

namespace {

// Horner on the order-th derivative of a piece: sum_k k!/(k-order)! c_k tau^(k-order).
Eigen::Vector3d Derivative(const Trajectory::Coefficients& c, double tau, int order) {
  Eigen::Vector3d r = Eigen::Vector3d::Zero();
  for (int k = 5; k >= order; --k) {
    double factor = 1.0;
    for (int m = 0; m < order; ++m) factor *= static_cast<double>(k - m);
    r = r * tau + factor * c.col(k);
  }
  return r;
}

}  // namespace

Eigen::Vector3d Trajectory::Evaluate(double t, int order) const {
  QT_DEMAND(order >= 0 && order <= 5, "derivative order must be in [0, 5]");
  double tau = 0.0;
  const int i = LocatePiece(t, &tau);
  return Derivative(coefficients_[static_cast<std::size_t>(i)], tau, order);
}

void Trajectory::State(double t, Eigen::Vector3d* p_W, Eigen::Vector3d* v_W,
                       Eigen::Vector3d* a_W) const {
  double tau = 0.0;
  const int i = LocatePiece(t, &tau);
  const Coefficients& c = coefficients_[static_cast<std::size_t>(i)];
  *p_W = Derivative(c, tau, 0);
  *v_W = Derivative(c, tau, 1);
  *a_W = Derivative(c, tau, 2);
}

double Trajectory::JerkEnergy() const {
  // j(τ) = 6 c3 + 24 c4 τ + 60 c5 τ^2, so ∫_0^T |j|^2 dτ =
  // 36|c3|^2 T + 144 c3·c4 T^2 + (192|c4|^2 + 240 c3·c5) T^3 + 720 c4·c5 T^4 + 720|c5|^2 T^5.
  double energy = 0.0;
  for (std::size_t i = 0; i < durations_.size(); ++i) {
    const auto& c = coefficients_[i];
    const double t1 = durations_[i];
    const double t2 = t1 * t1;
    const double t3 = t2 * t1;
    const double t4 = t3 * t1;
    const double t5 = t4 * t1;
    const Eigen::Vector3d c3 = c.col(3);
    const Eigen::Vector3d c4 = c.col(4);
    const Eigen::Vector3d c5 = c.col(5);
    energy += 36.0 * c3.squaredNorm() * t1 + 144.0 * c3.dot(c4) * t2 +
              (192.0 * c4.squaredNorm() + 240.0 * c3.dot(c5)) * t3 + 720.0 * c4.dot(c5) * t4 +
              720.0 * c5.squaredNorm() * t5;
  }
  return energy;
}

std::vector<TrajectorySample> Trajectory::Sample(double dt) const {
  QT_DEMAND(dt > 0.0 && std::isfinite(dt), "sample spacing must be > 0");
  std::vector<TrajectorySample> samples;
  if (Empty()) return samples;
  const auto count = static_cast<std::size_t>(std::floor(total_duration_ / dt));
  samples.reserve(count + 2);
  for (std::size_t k = 0; k <= count; ++k) {
    const double t = static_cast<double>(k) * dt;
    if (t >= total_duration_) break;
    TrajectorySample& sample = samples.emplace_back();
    sample.t = t;
    State(t, &sample.p_W, &sample.v_W, &sample.a_W);
  }
  TrajectorySample& last = samples.emplace_back();
  last.t = total_duration_;
  State(total_duration_, &last.p_W, &last.v_W, &last.a_W);
  return samples;
}

double Trajectory::MaxSpeed(double dt) const {
  double m = 0.0;
  for (const auto& s : Sample(dt)) m = std::max(m, s.v_W.norm());
  return m;
}

double Trajectory::MaxAcceleration(double dt) const {
  double m = 0.0;
  for (const auto& s : Sample(dt)) m = std::max(m, s.a_W.norm());
  return m;
}

double Trajectory::Length(double dt) const {
  const auto samples = Sample(dt);
  double length = 0.0;
  for (std::size_t k = 1; k < samples.size(); ++k) {
    length += (samples[k].p_W - samples[k - 1].p_W).norm();
  }
  return length;
}

std::string BrakingEnvelopeViolation(const Trajectory& trajectory, double v_start, double v_des,
                                     double a_max, double braking_fraction, double tolerance,
                                     double check_dt) {
  if (trajectory.Empty()) return "no_trajectory";
  const double brake_time = (v_start - v_des) / (braking_fraction * a_max);
  for (const TrajectorySample& s : trajectory.Sample(check_dt)) {
    const double limit = s.t <= brake_time ? v_start : v_des;
    if (s.v_W.norm() > (1.0 + tolerance) * limit) return "braking_too_slow";
    if (s.a_W.norm() > (1.0 + tolerance) * a_max) return "over_a_max";
  }
  return "";
}

}  // namespace quadtune::planning
