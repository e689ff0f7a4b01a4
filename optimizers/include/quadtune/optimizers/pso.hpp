#pragma once
/// \file
/// Asynchronous particle swarm optimisation (paper Sec. III-C-1), the short-term optimizer.
///
/// Each particle n keeps a position θ_n, a velocity v_n and its personal best p_n; g is the best
/// personal best of the swarm. When a particle whose last position has been evaluated is asked
/// for again, it moves (in unit coordinates, per dimension):
///   v ← w v + r_x φ_x (p_n − θ) + r_g φ_g (g − θ),   θ ← θ + v        (paper's PSO update)
/// with φ_x, φ_g ~ U(0, 1) drawn per dimension and w, r_x, r_g the paper's hyper-parameters
/// (inertia, cognitive and social weights). |v_k| is clamped to max_velocity; a coordinate that
/// leaves [0, 1] is reflected (velocity reversed) or clamped (velocity zeroed). Integer
/// parameters are rounded only in the issued candidate; particles move continuously.
///
/// Asynchrony: Ask hands out particles round-robin, skipping pending ones (a particle is never
/// issued twice at once), so Ask(k) may return fewer than k candidates. Results may be told in
/// any order; each moves the particle's p_n and g at once, so later moves use the newest g.
/// Asking for the whole swarm and telling all results reproduces synchronous PSO.
///
/// Noise (Sec. III-C "Tolerance to Noisy Observations"): with reevaluation_period = P > 0, every
/// P-th issue of a particle re-evaluates its personal best instead of moving; p_n's value becomes
/// the running mean of its evaluations, which removes the optimistic bias of a lucky sample.
///
/// Thread safety: one thread at a time (the engine serialises calls); instances independent.

#include <Eigen/Core>
#include <array>
#include <map>
#include <set>
#include <vector>

#include "quadtune/common/fields.hpp"
#include "quadtune/common/random.hpp"
#include "quadtune/common/yaml.hpp"
#include "quadtune/optimizers/optimizer.hpp"

namespace quadtune::optimizers {

/// What a coordinate leaving the unit cube does.
enum class BoundHandling { kReflect, kClamp };
constexpr auto EnumNames(BoundHandling) {
  return std::array{EnumName{BoundHandling::kReflect, "reflect"},
                    EnumName{BoundHandling::kClamp, "clamp"}};
}

/// Settings of Pso.
struct PsoOptions {
  int num_particles = 20;        ///< N_p >= 1
  double inertia = 0.72;         ///< w in [0, 1.5]
  double cognitive = 1.5;        ///< r_x >= 0 (weight of p_n − θ)
  double social = 1.5;           ///< r_g >= 0 (weight of g − θ)
  double max_velocity = 0.25;    ///< velocity clamp, in (0, 1] unit-cube widths per step
  BoundHandling bound_handling = BoundHandling::kReflect;  ///< YAML: reflect | clamp
  int reevaluation_period = 0;   ///< >= 0; 0: never re-evaluate personal bests
  std::uint64_t seed = 0;        ///< explicit seed

  /// Throws ConfigError naming the key and its range.
  void Validate() const;
  /// Reads the keys of PsoFields(); unknown keys and bad values throw ConfigError naming the
  /// file and key. Absent keys keep their defaults.
  static PsoOptions FromYaml(const YamlMap& map);
};

/// The keys of a `pso:` map: reading, writing and the configuration reference.
const Fields<PsoOptions>& PsoFields();

/// Ask/tell particle swarm (minimisation). See the file comment.
class Pso final : public Optimizer {
 public:
  /// Throws ConfigError for an empty space or invalid options.
  Pso(ParameterSpace space, PsoOptions options);

  [[nodiscard]] std::optional<BestPoint> Best() const override;
  [[nodiscard]] std::size_t NumPending() const override { return pending_.size(); }
  [[nodiscard]] std::size_t NumTold() const override { return num_told_; }
  [[nodiscard]] const ParameterSpace& Space() const override { return space_; }
  [[nodiscard]] nlohmann::json SaveState() const override;
  void RestoreState(const nlohmann::json& state) override;

  /// Starts afresh for a new environment (paper Sec. IV-B: "all the intermediate variables of
  /// previous optimizations will be cleared"): new random positions and velocities, personal and
  /// global bests forgotten. Results of candidates issued before the restart are accepted by Tell
  /// and ignored. `seed_point` (original coordinates, e.g. the previous best) becomes particle 0's
  /// position; std::invalid_argument when its size is wrong or it lies outside the space.
  void Restart(const std::optional<Eigen::VectorXd>& seed_point = std::nullopt);
  /// How often the global best g has changed (position or particle), over the whole life of the
  /// optimizer; the engine forwards increments to BayesOpt::NotifyContextChanged().
  [[nodiscard]] std::uint64_t BestChanges() const { return best_changes_; }
  /// The options.
  [[nodiscard]] const PsoOptions& Options() const { return options_; }
  /// Position of particle n in unit coordinates (0 <= n < num_particles).
  [[nodiscard]] const Eigen::VectorXd& ParticlePosition(int n) const {
    return particles_.at(static_cast<std::size_t>(n)).position;
  }
  /// Velocity of particle n in unit coordinates.
  [[nodiscard]] const Eigen::VectorXd& ParticleVelocity(int n) const {
    return particles_.at(static_cast<std::size_t>(n)).velocity;
  }

 protected:
  [[nodiscard]] bool Accepts(CandidateId id) const override {
    return pending_.count(id) > 0 || stale_.count(id) > 0;
  }
  std::vector<Candidate> DoAsk(int k) override;
  void DoTell(CandidateId id, double value, double noise_variance) override;
  void DoCancel(CandidateId id) override;

 private:
  struct Particle {
    Eigen::VectorXd position;       // unit coordinates
    Eigen::VectorXd velocity;
    Eigen::VectorXd best_position;  // p_n
    double best_value = 0.0;        // running mean of p_n's evaluations
    double best_sum = 0.0;
    int best_count = 0;             // 0: no personal best yet
    CandidateId best_id = 0;
    bool evaluated = false;         // the current position has a result
    bool pending = false;
    bool reevaluating = false;      // the pending candidate re-evaluates p_n
    int issues = 0;
  };

  void InitialiseSwarm();
  void Move(Particle& p);
  void UpdateGlobalBest();

  ParameterSpace space_;
  PsoOptions options_;
  Rng rng_;
  std::vector<Particle> particles_;
  std::map<CandidateId, int> pending_;  // id → particle
  std::set<CandidateId> stale_;         // issued before Restart()
  CandidateId next_id_ = 0;
  std::size_t cursor_ = 0;
  std::size_t num_told_ = 0;
  int global_best_ = -1;                // particle holding g
  Eigen::VectorXd global_best_position_;
  std::uint64_t best_changes_ = 0;
};

}  // namespace quadtune::optimizers
