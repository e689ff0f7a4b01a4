#include "quadtune/optimizers/optimizer.hpp"

#include <cmath>
#include <set>
#include <stdexcept>
#include <string>

namespace quadtune::optimizers {
namespace {

void CheckResult(double value, double noise_variance) {
  if (!std::isfinite(value)) {
    throw std::invalid_argument("Optimizer::Tell: objective value must be finite, got " +
                                std::to_string(value));
  }
  if (!std::isnan(noise_variance) && !(noise_variance >= 0.0 && std::isfinite(noise_variance))) {
    throw std::invalid_argument("Optimizer::Tell: noise variance must be finite and >= 0, got " +
                                std::to_string(noise_variance));
  }
}

}  // namespace

std::vector<Candidate> Optimizer::Ask(int k) {
  if (k < 1) throw std::invalid_argument("Optimizer::Ask: k must be >= 1, got " + std::to_string(k));
  return DoAsk(k);
}

void Optimizer::Tell(CandidateId id, double value, std::optional<double> noise_variance) {
  const double nv = noise_variance ? *noise_variance : std::numeric_limits<double>::quiet_NaN();
  if (noise_variance && std::isnan(*noise_variance)) {
    throw std::invalid_argument("Optimizer::Tell: noise variance is NaN");
  }
  CheckResult(value, nv);
  if (!Accepts(id)) {
    throw std::invalid_argument("Optimizer::Tell: unknown candidate id " + std::to_string(id) +
                                " (never issued, already told or cancelled)");
  }
  DoTell(id, value, nv);
}

void Optimizer::Tell(const std::vector<CandidateId>& ids, const std::vector<double>& values,
                     const std::vector<double>& noise_variances) {
  if (ids.size() != values.size()) {
    throw std::invalid_argument("Optimizer::Tell: " + std::to_string(ids.size()) + " ids but " +
                                std::to_string(values.size()) + " values");
  }
  if (!noise_variances.empty() && noise_variances.size() != values.size()) {
    throw std::invalid_argument("Optimizer::Tell: " + std::to_string(values.size()) + " values but " +
                                std::to_string(noise_variances.size()) + " noise variances");
  }
  std::set<CandidateId> seen;
  for (std::size_t i = 0; i < ids.size(); ++i) {
    const double nv = noise_variances.empty() ? std::numeric_limits<double>::quiet_NaN() : noise_variances[i];
    if (!noise_variances.empty() && std::isnan(nv)) {
      throw std::invalid_argument("Optimizer::Tell: noise variance is NaN");
    }
    CheckResult(values[i], nv);
    if (!seen.insert(ids[i]).second) {
      throw std::invalid_argument("Optimizer::Tell: candidate id " + std::to_string(ids[i]) +
                                  " appears twice");
    }
    if (!Accepts(ids[i])) {
      throw std::invalid_argument("Optimizer::Tell: unknown candidate id " + std::to_string(ids[i]) +
                                  " (never issued, already told or cancelled)");
    }
  }
  for (std::size_t i = 0; i < ids.size(); ++i) {
    DoTell(ids[i], values[i],
           noise_variances.empty() ? std::numeric_limits<double>::quiet_NaN() : noise_variances[i]);
  }
}

void Optimizer::Tell(const std::vector<Candidate>& candidates, const std::vector<double>& values,
                     const std::vector<double>& noise_variances) {
  std::vector<CandidateId> ids;
  ids.reserve(candidates.size());
  for (const auto& c : candidates) ids.push_back(c.id);
  Tell(ids, values, noise_variances);
}

void Optimizer::Cancel(CandidateId id) {
  if (!Accepts(id)) {
    throw std::invalid_argument("Optimizer::Cancel: unknown candidate id " + std::to_string(id));
  }
  DoCancel(id);
}

}  // namespace quadtune::optimizers
