#include "quadtune/optimizers/random_search.hpp"

#include "quadtune/common/error.hpp"
#include "state_util.hpp"

namespace quadtune::optimizers {

RandomSearch::RandomSearch(ParameterSpace space, RandomSearchOptions options)
    : space_(std::move(space)), rng_(DeriveSeed(options.seed, {0x125})) {
  if (space_.Empty()) throw ConfigError("", "parameters", "the parameter space must not be empty");
  options.Validate();
}

std::vector<Candidate> RandomSearch::DoAsk(int k) {
  std::vector<Candidate> out;
  out.reserve(static_cast<std::size_t>(k));
  Eigen::VectorXd u(space_.Dim());
  for (int c = 0; c < k; ++c) {
    for (int i = 0; i < space_.Dim(); ++i) u[i] = Uniform01(rng_);
    Candidate cand;
    cand.id = next_id_++;
    cand.x = space_.FromUnit(u);
    pending_.emplace(cand.id, cand.x);
    out.push_back(std::move(cand));
  }
  return out;
}

void RandomSearch::DoTell(CandidateId id, double value, double /*noise_variance*/) {
  auto it = pending_.find(id);
  ++num_told_;
  if (!best_ || value < best_->value) {
    BestPoint b;
    b.x = it->second;
    b.value = value;
    b.observed = value;
    b.id = id;
    best_ = std::move(b);
  }
  pending_.erase(it);
}

nlohmann::json RandomSearch::SaveState() const {
  nlohmann::json j;
  j["method"] = "random_search";
  j["dim"] = space_.Dim();
  j["rng"] = detail::RngToString(rng_);
  j["next_id"] = next_id_;
  j["num_told"] = num_told_;
  j["pending"] = nlohmann::json::array();
  for (const auto& [id, x] : pending_) j["pending"].push_back({{"id", id}, {"x", detail::ToJson(x)}});
  if (best_) {
    j["best"] = {{"x", detail::ToJson(best_->x)}, {"value", best_->value}, {"id", best_->id}};
  }
  return j;
}

void RandomSearch::RestoreState(const nlohmann::json& state) {
  detail::CheckHeader(state, "random_search", space_.Dim());
  detail::WithJsonErrors([&] {
    Rng rng = detail::RngFromString(state.at("rng").get<std::string>());
    std::map<CandidateId, Eigen::VectorXd> pending;
    for (const auto& p : state.at("pending")) {
      pending.emplace(p.at("id").get<CandidateId>(), detail::VectorFromJson(p.at("x"), space_.Dim()));
    }
    std::optional<BestPoint> best;
    if (state.contains("best")) {
      BestPoint b;
      b.x = detail::VectorFromJson(state.at("best").at("x"), space_.Dim());
      b.value = state.at("best").at("value").get<double>();
      b.observed = b.value;
      b.id = state.at("best").at("id").get<CandidateId>();
      best = std::move(b);
    }
    const auto next_id = state.at("next_id").get<CandidateId>();
    const auto num_told = state.at("num_told").get<std::size_t>();
    rng_ = rng;
    pending_ = std::move(pending);
    best_ = std::move(best);
    next_id_ = next_id;
    num_told_ = num_told;
  });
}

}  // namespace quadtune::optimizers
