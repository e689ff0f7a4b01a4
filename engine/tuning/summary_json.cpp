#include "quadtune/engine/tuning/summary_json.hpp"

#include "quadtune/engine/store/column_json.hpp"

namespace quadtune::engine {

nlohmann::json SummaryJson(const RunSummary& s, int queries_per_eval) {
  nlohmann::json j;
  j["status"] = ToString(s.status);
  j["wall_s"] = s.wall_s;
  j["threads"] = s.threads;
  if (s.ranks > 1) j["ranks"] = s.ranks;
  j["flights"] = s.flights;
  j["resolves"] = s.resolves;
  j["worlds"] = s.worlds;
  j["trials"] = nlohmann::json::array();
  for (const auto& t : s.trials) {
    nlohmann::json tj = ToJson(t, TrialSummaryColumns(), JsonReals::kNumbers);
    tj["resolves"] = static_cast<long>(t.short_evals) * queries_per_eval;
    j["trials"].push_back(std::move(tj));
  }
  j["validation"] = nlohmann::json::array();
  for (const auto& v : s.validation) {
    j["validation"].push_back({{"method", v.method},
                               {"repeat", v.repeat},
                               {"params", v.params},
                               {"flights", v.flights},
                               {"mean_value", v.mean_value},
                               {"completed", v.completed},
                               {"collision_free", v.collision_free},
                               {"emergency_stops", v.emergency_stops}});
  }
  return j;
}

}  // namespace quadtune::engine
