#pragma once
/// \file
/// A run's outcome as `OUT/summary.json` holds it, shared by `quadtune run` and the Python
/// module's `quadtune.run`.

#include <nlohmann/json.hpp>

#include "quadtune/engine/tuning/tuner.hpp"

namespace quadtune::engine {

/// status, wall_s, threads (ranks when more than one), flights, resolves, worlds, one object per
/// trial (its TrialSummaryColumns, and its re-solves: θ_s candidates × `queries_per_eval`) and
/// one per held-out validation point.
nlohmann::json SummaryJson(const RunSummary& s, int queries_per_eval);

}  // namespace quadtune::engine
