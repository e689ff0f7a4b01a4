#pragma once
/// \file
/// Uniform random search in the unit cube of a ParameterSpace: the baseline of the paper's
/// benchmark comparison (Sec. IV-A).
///
/// Thread safety: one thread at a time (the engine serialises calls); instances independent.

#include <map>

#include "quadtune/common/random.hpp"
#include "quadtune/optimizers/optimizer.hpp"

namespace quadtune::optimizers {

/// Settings of RandomSearch.
struct RandomSearchOptions {
  std::uint64_t seed = 0;  ///< explicit seed
  /// Nothing to check; kept for the Options/Validate convention.
  void Validate() const {}
};

/// Ask/tell random search (minimisation): candidates are uniform in the unit cube (so log-scale
/// parameters are log-uniform and every integer equally likely); Best() is the lowest value told.
class RandomSearch final : public Optimizer {
 public:
  /// Throws ConfigError for an empty space.
  RandomSearch(ParameterSpace space, RandomSearchOptions options = {});

  [[nodiscard]] std::optional<BestPoint> Best() const override { return best_; }
  [[nodiscard]] std::size_t NumPending() const override { return pending_.size(); }
  [[nodiscard]] std::size_t NumTold() const override { return num_told_; }
  [[nodiscard]] const ParameterSpace& Space() const override { return space_; }
  [[nodiscard]] nlohmann::json SaveState() const override;
  void RestoreState(const nlohmann::json& state) override;

 protected:
  [[nodiscard]] bool Accepts(CandidateId id) const override { return pending_.count(id) > 0; }
  std::vector<Candidate> DoAsk(int k) override;
  void DoTell(CandidateId id, double value, double noise_variance) override;
  void DoCancel(CandidateId id) override { pending_.erase(id); }

 private:
  ParameterSpace space_;
  Rng rng_;
  CandidateId next_id_ = 0;
  std::size_t num_told_ = 0;
  std::map<CandidateId, Eigen::VectorXd> pending_;  // original coordinates
  std::optional<BestPoint> best_;
};

}  // namespace quadtune::optimizers
