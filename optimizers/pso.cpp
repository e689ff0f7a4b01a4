#include "quadtune/optimizers/pso.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "quadtune/common/error.hpp"
#include "state_util.hpp"

namespace quadtune::optimizers {

const Fields<PsoOptions>& PsoFields() {
  static const Fields<PsoOptions> fields =
      Fields<PsoOptions>()
          .Integer("num_particles", &PsoOptions::num_particles, Range::Closed(1, 1e6),
                   "swarm size N_p")
          .Number("inertia", &PsoOptions::inertia, Range::Closed(0.0, 1.5), "inertia weight w")
          .Number("cognitive", &PsoOptions::cognitive, Range::NonNegative(),
                  "cognitive weight r_x (pull towards the particle's own best)")
          .Number("social", &PsoOptions::social, Range::NonNegative(),
                  "social weight r_g (pull towards the swarm's best)")
          .Number("max_velocity", &PsoOptions::max_velocity, Range{0.0, 1.0, true, false},
                  "velocity clamp, in unit-cube widths per step")
          .Choice("bound_handling", &PsoOptions::bound_handling,
                  "a coordinate leaving the box is reflected (velocity reversed) or clamped "
                  "(velocity zeroed)")
          .Integer("reevaluation_period", &PsoOptions::reevaluation_period, Range::Closed(0, 1e6),
                   "every P-th issue of a particle re-evaluates its personal best (noisy "
                   "objectives); 0: never")
          .Integer("seed", &PsoOptions::seed, Range::NonNegative(),
                   "seed (an experiment derives one per trial)");
  return fields;
}

void PsoOptions::Validate() const { PsoFields().Check(*this); }

PsoOptions PsoOptions::FromYaml(const YamlMap& map) { return PsoFields().Read(map); }

Pso::Pso(ParameterSpace space, PsoOptions options)
    : space_(std::move(space)), options_(options), rng_(DeriveSeed(options.seed, {0x950})) {
  if (space_.Empty()) throw ConfigError("", "parameters", "the parameter space must not be empty");
  options_.Validate();
  InitialiseSwarm();
}

void Pso::InitialiseSwarm() {
  const int d = space_.Dim();
  particles_.assign(static_cast<std::size_t>(options_.num_particles), Particle{});
  for (auto& p : particles_) {
    p.position.resize(d);
    p.velocity.resize(d);
    for (int i = 0; i < d; ++i) p.position[i] = Uniform01(rng_);
    for (int i = 0; i < d; ++i) p.velocity[i] = Uniform(rng_, -options_.max_velocity, options_.max_velocity);
    p.best_position = p.position;
  }
  global_best_ = -1;
  global_best_position_.resize(0);
  cursor_ = 0;
}

void Pso::Restart(const std::optional<Eigen::VectorXd>& seed_point) {
  if (seed_point && !space_.Contains(*seed_point)) {
    throw std::invalid_argument("Pso::Restart: seed point has the wrong size or lies outside the space");
  }
  for (const auto& [id, n] : pending_) stale_.insert(id);
  pending_.clear();
  InitialiseSwarm();
  if (seed_point) {
    particles_[0].position = space_.ToUnit(*seed_point);
    particles_[0].best_position = particles_[0].position;
  }
}

void Pso::Move(Particle& p) {
  const auto& g = global_best_position_;
  const double vmax = options_.max_velocity;
  for (Eigen::Index i = 0; i < p.position.size(); ++i) {
    const double phi_x = Uniform01(rng_);
    const double phi_g = Uniform01(rng_);
    double v = options_.inertia * p.velocity[i] + options_.cognitive * phi_x * (p.best_position[i] - p.position[i]) +
               options_.social * phi_g * (g[i] - p.position[i]);
    v = std::clamp(v, -vmax, vmax);
    double x = p.position[i] + v;
    if (x < 0.0 || x > 1.0) {
      if (options_.bound_handling == BoundHandling::kReflect) {
        x = x < 0.0 ? -x : 2.0 - x;
        v = -v;
        x = std::clamp(x, 0.0, 1.0);
      } else {
        x = std::clamp(x, 0.0, 1.0);
        v = 0.0;
      }
    }
    p.position[i] = x;
    p.velocity[i] = v;
  }
}

std::vector<Candidate> Pso::DoAsk(int k) {
  std::vector<Candidate> out;
  const std::size_t np = particles_.size();
  for (std::size_t scanned = 0; scanned < np && static_cast<int>(out.size()) < k; ++scanned) {
    const std::size_t n = cursor_;
    cursor_ = (cursor_ + 1) % np;
    Particle& p = particles_[n];
    if (p.pending) continue;
    const int period = options_.reevaluation_period;
    p.reevaluating = period > 0 && p.best_count > 0 && p.issues % period == period - 1;
    if (!p.reevaluating && p.evaluated && global_best_ >= 0) {
      Move(p);
      p.evaluated = false;
    }
    ++p.issues;
    p.pending = true;
    Candidate c;
    c.id = next_id_++;
    c.x = space_.FromUnit(p.reevaluating ? p.best_position : p.position);
    pending_.emplace(c.id, static_cast<int>(n));
    out.push_back(std::move(c));
  }
  return out;
}

void Pso::UpdateGlobalBest() {
  int best = -1;
  for (std::size_t n = 0; n < particles_.size(); ++n) {
    const Particle& p = particles_[n];
    if (p.best_count == 0) continue;
    if (best < 0 || p.best_value < particles_[static_cast<std::size_t>(best)].best_value) best = static_cast<int>(n);
  }
  if (best < 0) return;
  const Eigen::VectorXd& pos = particles_[static_cast<std::size_t>(best)].best_position;
  if (best != global_best_ || global_best_position_.size() != pos.size() || global_best_position_ != pos) {
    ++best_changes_;
    global_best_ = best;
    global_best_position_ = pos;
  }
}

void Pso::DoTell(CandidateId id, double value, double /*noise_variance*/) {
  if (stale_.erase(id) > 0) return;  // issued before Restart(): the old environment
  auto it = pending_.find(id);
  Particle& p = particles_[static_cast<std::size_t>(it->second)];
  pending_.erase(it);
  p.pending = false;
  ++num_told_;
  if (p.reevaluating) {
    p.reevaluating = false;
    p.best_sum += value;
    ++p.best_count;
    p.best_value = p.best_sum / p.best_count;
  } else {
    p.evaluated = true;
    if (p.best_count == 0 || value < p.best_value) {
      p.best_position = p.position;
      p.best_sum = value;
      p.best_count = 1;
      p.best_value = value;
      p.best_id = id;
    }
  }
  UpdateGlobalBest();
}

void Pso::DoCancel(CandidateId id) {
  if (stale_.erase(id) > 0) return;
  auto it = pending_.find(id);
  Particle& p = particles_[static_cast<std::size_t>(it->second)];
  pending_.erase(it);
  p.pending = false;
  p.reevaluating = false;  // the (moved) position is issued again next time
}

std::optional<BestPoint> Pso::Best() const {
  if (global_best_ < 0) return std::nullopt;
  const Particle& p = particles_[static_cast<std::size_t>(global_best_)];
  BestPoint b;
  b.x = space_.FromUnit(p.best_position);
  b.value = p.best_value;
  b.observed = p.best_value;
  b.id = p.best_id;
  return b;
}

nlohmann::json Pso::SaveState() const {
  using detail::ToJson;
  nlohmann::json j;
  j["method"] = "pso";
  j["dim"] = space_.Dim();
  j["num_particles"] = options_.num_particles;
  j["rng"] = detail::RngToString(rng_);
  j["next_id"] = next_id_;
  j["cursor"] = cursor_;
  j["num_told"] = num_told_;
  j["global_best"] = global_best_;
  j["global_best_position"] = ToJson(global_best_position_);
  j["best_changes"] = best_changes_;
  j["stale"] = stale_;
  j["pending"] = nlohmann::json::array();
  for (const auto& [id, n] : pending_) j["pending"].push_back({id, n});
  j["particles"] = nlohmann::json::array();
  for (const auto& p : particles_) {
    j["particles"].push_back({{"position", ToJson(p.position)},
                              {"velocity", ToJson(p.velocity)},
                              {"best_position", ToJson(p.best_position)},
                              {"best_value", p.best_value},
                              {"best_sum", p.best_sum},
                              {"best_count", p.best_count},
                              {"best_id", p.best_id},
                              {"evaluated", p.evaluated},
                              {"pending", p.pending},
                              {"reevaluating", p.reevaluating},
                              {"issues", p.issues}});
  }
  return j;
}

void Pso::RestoreState(const nlohmann::json& state) {
  detail::CheckHeader(state, "pso", space_.Dim());
  const int d = space_.Dim();
  detail::WithJsonErrors([&] {
    if (state.at("num_particles").get<int>() != options_.num_particles ||
        state.at("particles").size() != static_cast<std::size_t>(options_.num_particles)) {
      throw std::invalid_argument("Pso::RestoreState: saved with a different number of particles");
    }
    std::vector<Particle> particles;
    for (const auto& j : state.at("particles")) {
      Particle p;
      p.position = detail::VectorFromJson(j.at("position"), d);
      p.velocity = detail::VectorFromJson(j.at("velocity"), d);
      p.best_position = detail::VectorFromJson(j.at("best_position"), d);
      p.best_value = j.at("best_value").get<double>();
      p.best_sum = j.at("best_sum").get<double>();
      p.best_count = j.at("best_count").get<int>();
      p.best_id = j.at("best_id").get<CandidateId>();
      p.evaluated = j.at("evaluated").get<bool>();
      p.pending = j.at("pending").get<bool>();
      p.reevaluating = j.at("reevaluating").get<bool>();
      p.issues = j.at("issues").get<int>();
      particles.push_back(std::move(p));
    }
    std::map<CandidateId, int> pending;
    for (const auto& e : state.at("pending")) {
      const int n = e.at(1).get<int>();
      if (n < 0 || n >= options_.num_particles) throw std::invalid_argument("Pso::RestoreState: bad particle index");
      pending.emplace(e.at(0).get<CandidateId>(), n);
    }
    Rng rng = detail::RngFromString(state.at("rng").get<std::string>());
    const auto next_id = state.at("next_id").get<CandidateId>();
    const auto cursor = state.at("cursor").get<std::size_t>();
    const auto num_told = state.at("num_told").get<std::size_t>();
    const int global_best = state.at("global_best").get<int>();
    Eigen::VectorXd gpos = detail::VectorFromJson(state.at("global_best_position"));
    const auto best_changes = state.at("best_changes").get<std::uint64_t>();
    auto stale = state.at("stale").get<std::set<CandidateId>>();
    if (cursor >= particles.size() || global_best >= options_.num_particles) {
      throw std::invalid_argument("Pso::RestoreState: inconsistent state");
    }
    particles_ = std::move(particles);
    pending_ = std::move(pending);
    rng_ = rng;
    next_id_ = next_id;
    cursor_ = cursor;
    num_told_ = num_told;
    global_best_ = global_best;
    global_best_position_ = std::move(gpos);
    best_changes_ = best_changes;
    stale_ = std::move(stale);
  });
}

}  // namespace quadtune::optimizers
