#pragma once
/// \file
/// The ask/tell interface shared by every quadtune optimizer (PSO, Bayesian optimisation, random
/// search). The engine asks for as many candidates as it has free worlds, evaluates them in any
/// order, possibly concurrently, and tells the results back by candidate id.
///
/// All optimizers **minimise** the objective (the paper's θ* = argmin E[f(θ)], Eq. 1).
///
/// Thread safety: an optimizer instance is used by one thread at a time; the engine serialises
/// Ask/Tell/Best/SaveState. Distinct instances are independent.

#include <Eigen/Core>
#include <cstdint>
#include <limits>
#include <nlohmann/json.hpp>
#include <optional>
#include <vector>

#include "quadtune/optimizers/parameter_space.hpp"

namespace quadtune::optimizers {

/// Identifies one issued candidate; ids are issued 0, 1, 2, … by each optimizer instance.
using CandidateId = std::uint64_t;

/// A point to evaluate.
struct Candidate {
  CandidateId id = 0;  ///< pass back to Tell
  Eigen::VectorXd x;   ///< original coordinates, inside the space, integer parameters integral
};

/// The optimizer's current estimate of the minimiser.
struct BestPoint {
  Eigen::VectorXd x;          ///< original coordinates
  double value = 0.0;         ///< estimated objective at x (a posterior mean or running average)
  double observed = 0.0;      ///< the (last or averaged) observed value at x
  CandidateId id = 0;         ///< the candidate that first evaluated x
};

/// Abstract ask/tell optimizer. Subclasses implement the Do* hooks; the public methods check
/// arguments first, so a bad call changes no state.
class Optimizer {
 public:
  virtual ~Optimizer() = default;
  Optimizer() = default;
  Optimizer(const Optimizer&) = default;
  Optimizer& operator=(const Optimizer&) = default;
  Optimizer(Optimizer&&) = default;
  Optimizer& operator=(Optimizer&&) = default;

  /// Proposes up to k new candidates (k >= 1, else std::invalid_argument). Every returned
  /// candidate is pending until told or cancelled. May return fewer than k when the method
  /// cannot propose more (PSO: every particle is pending).
  std::vector<Candidate> Ask(int k);

  /// Reports the objective value of one pending candidate. `noise_variance` is the observation's
  /// noise variance σ₀² in squared objective units (used by Bayesian optimisation, ignored by
  /// the others); absent → the optimizer's default. Throws std::invalid_argument for an unknown or
  /// already told id, a non-finite value or a negative / non-finite noise variance.
  void Tell(CandidateId id, double value, std::optional<double> noise_variance = std::nullopt);
  /// Reports several results at once; all are checked before any is applied. `noise_variances`
  /// is empty or has the size of `values`. Throws std::invalid_argument on size mismatch,
  /// duplicate ids and everything the single-result Tell rejects.
  void Tell(const std::vector<CandidateId>& ids, const std::vector<double>& values,
            const std::vector<double>& noise_variances = {});
  /// As above, taking the candidates returned by Ask.
  void Tell(const std::vector<Candidate>& candidates, const std::vector<double>& values,
            const std::vector<double>& noise_variances = {});

  /// Withdraws a pending candidate whose evaluation failed or was abandoned (unknown id →
  /// std::invalid_argument). PSO re-issues the particle; the others forget the point.
  void Cancel(CandidateId id);

  /// The current best estimate; std::nullopt before the first result.
  [[nodiscard]] virtual std::optional<BestPoint> Best() const = 0;
  /// Number of issued candidates not yet told or cancelled.
  [[nodiscard]] virtual std::size_t NumPending() const = 0;
  /// Number of results told so far.
  [[nodiscard]] virtual std::size_t NumTold() const = 0;
  /// The space searched.
  [[nodiscard]] virtual const ParameterSpace& Space() const = 0;

  /// The complete mutable state (RNG included) as JSON. An optimizer constructed with the same
  /// space and options and given this state through RestoreState continues exactly as this one.
  [[nodiscard]] virtual nlohmann::json SaveState() const = 0;
  /// Replaces the state by one from SaveState; throws std::invalid_argument when the state is
  /// malformed or belongs to another method or dimension.
  virtual void RestoreState(const nlohmann::json& state) = 0;

 protected:
  /// True when `id` is pending (issued, not told, not cancelled) or otherwise acceptable to Tell.
  [[nodiscard]] virtual bool Accepts(CandidateId id) const = 0;
  /// Implements Ask after the argument check.
  virtual std::vector<Candidate> DoAsk(int k) = 0;
  /// Implements Tell for a checked result; `noise_variance` is NaN when not given.
  virtual void DoTell(CandidateId id, double value, double noise_variance) = 0;
  /// Implements Cancel for a checked id.
  virtual void DoCancel(CandidateId id) = 0;
};

}  // namespace quadtune::optimizers
