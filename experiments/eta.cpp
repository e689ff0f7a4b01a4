#include "eta.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

namespace quadtune::cli {

int WorkPlan::AddTrials(const engine::Experiment& e, int run) {
  int tuned = 0;
  for (int repeat = 0; repeat < e.repeats; ++repeat) {
    for (const engine::Method m : e.methods) {
      PlannedTrial t;
      t.method = quadtune::ToString(m);
      t.repeat = repeat;
      t.run = run;
      const bool is_default = m == engine::Method::kDefault;
      t.flights = is_default ? e.budget.default_flights : e.budget.flights;
      t.recheck_flights = !is_default && e.recommend.candidates > 0 ? e.recommend.flights : 0;
      if (m == engine::Method::kBoPso) {
        t.resolves = static_cast<long>(e.budget.short_evals_per_flight) * e.budget.flights *
                     e.budget.queries_per_eval;
      }
      if (!is_default) ++tuned;
      trials.push_back(t);
    }
  }
  return tuned;
}

void WorkPlan::AddDrawing(const engine::Experiment& e, int threads, int stores) {
  drawing.on = true;
  drawing.replay_flights = std::min(3, stores * static_cast<int>(e.methods.size()));
  const int t = std::max(1, threads);
  drawing.flights_at_once = e.budget.flight_batch > 0 ? std::min(e.budget.flight_batch, t) : t;
}

namespace {

/// Validation flies on every thread; a trial round flies flight_batch flights at once.
double ValidationSpeedup(const engine::Experiment& e, int threads) {
  const int t = std::max(1, threads);
  const int batch = e.budget.flight_batch > 0 ? std::min(e.budget.flight_batch, t) : t;
  return static_cast<double>(t) / batch;
}

}  // namespace

WorkPlan WorkPlan::Of(const engine::Experiment& e, int threads) {
  WorkPlan plan;
  const int tuned = plan.AddTrials(e, 0);
  if (e.validation.maps > 0) {
    // Each tuned trial's recommended point and the defaults.
    plan.validations.push_back({0, e.validation.maps * (tuned + 1), ValidationSpeedup(e, threads)});
  }
  return plan;
}

WorkPlan WorkPlan::Of(const engine::Study& s, int threads) {
  WorkPlan plan;
  const int stages = static_cast<int>(s.stages.size());
  for (std::size_t p = 0; p < s.labels.size(); ++p) {
    int tuned = 0;
    for (int k = 0; k < stages; ++k) {
      const engine::Experiment e = s.Build(p, static_cast<std::size_t>(k));
      tuned += plan.AddTrials(e, static_cast<int>(p) * stages + k);
      if (k + 1 == stages && s.validation_flights > 0) {
        const int t = threads > 0 ? threads : e.threads;
        plan.validations.push_back({static_cast<int>(p) * stages + k,
                                    s.validation_flights * (tuned + 1), ValidationSpeedup(e, t)});
      }
    }
  }
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

EtaEstimator::EtaEstimator(WorkPlan plan)
    : plan_(std::move(plan)),
      flights_(plan_.trials.size(), 0),
      resolves_(plan_.trials.size(), 0.0),
      validated_(plan_.validations.size(), 0.0) {}

int EtaEstimator::TrialIndex(int run, const std::string& method, int repeat) const {
  for (std::size_t i = 0; i < plan_.trials.size(); ++i) {
    const PlannedTrial& t = plan_.trials[i];
    if (t.run == run && t.method == method && t.repeat == repeat) return static_cast<int>(i);
  }
  return -1;
}

bool EtaEstimator::RechecksDone(std::size_t i) const {
  return static_cast<int>(i) != current_ && flights_[i] >= plan_.trials[i].flights &&
         flights_[i] > 0;
}

double EtaEstimator::FlightsDone() const {
  if (finished_) return FlightsPlanned();
  double done = 0.0;
  for (std::size_t i = 0; i < flights_.size(); ++i) {
    done += flights_[i];
    if (RechecksDone(i)) done += plan_.trials[i].recheck_flights;
  }
  for (const double v : validated_) done += v;
  return done;
}

double EtaEstimator::FlightsPlanned() const {
  double planned = 0.0;
  for (const PlannedTrial& t : plan_.trials) planned += t.flights + t.recheck_flights;
  for (const PlannedValidation& v : plan_.validations) planned += v.flights;
  return planned;
}

double EtaEstimator::ResolvesDone() const {
  double done = 0.0;
  for (const double r : resolves_) done += r;
  return done;
}

const CostFit* EtaEstimator::MethodFit(const std::string& method) const {
  const auto it = method_fits_.find(method);
  return it == method_fits_.end() ? nullptr : &it->second;
}

void EtaEstimator::ObserveValidation(const engine::Progress& p, double now_s, int run) {
  std::size_t v = 0;
  while (v < plan_.validations.size() && plan_.validations[v].run != run) ++v;
  if (v == plan_.validations.size()) return;
  // On --resume the stored validation flights are replayed: the report's total is the rest.
  if (p.flights_total > 0 && p.flights_total < plan_.validations[v].flights) {
    plan_.validations[v].flights = p.flights_total;
  }
  const double flights = p.flights_done - validated_[v];
  if (flights <= 0.0) return;  // no work finished: the time counts on
  const double seconds = now_s - last_t_;
  last_t_ = now_s;
  if (validated_[v] > 0.0) {
    validation_fit_.Add(seconds, flights, 0.0);
  } else {
    // The first validation flights, after the last trial's tail.
    const std::string previous =
        current_ >= 0 ? plan_.trials[static_cast<std::size_t>(current_)].method : std::string();
    handovers_.push_back({previous, seconds, "validation", flights, 0.0, v});
  }
  current_ = -1;  // every trial of the run has finished, with its re-check flights
  validated_[v] = p.flights_done;
}

void EtaEstimator::Observe(const engine::Progress& p, double now_s, int run) {
  if (p.method == "validation") {
    ObserveValidation(p, now_s, run);
    return;
  }
  const int i = TrialIndex(run, p.method, p.repeat);
  if (i < 0) return;
  const std::size_t u = static_cast<std::size_t>(i);
  const double flights_before = FlightsDone();
  const double resolves_before = ResolvesDone();
  // A new trial after a finished one (or the job's first report): the increment holds the
  // previous trial's tail (re-check flights) or the job's start, then this trial's first round.
  std::string previous;
  bool handover = i != current_;
  if (handover && current_ >= 0) {
    const std::size_t c = static_cast<std::size_t>(current_);
    previous = plan_.trials[c].method;
    handover = flights_[c] >= plan_.trials[c].flights;
  }
  const int trial_flights_before = flights_[u];
  const double trial_resolves_before = resolves_[u];
  flights_[u] = p.flights_done;
  if (p.rank > 0) {
    // Another MPI rank's trial reports once, finished; its re-solves are not in short_evals.
    distributed_ = true;
    resolves_[u] = static_cast<double>(plan_.trials[u].resolves);
  } else {
    // This rank's counter belongs to the trial running here.
    const long counter = p.short_evals;
    const auto it = run_resolves_.find(run);
    const long previous_count = it == run_resolves_.end() ? 0 : it->second;
    resolves_[u] += static_cast<double>(std::max(0L, counter - previous_count));
    run_resolves_[run] = counter;
    current_ = i;
  }
  const double flights_done = FlightsDone() - flights_before;
  const double resolves_done = ResolvesDone() - resolves_before;
  if (flights_done <= 0.0 && resolves_done <= 0.0) return;  // no work finished: the time counts on
  const double seconds = now_s - last_t_;
  last_t_ = now_s;
  pooled_.Add(seconds, flights_done, resolves_done);
  if (distributed_) return;
  const double own_flights = flights_[u] - trial_flights_before;
  const double own_resolves = resolves_[u] - trial_resolves_before;
  if (handover) {
    handovers_.push_back({previous, seconds, p.method, own_flights, own_resolves, 0});
  } else {
    method_fits_[p.method].Add(seconds, own_flights, own_resolves);
  }
}

Eta EtaEstimator::ValidationCost(std::size_t v, double flights) const {
  Eta eta = validation_fit_.Cost(flights, 0.0);
  if (eta.lower_bound) {  // no validation increment yet: a trial flight's cost, on every thread
    eta = pooled_.Cost(flights / plan_.validations[v].speedup, 0.0);
  }
  return eta;
}

double EtaEstimator::Tail(const std::string& method) const {
  double sum = 0.0;
  int n = 0;
  for (const Handover& h : handovers_) {
    if (h.method != method || method.empty()) continue;
    const Eta next = h.next == "validation" ? ValidationCost(h.validation, h.flights)
                                            : TrialCost(h.next, h.flights, h.resolves);
    sum += std::max(0.0, h.seconds - next.seconds);
    ++n;
  }
  return n > 0 ? sum / n : -1.0;
}

Eta EtaEstimator::TrialCost(const std::string& method, double flights, double resolves) const {
  if (!distributed_) {
    if (const CostFit* fit = MethodFit(method)) {
      const Eta own = fit->Cost(flights, resolves);
      if (!own.lower_bound) return own;
    }
  }
  return pooled_.Cost(flights, resolves);
}

void EtaEstimator::Finished() { finished_ = true; }

Eta EtaEstimator::DrawingCost() const {
  const PlannedDrawing& d = plan_.drawing;
  if (!d.on) return {};
  Eta eta = pooled_.Cost(d.replay_flights * d.flights_at_once, 0.0);
  eta.seconds += kScriptSeconds;
  return eta;
}

Eta EtaEstimator::Remaining() const {
  Eta eta = DrawingCost();
  if (finished_) return eta;
  const auto add = [&eta](const Eta& part) {
    eta.seconds += part.seconds;
    eta.lower_bound = eta.lower_bound || part.lower_bound;
  };
  for (std::size_t i = 0; i < plan_.trials.size(); ++i) {
    const PlannedTrial& t = plan_.trials[i];
    const double flights_left = std::max(0, t.flights - flights_[i]);
    // A trial's rounds re-solve before they report: with its flights, its re-solves are done
    // (on --resume, replayed re-solves are not counted).
    const double resolves_left =
        flights_left > 0.0 ? std::max(0.0, static_cast<double>(t.resolves) - resolves_[i]) : 0.0;
    if (flights_left > 0.0 || resolves_left > 0.0) {
      add(TrialCost(t.method, flights_left, resolves_left));
    }
    if (RechecksDone(i)) continue;
    // Its tail: as long as the method's measured tails, else its fewest re-check flights.
    const double tail = distributed_ ? -1.0 : Tail(t.method);
    if (tail >= 0.0) {
      eta.seconds += tail;
    } else if (t.recheck_flights > 0) {
      add(pooled_.Cost(t.recheck_flights, 0.0));
    }
  }
  for (std::size_t v = 0; v < plan_.validations.size(); ++v) {
    const double left = std::max(0.0, plan_.validations[v].flights - validated_[v]);
    if (left > 0.0) add(ValidationCost(v, left));
  }
  return eta;
}

}  // namespace quadtune::cli
