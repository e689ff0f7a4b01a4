#include "eta.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

namespace quadtune::cli {

WorkPlan WorkPlan::Of(const engine::Experiment& e, int threads) {
  WorkPlan plan;
  int validated = 1;  // the defaults are always validated
  for (int repeat = 0; repeat < e.repeats; ++repeat) {
    for (const engine::Method m : e.methods) {
      PlannedTrial t;
      t.method = engine::ToString(m);
      t.repeat = repeat;
      const bool is_default = m == engine::Method::kDefault;
      t.flights = is_default ? e.budget.default_flights : e.budget.flights;
      t.recheck_flights = !is_default && e.recommend.candidates > 0 ? e.recommend.flights : 0;
      if (m == engine::Method::kBoPso) {
        t.resolves = static_cast<long>(e.budget.short_evals_per_flight) * e.budget.flights *
                     e.budget.queries_per_eval;
      }
      if (!is_default) ++validated;
      plan.trials.push_back(t);
    }
  }
  plan.validation_flights = e.validation.maps > 0 ? e.validation.maps * validated : 0;
  const int t = std::max(1, threads);
  const int batch = e.budget.flight_batch > 0 ? std::min(e.budget.flight_batch, t) : t;
  plan.validation_speedup = static_cast<double>(t) / batch;
  return plan;
}

std::string Eta::Text() const {
  return fmt::format("ETA {}{:.0f} s", lower_bound ? "> " : "", seconds);
}

void CostFit::Add(double seconds, double flights, double resolves) {
  if (!(seconds > 0.0) || (flights <= 0.0 && resolves <= 0.0)) return;
  flights = std::max(0.0, flights);
  resolves = std::max(0.0, resolves);
  ff_ += flights * flights;
  fr_ += flights * resolves;
  rr_ += resolves * resolves;
  ft_ += flights * seconds;
  rt_ += resolves * seconds;
}

std::pair<double, double> CostFit::Solve() const {
  if (ff_ <= 0.0 && rr_ <= 0.0) return {-1.0, -1.0};
  if (rr_ <= 0.0) return {ft_ / ff_, -1.0};
  if (ff_ <= 0.0) return {-1.0, rt_ / rr_};
  const double det = ff_ * rr_ - fr_ * fr_;
  if (det <= 1e-6 * ff_ * rr_) {
    // One mix only: the time per flight with its re-solves, half charged to each kind.
    const double per_flight = ft_ / ff_;
    const double resolves_per_flight = fr_ / ff_;
    return {0.5 * per_flight, 0.5 * per_flight / resolves_per_flight};
  }
  const double a = (ft_ * rr_ - rt_ * fr_) / det;
  const double b = (ff_ * rt_ - fr_ * ft_) / det;
  if (a < 0.0) return {0.0, rt_ / rr_};  // the best fit with a = 0
  if (b < 0.0) return {ft_ / ff_, 0.0};  // the best fit with b = 0
  return {a, b};
}

Eta CostFit::Cost(double flights, double resolves) const {
  const auto [a, b] = Solve();
  Eta eta;
  flights = std::max(0.0, flights);
  resolves = std::max(0.0, resolves);
  if (flights > 0.0) {
    if (a >= 0.0) {
      eta.seconds += a * flights;
    } else {
      eta.lower_bound = true;
    }
  }
  if (resolves > 0.0) {
    if (b >= 0.0) {
      eta.seconds += b * resolves;
    } else {
      eta.lower_bound = true;
    }
  }
  return eta;
}

EtaEstimator::EtaEstimator(WorkPlan plan) : plan_(std::move(plan)) {
  for (const PlannedTrial& t : plan_.trials) {
    planned_trial_flights_ += t.flights + t.recheck_flights;
    planned_resolves_ += static_cast<double>(t.resolves);
  }
}

double EtaEstimator::TrialFlightsDone() const {
  double done = 0.0;
  for (const auto& [key, flights] : flights_) {
    done += flights;
    if (key == current_) continue;  // its re-check flights come after its last report
    // A finished trial that is no longer reporting has flown its re-check flights.
    for (const PlannedTrial& t : plan_.trials) {
      if (t.method == key.first && t.repeat == key.second && flights >= t.flights) {
        done += t.recheck_flights;
        break;
      }
    }
  }
  return done;
}

double EtaEstimator::FlightsDone() const { return TrialFlightsDone() + validation_done_; }

void EtaEstimator::Observe(const engine::Progress& p) {
  if (p.method == "validation") {
    if (validation_offset_ < 0.0) {
      validation_offset_ = last_t_;
      current_ = {};  // every trial has finished, with its re-check flights
      validation_fit_.Add(p.elapsed_s, p.flights_done, 0.0);
    } else {
      validation_fit_.Add(p.elapsed_s - (last_t_ - validation_offset_),
                          p.flights_done - validation_done_, 0.0);
    }
    validation_done_ = p.flights_done;
    last_t_ = validation_offset_ + p.elapsed_s;
    return;
  }
  const std::pair<std::string, int> key{p.method, p.repeat};
  current_ = key;
  flights_[key] = p.flights_done;
  if (p.rank > 0) {
    // Another MPI rank's trial reports once, finished; its re-solves are not in short_evals.
    for (const PlannedTrial& t : plan_.trials) {
      if (t.method == p.method && t.repeat == p.repeat) remote_resolves_[key] = t.resolves;
    }
  }
  resolves_ = static_cast<double>(p.short_evals);
  for (const auto& [trial, resolves] : remote_resolves_) resolves_ += resolves;
  const double f = TrialFlightsDone();
  fit_.Add(p.elapsed_s - last_t_, f - last_f_, resolves_ - last_r_);
  last_t_ = p.elapsed_s;
  last_f_ = f;
  last_r_ = resolves_;
}

Eta EtaEstimator::Remaining() const {
  const double validation_left = plan_.validation_flights - validation_done_;
  Eta eta;
  if (validation_offset_ < 0.0) {
    eta = fit_.Cost(planned_trial_flights_ - TrialFlightsDone(), planned_resolves_ - resolves_);
  }
  if (validation_left > 0.0) {
    Eta v = validation_fit_.Cost(validation_left, 0.0);
    if (v.lower_bound) {  // no validation flight yet: a trial flight's cost, on every thread
      v = fit_.Cost(validation_left / plan_.validation_speedup, 0.0);
    }
    eta.seconds += v.seconds;
    eta.lower_bound = eta.lower_bound || v.lower_bound;
  }
  return eta;
}

}  // namespace quadtune::cli
