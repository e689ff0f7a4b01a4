#include "quadtune/engine/tuning/tuner.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <deque>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <tuple>
#include <utility>

#include "quadtune/common/random.hpp"
#include "quadtune/engine/store/result_store.hpp"
#include "quadtune/engine/tuning/scheduler.hpp"
#include "quadtune/optimizers/challenger_model.hpp"
#include "quadtune/optimizers/racing.hpp"
#include "quadtune/optimizers/random_search.hpp"

namespace quadtune::engine {
namespace {

using Clock = std::chrono::steady_clock;

double Now() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

std::string ToJson(const std::map<std::string, double>& values) {
  nlohmann::json j = nlohmann::json::object();
  for (const auto& [k, v] : values) j[k] = v;
  return j.dump();
}

ParamValues Merge(ParamValues a, const ParamValues& b) {
  for (const auto& [k, v] : b) a[k] = v;
  return a;
}

/// The result of one evaluation, computed or replayed.
struct Outcome {
  ParamValues params;
  ObjectiveValue objective;
  EvalStatus status = EvalStatus::kOk;
  EvalState state = EvalState::kOk;
  std::string message;
  double wall_s = 0.0;
  double started = 0.0;
  double finished = 0.0;
  std::vector<Opaque> queries;  // flights that record
  bool replayed = false;
  int query_count = 0;
  std::uint64_t map_seed = 0;     // flights
  std::uint64_t flight_seed = 0;  // flights
};

/// State shared by every trial of a run.
struct Context {
  const Experiment& e;
  const RunOptions& options;
  Scheduler& scheduler;
  WorldPool& pool;
  EvaluationStore* store;
  int threads;
  Clock::time_point start;
  std::atomic<long> flights{0};
  std::atomic<long> resolves{0};
  std::atomic<int> trials_done{0};
  std::atomic<int> trials_total{0};
  std::mutex maps_mutex{};
  std::map<std::uint64_t, Opaque> maps{};  // prepared maps by seed (shared by every method)

  /// The map of `seed`, prepared on first use (deterministic: two threads preparing one seed
  /// make the same map). Throws what PrepareMap throws.
  Opaque Map(std::uint64_t seed) {
    {
      std::lock_guard lock(maps_mutex);
      if (auto it = maps.find(seed); it != maps.end()) return it->second;
    }
    Opaque map = e.planner.PrepareMap(seed);
    std::lock_guard lock(maps_mutex);
    return maps.emplace(seed, std::move(map)).first->second;
  }

  [[nodiscard]] bool CancelRequested() const {
    return options.cancel != nullptr && options.cancel->load();
  }
};

/// Runs one flight into `out` (called inside a scheduler job). Never throws.
void FlyInto(Context& c, std::uint64_t map_seed, const ParamValues& params, std::uint64_t seed,
             bool record, std::function<void(double, ParamValues&)> provider, Outcome& out) {
  out.params = params;
  out.map_seed = map_seed;
  out.flight_seed = seed;
  out.started = Now();
  const auto t0 = Clock::now();
  FlightRequest req;
  req.params = params;
  req.seed = seed;
  req.short_params_provider = std::move(provider);
  if (record) req.on_query = [&out](const Opaque& q) { out.queries.push_back(q); };
  if (c.options.cancel != nullptr) {
    const std::atomic<bool>* cancel = c.options.cancel;
    req.cancelled = [cancel] { return cancel->load(); };
  }
  FlightRecord rec;
  bool threw = false;
  try {
    req.map = c.Map(map_seed);
  } catch (const std::exception& ex) {  // a layout that cannot be generated for this seed
    rec.status = EvalStatus::kFailed;
    rec.message = std::string("map: ") + ex.what();
    threw = true;
  }
  if (!threw) rec = FlyOnPool(c.e.planner, c.pool, req, &threw);
  if (threw) out.queries.clear();
  out.objective = LongTermObjective(rec, c.e.objective);
  out.status = rec.status;
  out.state = StateOf(rec);
  out.message = rec.message;
  out.query_count = static_cast<int>(out.queries.size());
  out.wall_s = std::chrono::duration<double>(Clock::now() - t0).count();
  out.finished = Now();
  c.flights.fetch_add(1);
}

/// Planner defaults, overridden by the space's explicit defaults.
ParamValues DefaultsOf(const Experiment& e) { return e.Defaults(); }

ParamValues Pick(const ParamValues& all, const std::vector<std::string>& names) {
  ParamValues out;
  for (const auto& n : names) out[n] = all.at(n);
  return out;
}

/// Refinement (experiment `start:`, paper Sec. III-E): with moving bounds on, BO begins inside
/// start ± half_width (unit-cube widths, clipped to the space); the bounds then move with the best.
void BoundAroundStart(const Experiment& e, optimizers::BayesOpt& bo) {
  if (!e.start || !e.bo.moving_bounds.enabled) return;
  const auto& space = bo.Space();
  ParamValues point = DefaultsOf(e);
  for (const auto& [name, value] : *e.start) point[name] = value;
  Eigen::VectorXd x(space.Dim());
  const auto names = space.Names();
  for (std::size_t i = 0; i < names.size(); ++i) x[static_cast<Eigen::Index>(i)] = point.at(names[i]);
  const Eigen::VectorXd u = space.ToUnit(x);
  const double r = e.bo.moving_bounds.half_width;
  const Eigen::VectorXd lo = (u.array() - r).max(0.0).matrix();
  const Eigen::VectorXd hi = (u.array() + r).min(1.0).matrix();
  // An integer parameter's unit interval spans half a cell beyond its bounds (FromUnitContinuous
  // maps 0 to lower − 0.5): clamp to the bounds, which SetBounds widens by that half cell again.
  Eigen::VectorXd x_lo = space.FromUnitContinuous(lo);
  Eigen::VectorXd x_hi = space.FromUnitContinuous(hi);
  for (int i = 0; i < space.Dim(); ++i) {
    const auto& p = space.At(i);
    x_lo[i] = std::clamp(x_lo[i], p.lower, p.upper);
    x_hi[i] = std::clamp(x_hi[i], p.lower, p.upper);
  }
  bo.SetBounds(x_lo, x_hi);
}

/// The trial's evaluations in the results store: the stored ones are replayed (resume), the new
/// ones stored. Without a store nothing is replayed and nothing stored.
class EvaluationLog {
 public:
  EvaluationLog(Context& c, Method method, int repeat) : c_(c), method_(method) {
    if (c.store != nullptr) {
      trial_id_ = c.store->Trial(ToString(method), repeat, c.e.FlightMapSeed(repeat, 0));
    }
  }

  [[nodiscard]] std::int64_t TrialId() const { return trial_id_; }

  /// The stored evaluation (kind, iteration, index) replayed for the parameters `asked`, if one
  /// is stored. In reproducible mode the stored parameters must be the ones asked now (else
  /// ConfigError: the stored run is not a prefix of this one).
  [[nodiscard]] std::optional<Outcome> Replayed(EvalKind kind, int iteration, int index,
                                                const ParamValues& asked) const {
    const EvaluationRow* row =
        c_.store != nullptr ? c_.store->Find(trial_id_, kind, iteration, index) : nullptr;
    if (row == nullptr) return std::nullopt;
    return Replay(*row, asked);
  }

  /// Stores a new evaluation (a replayed one is stored already).
  void Store(EvalKind kind, int iteration, int index, const Outcome& o) const {
    if (c_.store == nullptr || o.replayed) return;
    EvaluationRow r;
    r.trial_id = trial_id_;
    r.method = method_;
    r.kind = kind;
    r.iteration = iteration;
    r.index = index;
    r.params = ToJson(o.params);
    r.terms = ToJson(o.objective.terms);
    r.value = o.objective.value;
    r.status = o.status;
    r.state = o.state;
    r.message = o.message;
    r.wall_s = o.wall_s;
    r.started = o.started;
    r.finished = o.finished;
    r.map_seed = o.map_seed;
    r.flight_seed = o.flight_seed;
    c_.store->Insert(r);
  }

  /// Marks the trial finished (done, or cancelled) with its best point.
  void Finish(bool done, const ParamValues& best, double best_value) const {
    if (c_.store == nullptr) return;
    c_.store->FinishTrial(trial_id_, done ? TrialStatus::kDone : TrialStatus::kCancelled,
                          ToJson(best), best_value);
  }

 private:
  Outcome Replay(const EvaluationRow& row, const ParamValues& asked) const {
    if (c_.e.mode == TimingMode::kReproducible && row.params != ToJson(asked)) {
      throw ConfigError(c_.options.store_path, "--resume",
                        "stored evaluation (" + std::string(ToString(row.kind)) + ", iteration " +
                            std::to_string(row.iteration) + ", index " + std::to_string(row.index) +
                            ") has parameters " + row.params + " but the run asks " +
                            ToJson(asked) + "; the stored run is not a prefix of this one");
    }
    Outcome o;
    o.params = asked;
    o.objective.value = row.value;
    const auto terms = nlohmann::json::parse(row.terms);
    for (auto it = terms.begin(); it != terms.end(); ++it) {
      o.objective.terms[it.key()] = it.value().get<double>();
    }
    o.status = row.status;
    o.state = row.state;
    o.message = row.message;
    o.wall_s = row.wall_s;
    o.started = row.started;
    o.finished = row.finished;
    o.replayed = true;
    o.map_seed = row.map_seed;
    o.flight_seed = row.flight_seed;
    auto q = o.objective.terms.find("queries");
    o.query_count = q == o.objective.terms.end() ? 0 : static_cast<int>(q->second);
    return o;
  }

  Context& c_;
  Method method_;
  std::int64_t trial_id_ = 0;
};

/// The optimiser of a single-loop method over the whole space (random, pso, bo; none for the
/// defaults), seeded from the trial's seed. *bo: the optimiser as BayesOpt for bo, else null.
std::unique_ptr<optimizers::Optimizer> MakeSingleOptimizer(const Experiment& e, Method method,
                                                           std::uint64_t seed,
                                                           optimizers::BayesOpt** bo) {
  *bo = nullptr;
  switch (method) {
    case Method::kRandom:
      return std::make_unique<optimizers::RandomSearch>(
          e.space, optimizers::RandomSearchOptions{DeriveSeed(seed, {1})});
    case Method::kPso: {
      auto o = e.pso;
      o.seed = DeriveSeed(seed, {1});
      return std::make_unique<optimizers::Pso>(e.space, o);
    }
    case Method::kBo: {
      auto o = e.bo;
      o.seed = DeriveSeed(seed, {1});
      auto made = std::make_unique<optimizers::BayesOpt>(e.space, o);
      BoundAroundStart(e, *made);
      *bo = made.get();
      return made;
    }
    default:
      return nullptr;
  }
}

/// bo_pso's two optimisers: PSO over θ_s, BO over θ_l, each on its subspace.
struct BoPsoOptimizers {
  optimizers::ParameterSpace short_space, long_space;
  std::unique_ptr<optimizers::Pso> pso;
  std::unique_ptr<optimizers::BayesOpt> bo;
};

BoPsoOptimizers MakeBoPsoOptimizers(const Experiment& e, std::uint64_t seed) {
  BoPsoOptimizers o;
  o.short_space = e.space.Subspace(e.short_names);
  o.long_space = e.space.Subspace(e.long_names);
  auto po = e.pso;
  po.seed = DeriveSeed(seed, {1});
  o.pso = std::make_unique<optimizers::Pso>(o.short_space, po);
  auto bo = e.bo;
  bo.seed = DeriveSeed(seed, {2});
  o.bo = std::make_unique<optimizers::BayesOpt>(o.long_space, bo);
  BoundAroundStart(e, *o.bo);
  return o;
}

/// bo_pso's planning queries: the recording flights, oldest first, trimmed so that dropping the
/// oldest would leave fewer than `window` queries. A replayed flight's queries exist only after
/// Materialise flies it again.
class QueryBuffer {
 public:
  explicit QueryBuffer(int window) : window_(window) {}

  [[nodiscard]] std::size_t Size() const { return entries_.size(); }

  /// Queries of the first `entries` flights.
  [[nodiscard]] int Total(std::size_t entries) const {
    int n = 0;
    for (std::size_t i = 0; i < entries; ++i) n += entries_[i].count;
    return n;
  }

  /// Adds a flight's queries (nothing when it recorded none), then trims.
  void Add(const Outcome& o) {
    Entry b;
    b.params = o.params;
    b.seed = o.flight_seed;
    b.map_seed = o.map_seed;
    if (o.replayed) {
      b.pending = o.query_count > 0;
      b.count = o.query_count;
    } else {
      b.queries = o.queries;
      b.count = static_cast<int>(o.queries.size());
    }
    if (b.count > 0) entries_.push_back(std::move(b));
    while (!entries_.empty() && Total(entries_.size()) - entries_.front().count >= window_) {
      entries_.pop_front();
    }
  }

  /// Re-flies the replayed flights among the first `entries` so that their queries exist
  /// (deterministic in reproducible mode).
  void Materialise(Context& c, std::size_t entries) {
    TaskGroup group;
    std::vector<Outcome> out(entries);
    bool any = false;
    for (std::size_t i = 0; i < entries; ++i) {
      if (!entries_[i].pending) continue;
      any = true;
      Outcome* slot = &out[i];
      const ParamValues params = entries_[i].params;
      const std::uint64_t seed = entries_[i].seed;
      const std::uint64_t map_seed = entries_[i].map_seed;
      c.scheduler.Submit(group, Priority::kFlight, [&c, slot, map_seed, params, seed] {
        FlyInto(c, map_seed, params, seed, true, {}, *slot);
      });
    }
    if (!any) return;
    c.scheduler.Wait(group);
    for (std::size_t i = 0; i < entries; ++i) {
      if (!entries_[i].pending) continue;
      entries_[i].queries = std::move(out[i].queries);
      entries_[i].count = static_cast<int>(entries_[i].queries.size());
      entries_[i].pending = false;
    }
  }

  /// `count` queries drawn with replacement by `rng` from buffer positions
  /// [window_begin, total).
  std::vector<Opaque> Draw(Rng& rng, int count, int window_begin, int total) const {
    std::vector<Opaque> subset;
    for (int j = 0; j < count; ++j) {
      int pick = static_cast<int>(UniformInt(rng, window_begin, total - 1));
      std::size_t entry = 0;
      while (pick >= entries_[entry].count) {
        pick -= entries_[entry].count;
        ++entry;
      }
      subset.push_back(entries_[entry].queries[static_cast<std::size_t>(pick)]);
    }
    return subset;
  }

 private:
  struct Entry {
    std::vector<Opaque> queries;
    int count = 0;
    bool pending = false;  // replayed flight: queries not materialised yet
    ParamValues params;
    std::uint64_t seed = 0;
    std::uint64_t map_seed = 0;
  };
  int window_;
  std::deque<Entry> entries_;
};

/// One θ_s candidate of a PSO generation: its outcome and, per re-solved query, the objective,
/// the state, the error (empty when none) and the wall time.
struct ShortEvaluation {
  Outcome outcome;
  struct Resolve {
    ObjectiveValue value;
    EvalState state = EvalState::kOk;
    std::string error;
    double wall_s = 0.0;
  };
  std::vector<Resolve> resolves;

  /// The mean over the re-solved queries, term by term, into the outcome (a replayed outcome,
  /// or one without re-solves, is kept); its state: error when a re-solve raised one, else the
  /// first re-solve's that is not ok.
  void Average() {
    Outcome& o = outcome;
    if (o.replayed || resolves.empty()) return;
    const double n = static_cast<double>(resolves.size());
    for (const Resolve& r : resolves) {
      o.objective.value += r.value.value / n;
      for (const auto& [k, v] : r.value.terms) o.objective.terms[k] += v / n;
      o.wall_s += r.wall_s;
      if (r.state == EvalState::kError || o.state == EvalState::kOk) o.state = r.state;
      if (!r.error.empty()) {
        o.status = EvalStatus::kFailed;
        if (o.message.empty()) o.message = r.error;
      }
    }
    o.objective.terms["queries"] = n;
    o.finished = Now();
  }
};

/// One trial: method × repeat.
class Trial {
 public:
  Trial(Context& c, Method method, int repeat)
      : c_(c),
        e_(c.e),
        method_(method),
        repeat_(repeat),
        seed_(DeriveSeed(c.e.seed,
                         {static_cast<std::uint64_t>(method), static_cast<std::uint64_t>(repeat)})),
        log_(c, method, repeat),
        buffer_(c.e.budget.query_window) {
    summary_.method = ToString(method);
    summary_.repeat = repeat;
    summary_.trial_id = log_.TrialId();
  }

  /// Returns false when cancelled.
  bool Run() {
    if (method_ == Method::kBoPso) {
      bo_pso_defaults_ = DefaultsOf(e_);
      if (e_.start) {
        for (const auto& [name, value] : *e_.start) bo_pso_defaults_[name] = value;
      }
    }
    incumbent_ = TrialDefaults();
    raced_.push_back(Unit(incumbent_));
    bool done = method_ == Method::kBoPso ? RunBoPso() : RunSingle();
    Recommend();
    if (done) done = Recheck();
    log_.Finish(done, summary_.best, summary_.best_value);
    return done;
  }
  [[nodiscard]] const TrialSummary& Summary() const { return summary_; }

 private:
  int FlightBatch() const {
    return e_.budget.flight_batch > 0 ? e_.budget.flight_batch : c_.threads;
  }

  std::uint64_t FlightSeed(int iteration, int index) const {
    return DeriveSeed(seed_, {0xf1, static_cast<std::uint64_t>(iteration), static_cast<std::uint64_t>(index)});
  }

  void Observe(const Outcome& o) {
    ++summary_.flights;
    if (o.status != EvalStatus::kOk) ++summary_.failed;
    if (o.replayed) ++summary_.replayed;
    // The best completed evaluation; until there is one, the best failed one (its value is the
    // failure value), so that a trial whose every flight failed does not report f_l = 0.
    const bool ok = o.status == EvalStatus::kOk;
    flown_.push_back({!ok, o.objective.value, o.params});
    every_flight_.push_back({Sample(o).failed, o.objective.value, o.params});
    const bool lower = summary_.flights == 1 || o.objective.value < summary_.best_value;
    if (have_best_ ? ok && lower : ok || lower) {
      have_best_ = have_best_ || ok;
      summary_.best_value = o.objective.value;
      summary_.best = o.params;
    }
  }

  void Report() {
    if (!c_.options.on_progress) return;
    Progress p;
    p.method = summary_.method;
    p.repeat = repeat_;
    p.flights_done = summary_.flights;
    p.flights_total = FlightBudget();
    p.trials_done = c_.trials_done.load();
    p.trials_total = c_.trials_total.load();
    p.short_evals = c_.resolves.load();
    p.best_long = summary_.best_value;
    p.elapsed_s = std::chrono::duration<double>(Clock::now() - c_.start).count();
    c_.options.on_progress(p);
  }

  /// Flies a batch of parameter sets (replaying stored ones) into `out`, in index order. The
  /// caller must call scheduler.Wait(group) before reading them.
  void SubmitFlights(TaskGroup& group, int iteration, const std::vector<ParamValues>& batch,
                     bool record, std::vector<Outcome>& out) {
    out.assign(batch.size(), Outcome{});
    for (std::size_t i = 0; i < batch.size(); ++i) {
      const int index = static_cast<int>(i);
      const std::uint64_t map_seed = e_.FlightMapSeed(repeat_, TuningFlights() + index);
      if (auto replayed = log_.Replayed(EvalKind::kLong, iteration, index, batch[i])) {
        if (e_.mode == TimingMode::kReproducible && replayed->map_seed != map_seed) {
          throw ConfigError(c_.options.store_path, "--resume",
                            "stored flight (iteration " + std::to_string(iteration) + ", index " +
                                std::to_string(i) + ") flew map " +
                                std::to_string(replayed->map_seed) + " but the run asks map " +
                                std::to_string(map_seed) +
                                "; the stored run is not a prefix of this one");
        }
        out[i] = std::move(*replayed);
        out[i].map_seed = map_seed;
        out[i].flight_seed = FlightSeed(iteration, index);
        continue;
      }
      std::function<void(double, ParamValues&)> provider;
      if (e_.mode == TimingMode::kRealtime && method_ == Method::kBoPso) {
        provider = [this](double, ParamValues& theta_s) {
          std::lock_guard lock(live_mutex_);
          if (!live_best_.empty()) theta_s = live_best_;
        };
      }
      const std::uint64_t seed = FlightSeed(iteration, index);
      Outcome* slot = &out[i];
      const ParamValues params = batch[i];
      c_.scheduler.Submit(group, Priority::kFlight,
                          [this, slot, map_seed, params, seed, record, provider] {
                            FlyInto(c_, map_seed, params, seed, record, provider, *slot);
                          });
    }
  }

  /// Flights of this trial: budget.default_flights for the defaults, else budget.flights.
  [[nodiscard]] int FlightBudget() const {
    return method_ == Method::kDefault ? e_.budget.default_flights : e_.budget.flights;
  }

  bool RunSingle() {
    single_opt_ = MakeSingleOptimizer(e_, method_, seed_, &single_bo_);
    optimizers::Optimizer* opt = single_opt_.get();
    const ParamValues defaults = DefaultsOf(e_);
    int iteration = 0;
    while (summary_.flights < TuningLimit()) {
      if (c_.CancelRequested()) return false;
      const int k = std::min(FlightBatch(), TuningLimit() - summary_.flights);
      std::vector<optimizers::Candidate> cands;
      std::vector<ParamValues> batch;
      if (opt != nullptr) {
        cands = opt->Ask(k);
        for (const auto& cand : cands) batch.push_back(Merge(defaults, e_.space.ToNamed(cand.x)));
      } else {
        batch.assign(static_cast<std::size_t>(k), defaults);
      }
      TaskGroup group;
      std::vector<Outcome> out;
      SubmitFlights(group, iteration, batch, false, out);
      c_.scheduler.Wait(group);
      if (c_.CancelRequested()) return false;
      for (std::size_t i = 0; i < out.size(); ++i) {
        NumberFlight(out[i]);
        log_.Store(EvalKind::kLong, iteration, static_cast<int>(i), out[i]);
        if (opt != nullptr) opt->Tell(cands[i].id, out[i].objective.value);
        Observe(out[i]);
      }
      ++iteration;
      Report();
      if (!MaybeRace()) return false;
    }
    return FinalRaces();
  }

  // ---- bo_pso ------------------------------------------------------------------------------

  /// Runs `evaluations` θ_s evaluations (PSO generations) on the first `entries` buffer entries;
  /// then, when `until` is given, more generations until that group is done.
  void ShortPhase(int evaluations, std::size_t entries, const TaskGroup* until = nullptr) {
    if (evaluations <= 0) return;
    if (buffer_.Total(entries) == 0) return;
    bool materialised = false;
    int left = evaluations;
    while (left > 0 || (until != nullptr && !until->Done())) {
      if (c_.CancelRequested()) return;
      const auto cands =
          bo_pso_.pso->Ask(left > 0 ? std::min(left, e_.pso.num_particles) : e_.pso.num_particles);
      if (cands.empty()) break;
      const int gen = generation_++;
      std::vector<ShortEvaluation> evals(cands.size());
      if (!ScoreGeneration(gen, cands, entries, materialised, evals)) return;
      for (std::size_t i = 0; i < cands.size(); ++i) {
        const Outcome& o = evals[i].outcome;
        log_.Store(EvalKind::kShort, gen, static_cast<int>(i), o);
        bo_pso_.pso->Tell(cands[i].id, o.objective.value);
        ++summary_.short_evals;
        if (o.status != EvalStatus::kOk) ++summary_.failed;
        if (o.replayed) ++summary_.replayed;
      }
      left = std::max(0, left - static_cast<int>(cands.size()));
      if (e_.mode == TimingMode::kRealtime) {
        std::lock_guard lock(live_mutex_);
        live_best_ = BestShort();
      }
    }
  }

  /// Scores the candidates of generation `gen` into `evals`: replayed where stored, else
  /// re-solved on one query subset drawn for the generation (every candidate is scored on the
  /// same problems), on the first `entries` buffer entries (materialised once, on first need:
  /// *materialised). Returns false when cancelled.
  bool ScoreGeneration(int gen, const std::vector<optimizers::Candidate>& cands,
                       std::size_t entries, bool& materialised,
                       std::vector<ShortEvaluation>& evals) {
    int total = buffer_.Total(entries);
    std::vector<Opaque> subset;
    TaskGroup group;
    for (std::size_t i = 0; i < cands.size(); ++i) {
      const ParamValues theta_s = bo_pso_.short_space.ToNamed(cands[i].x);
      Outcome& out = evals[i].outcome;
      if (auto replayed = log_.Replayed(EvalKind::kShort, gen, static_cast<int>(i), theta_s)) {
        out = std::move(*replayed);
        continue;
      }
      if (!materialised) {
        buffer_.Materialise(c_, entries);
        materialised = true;
        // Re-flown flights give the stored query counts in reproducible mode; recount anyway.
        total = buffer_.Total(entries);
      }
      out.params = theta_s;
      if (total == 0) {
        out.status = EvalStatus::kFailed;
        out.message = "no recorded planning query to re-solve";
        out.objective.value = e_.objective.failure_value;
        continue;
      }
      out.started = Now();
      if (subset.empty()) subset = DrawSubset(gen, total);
      SubmitResolves(group, subset, theta_s, evals[i]);
    }
    c_.scheduler.Wait(group);
    if (c_.CancelRequested()) return false;
    for (ShortEvaluation& eval : evals) eval.Average();
    return true;
  }

  /// Re-solves every query of `subset` with θ_s into eval.resolves (sized here).
  void SubmitResolves(TaskGroup& group, const std::vector<Opaque>& subset,
                      const ParamValues& theta_s, ShortEvaluation& eval) {
    eval.resolves.resize(subset.size());
    for (std::size_t j = 0; j < subset.size(); ++j) {
      const Opaque query = subset[j];
      ShortEvaluation::Resolve* resolve = &eval.resolves[j];
      c_.scheduler.Submit(group, Priority::kShort, [this, query, theta_s, resolve] {
        if (c_.CancelRequested()) return;  // the generation is dropped: stop within one re-solve
        const auto t0 = Clock::now();
        ResolveRecord rec;
        try {
          rec = e_.planner.Resolve(query, theta_s);
        } catch (const std::exception& ex) {
          rec = ResolveRecord{};
          rec.status = EvalStatus::kFailed;
          resolve->error = std::string("exception: ") + ex.what();
        }
        resolve->value = ShortTermObjective(rec, e_.objective, e_.mode);
        resolve->state = StateOf(rec);
        resolve->wall_s = std::chrono::duration<double>(Clock::now() - t0).count();
        c_.resolves.fetch_add(1);
      });
    }
  }

  /// The queries_per_eval queries every candidate of generation `gen` re-solves, drawn (with
  /// replacement) from the last query_window of the first `total` buffered queries.
  std::vector<Opaque> DrawSubset(int gen, int total) const {
    Rng rng(DeriveSeed(seed_, {0x5e, static_cast<std::uint64_t>(gen)}));
    const int window_begin = std::max(0, total - e_.budget.query_window);
    return buffer_.Draw(rng, e_.budget.queries_per_eval, window_begin, total);
  }

  ParamValues BestShort() const {
    const auto best = bo_pso_.pso->Best();
    return best ? bo_pso_.short_space.ToNamed(best->x) : theta_s_start_;
  }

  /// n_d advances once when the θ_s that flies this round differs from the last round's.
  void NoteFlyingShort(const ParamValues& theta_s) {
    if (theta_s == flying_short_) return;
    flying_short_ = theta_s;
    bo_pso_.bo->NotifyContextChanged();
    ++summary_.context_changes;
  }

  /// Stores and tells the flights of one bo_pso round (BO is told when `cands` is given) and
  /// buffers their queries.
  void TakeLongRound(int iteration, std::vector<Outcome>& out,
                     const std::vector<optimizers::Candidate>* cands) {
    for (std::size_t i = 0; i < out.size(); ++i) {
      if (!out[i].replayed) out[i].objective.terms["n_d"] = summary_.context_changes;
      NumberFlight(out[i]);
      log_.Store(EvalKind::kLong, iteration, static_cast<int>(i), out[i]);
      if (cands != nullptr) bo_pso_.bo->Tell((*cands)[i].id, out[i].objective.value);
      Observe(out[i]);
    }
    for (const Outcome& o : out) buffer_.Add(o);
  }

  bool RunBoPso() {
    bo_pso_ = MakeBoPsoOptimizers(e_, seed_);
    const ParamValues defaults = bo_pso_defaults_;
    theta_s_start_ = e_.initial_short ? *e_.initial_short : Pick(defaults, e_.short_names);
    live_best_ = theta_s_start_;
    flying_short_ = theta_s_start_;
    int iteration = 0;
    if (!e_.initial_short) {
      // θ_s first: a flight with the defaults records queries; PSO runs on them before BO.
      TaskGroup group;
      std::vector<Outcome> out;
      SubmitFlights(group, 0, {defaults}, true, out);
      c_.scheduler.Wait(group);
      if (c_.CancelRequested()) return false;
      TakeLongRound(0, out, nullptr);
      ShortPhase(e_.budget.short_evals_per_flight, buffer_.Size());
      if (c_.CancelRequested()) return false;
      iteration = 1;
      Report();
    }
    while (summary_.flights < TuningLimit()) {
      if (c_.CancelRequested()) return false;
      const int k = std::min(FlightBatch(), TuningLimit() - summary_.flights);
      const ParamValues theta_s_round = BestShort();
      NoteFlyingShort(theta_s_round);
      const auto cands = bo_pso_.bo->Ask(k);
      std::vector<ParamValues> batch;
      for (const auto& cand : cands) {
        batch.push_back(Merge(Merge(defaults, theta_s_round), bo_pso_.long_space.ToNamed(cand.x)));
      }
      TaskGroup flights;
      std::vector<Outcome> out;
      SubmitFlights(flights, iteration, batch, true, out);  // flights first ...
      const std::size_t entries = buffer_.Size();           // ... PSO on earlier queries meanwhile
      ShortPhase(e_.budget.short_evals_per_flight * static_cast<int>(cands.size()), entries,
                 e_.budget.short_term_while_flying ? &flights : nullptr);
      c_.scheduler.Wait(flights);
      if (c_.CancelRequested()) return false;
      TakeLongRound(iteration, out, &cands);
      ++iteration;
      Report();
      if (!MaybeRace()) return false;
    }
    return FinalRaces();
  }

  /// Fills summary_.recommended (see TrialSummary).
  void Recommend() {
    summary_.recommended = summary_.best;
    summary_.recommended_value = summary_.best_value;
    if (Racing()) {
      summary_.recommended = incumbent_;
      summary_.recommended_value = std::numeric_limits<double>::infinity();
      if (!incumbent_samples_.empty()) summary_.recommended_value = MeanOf(incumbent_samples_);
      summary_.recommended_rank = summary_.incumbent_changes > 0 ? 0 : -1;
    } else if (method_ == Method::kDefault) {
      summary_.recommended = DefaultsOf(e_);
    } else if (method_ == Method::kBo && single_bo_ != nullptr) {
      if (const auto best = single_bo_->Best()) {
        summary_.recommended = Merge(DefaultsOf(e_), e_.space.ToNamed(best->x));
        summary_.recommended_value = best->value;
      }
    } else if (method_ == Method::kBoPso && bo_pso_.bo) {
      if (const auto best = bo_pso_.bo->Best()) {
        summary_.recommended =
            Merge(Merge(bo_pso_defaults_, BestShort()), bo_pso_.long_space.ToNamed(best->x));
        summary_.recommended_value = best->value;
      }
    }
  }

  // ---- recommendation by re-flights ---------------------------------------------------------

  /// Point `p` in the unit cube of the tuned space (`p` may hold untuned planner parameters too,
  /// which ParameterSpace::FromNamed refuses).
  Eigen::VectorXd Unit(const ParamValues& p) const { return UnitIn(e_.space, p); }

  /// Point `p` in the unit cube of `space` (`p` may hold other parameters too).
  static Eigen::VectorXd UnitIn(const optimizers::ParameterSpace& space, const ParamValues& p) {
    const auto names = space.Names();
    Eigen::VectorXd x(static_cast<Eigen::Index>(names.size()));
    for (std::size_t i = 0; i < names.size(); ++i) x[static_cast<Eigen::Index>(i)] = p.at(names[i]);
    return space.ToUnit(x);
  }

  /// The recommendation's candidates, best first, at most recommend.candidates, then
  /// recommend.backoff points between the first and the defaults; a point within
  /// kNearDuplicate of an earlier candidate in every coordinate of the unit cube is skipped
  /// (re-flying near copies of a candidate tells nothing new).
  std::vector<ParamValues> RankedCandidates() const {
    std::vector<ParamValues> out;
    std::vector<Eigen::VectorXd> units;
    auto cap = static_cast<std::size_t>(e_.recommend.candidates);
    auto add = [&](ParamValues p) {
      if (out.size() >= cap) return;
      const Eigen::VectorXd u = Unit(p);
      if (NearAny(units, u)) return;
      units.push_back(u);
      out.push_back(std::move(p));
    };
    for (auto& p : RankedPoints()) add(std::move(p));
    // Back-off: the best candidate moved towards the defaults, u = u_d + α (u_best − u_d) in the
    // unit cube, α = 1 − i / (backoff + 1), i = 1 … backoff.
    if (!out.empty() && e_.recommend.backoff > 0) {
      const ParamValues defaults = TrialDefaults();
      const Eigen::VectorXd u_d = Unit(defaults);
      const Eigen::VectorXd u_best = Unit(out.front());
      const int n = e_.recommend.backoff;
      cap = out.size() + static_cast<std::size_t>(n);
      for (int i = 1; i <= n; ++i) {
        const double alpha = 1.0 - static_cast<double>(i) / static_cast<double>(n + 1);
        const Eigen::VectorXd u = u_d + alpha * (u_best - u_d);
        add(Merge(defaults, e_.space.ToNamed(e_.space.FromUnit(u))));
      }
    }
    return out;
  }

  /// Within kNearDuplicate of one of `units` in every coordinate of the unit cube.
  static bool NearAny(const std::vector<Eigen::VectorXd>& units, const Eigen::VectorXd& u) {
    static constexpr double kNearDuplicate = 0.02;
    return std::any_of(units.begin(), units.end(), [&](const Eigen::VectorXd& v) {
      return (v - u).cwiseAbs().maxCoeff() < kNearDuplicate;
    });
  }

  /// The method's points, best first: bo, the observed points by posterior mean; bo_pso, those
  /// for θ_l with PSO's best θ_s; random and pso, the flights by f_l (completed ones first).
  std::vector<ParamValues> RankedPoints() const {
    std::vector<ParamValues> out;
    if (method_ == Method::kBo && single_bo_ != nullptr) {
      for (const auto& b : single_bo_->Ranked()) {
        out.push_back(Merge(DefaultsOf(e_), e_.space.ToNamed(b.x)));
      }
    } else if (method_ == Method::kBoPso && bo_pso_.bo) {
      const ParamValues theta_s = BestShort();
      const bool both = Racing() && e_.race.incumbent_short;
      for (const auto& b : bo_pso_.bo->Ranked()) {
        const ParamValues theta_l = bo_pso_.long_space.ToNamed(b.x);
        out.push_back(Merge(Merge(bo_pso_defaults_, theta_s), theta_l));
        if (both) out.push_back(Merge(Merge(bo_pso_defaults_, Pick(incumbent_, e_.short_names)), theta_l));
      }
    } else {
      auto flown = flown_;  // completed flights first, then by f_l; ties keep flight order
      std::stable_sort(flown.begin(), flown.end(), [](const Flown& a, const Flown& b) {
        return std::tie(a.failed, a.value) < std::tie(b.failed, b.value);
      });
      for (const auto& f : flown) out.push_back(f.params);
    }
    return out;
  }

  // ---- racing -------------------------------------------------------------------------------

  [[nodiscard]] bool Racing() const { return e_.race.enabled && method_ != Method::kDefault; }

  [[nodiscard]] int TuningFlights() const { return summary_.flights - summary_.race_flights; }

  /// With racing, a flight's place among the trial's flights (1, 2, …) as term "flight_no".
  void NumberFlight(Outcome& o) const {
    if (Racing() && !o.replayed) o.objective.terms["flight_no"] = summary_.flights + 1;
  }

  static double MeanOf(const std::vector<optimizers::RaceSample>& samples) {
    double sum = 0.0;
    for (const auto& s : samples) sum += s.value;
    return sum / static_cast<double>(samples.size());
  }

  /// A race flight fails the finish/collision rate: not completed, a collision, or an error.
  static optimizers::RaceSample Sample(const Outcome& o) {
    const bool failed =
        o.status != EvalStatus::kOk || Term(o, "completed") != 1.0 || Term(o, "n_c") != 0.0;
    return {o.objective.value, failed};
  }

  /// After a round: races the method's best point not raced yet when the race's first stage
  /// keeps racing flights within race.share of the trial's flights. Returns false when
  /// cancelled.
  bool MaybeRace() {
    if (!Racing()) return true;
    // A race starts when its first stage fits in the budget left and keeps racing flights within
    // race.share of the trial's flights.
    const int first = std::min(e_.race.first_maps, e_.race.max_maps);
    const int stage = first + std::max(0, first - static_cast<int>(incumbent_samples_.size()));
    // With race.reserve a race during the rounds must leave a whole race's flights after it.
    if (summary_.flights + (e_.race.reserve ? 2 * WholeRaceFlights() : stage) > FlightBudget()) {
      return true;
    }
    // A pending back-off point or step races at once: the race before it showed the gain is there.
    if (!pending_ &&
        summary_.race_flights + stage > e_.race.share * (summary_.flights + stage)) {
      return true;
    }
    std::vector<ParamValues> points = Challengers();
    if (points.empty()) return true;
    return RaceAgainst(std::move(points.front()));
  }

  /// The points not raced yet, the next challenger first (race.challenger); a pending
  /// race.backoff point or race.extrapolate step alone.
  std::vector<ParamValues> Challengers() {
    std::vector<ParamValues> points;
    if (pending_ && !NearAny(raced_, Unit(pending_->point))) {
      challenger_estimate_.reset();
      return {pending_->point};
    }
    pending_.reset();
    for (auto& p : RankedPoints()) {
      if (!NearAny(raced_, Unit(p))) points.push_back(std::move(p));
    }
    if (!points.empty() && e_.race.challenger == optimizers::ChallengerRule::kTwoPart) {
      points = ByTwoPartModel(points);
    }
    return points;
  }

  /// Flights a race of a new challenger may need: max_maps of its own and the incumbent's
  /// missing ones.
  [[nodiscard]] int WholeRaceFlights() const {
    const int have = static_cast<int>(incumbent_samples_.size());
    return e_.race.max_maps + std::max(0, e_.race.max_maps - have);
  }

  /// The flights tuning rounds may use: the budget, less one whole race with race.reserve.
  [[nodiscard]] int TuningLimit() const {
    if (!Racing() || !e_.race.reserve) return FlightBudget();
    return std::max(0, FlightBudget() - WholeRaceFlights());
  }

  /// race.reserve: after the tuning rounds, races the points not raced yet while a whole race
  /// fits the flights left. Returns false when cancelled.
  bool FinalRaces() {
    if (!Racing() || !e_.race.reserve) return true;
    while (summary_.flights + WholeRaceFlights() <= FlightBudget()) {
      if (c_.CancelRequested()) return false;
      std::vector<ParamValues> points = Challengers();
      if (points.empty()) return true;
      if (!RaceAgainst(std::move(points.front()))) return false;
    }
    return true;
  }

  /// The space the challenger model works in: bo_pso's θ_l (its challengers share the best
  /// θ_s), else (and with race.incumbent_short) the tuned space.
  [[nodiscard]] const optimizers::ParameterSpace& ModelSpace() const {
    return ModelIsLongOnly() ? bo_pso_.long_space : e_.space;
  }

  /// The challenger model works in bo_pso's θ_l only (see ModelSpace()).
  [[nodiscard]] bool ModelIsLongOnly() const {
    return method_ == Method::kBoPso && !e_.race.incumbent_short;
  }

  /// `p` in the unit cube of ModelSpace().
  [[nodiscard]] Eigen::VectorXd ModelUnit(const ParamValues& p) const {
    return UnitIn(ModelSpace(), p);
  }

  /// `points` ordered by a ChallengerModel fit to every flight of the trial (race flights
  /// included), highest score first, against the model's value at the incumbent; the first
  /// one's estimate is kept for the race's stored outcome.
  std::vector<ParamValues> ByTwoPartModel(const std::vector<ParamValues>& points) {
    challenger_estimate_.reset();
    const optimizers::ChallengerModel model = FittedModel(0xc4);
    double reference = std::numeric_limits<double>::infinity();
    double sd = 0.0;
    if (!model.PredictFinished(ModelUnit(incumbent_), &reference, &sd)) return points;
    std::vector<std::pair<optimizers::ChallengerEstimate, std::size_t>> scored;
    for (std::size_t i = 0; i < points.size(); ++i) {
      scored.emplace_back(model.Estimate(ModelUnit(points[i]), reference, e_.race.max_maps,
                                         e_.race.failures),
                          i);
    }
    std::stable_sort(scored.begin(), scored.end(),
                     [](const auto& a, const auto& b) { return a.first.score > b.first.score; });
    std::vector<ParamValues> out;
    for (const auto& [estimate, i] : scored) out.push_back(points[i]);
    challenger_estimate_ = scored.front().first;
    if (e_.race.propose) {
      if (auto p = Proposed(model, reference); p && p->estimate.score > challenger_estimate_->score) {
        out.insert(out.begin(), FromModelUnit(p->u));
        challenger_estimate_ = p->estimate;
      }
    }
    return out;
  }

  /// A ChallengerModel of ModelSpace() fit to every flight of the trial (race flights included),
  /// seeded by `tag` and the races so far.
  [[nodiscard]] optimizers::ChallengerModel FittedModel(std::uint64_t tag) const {
    optimizers::ChallengerModel model(
        ModelSpace().Dim(), DeriveSeed(seed_, {tag, static_cast<std::uint64_t>(summary_.races)}),
        e_.bo.gp, e_.race.failure_prior);
    std::vector<optimizers::ChallengerObservation> observations;
    for (const Flown& f : every_flight_) observations.push_back({ModelUnit(f.params), f.value, f.failed});
    model.Fit(observations);
    return model;
  }

  /// race.failure_margin: a winner's failure probability under a ChallengerModel fit to every
  /// flight, its race flights included, may exceed the incumbent's by at most the margin (its
  /// failing neighbours count against it where its own few race maps cannot). Sets the two
  /// probabilities.
  bool WithinFailureMargin(const ParamValues& challenger, double* p_challenger,
                           double* p_incumbent) const {
    const optimizers::ChallengerModel model = FittedModel(0xc6);
    *p_challenger = model.FailureProbability(ModelUnit(challenger));
    *p_incumbent = model.FailureProbability(ModelUnit(incumbent_));
    return *p_challenger <= *p_incumbent + e_.race.failure_margin;
  }

  /// race.propose: the model's own point (optimizers::ProposeChallenger), searched from the
  /// incumbent and every flown point; points near a raced one are not proposed.
  std::optional<optimizers::Proposal> Proposed(const optimizers::ChallengerModel& model,
                                               double reference) const {
    const optimizers::ParameterSpace& space = ModelSpace();
    std::vector<Eigen::VectorXd> starts{ModelUnit(incumbent_)};
    for (const Flown& f : every_flight_) starts.push_back(ModelUnit(f.params));
    Rng rng(DeriveSeed(seed_, {0xc5, static_cast<std::uint64_t>(summary_.races)}));
    optimizers::ProposalSearch search;
    search.center = starts.front();
    search.radius = e_.race.propose_radius;
    return optimizers::ProposeChallenger(
        model, starts, reference, e_.race.max_maps, e_.race.failures, rng,
        [&](Eigen::VectorXd u) { return space.SnapUnit(u); },
        [&](const Eigen::VectorXd& u) { return NearAny(raced_, Unit(FromModelUnit(u))); }, search);
  }

  /// A point of ModelSpace()'s unit cube as the parameters a race flies: bo_pso's θ_l with
  /// PSO's best θ_s, else the tuned point over the trial's defaults.
  [[nodiscard]] ParamValues FromModelUnit(const Eigen::VectorXd& u) const {
    const optimizers::ParameterSpace& space = ModelSpace();
    const ParamValues named = space.ToNamed(space.FromUnit(u));
    if (ModelIsLongOnly()) return Merge(Merge(bo_pso_defaults_, BestShort()), named);
    return Merge(TrialDefaults(), named);
  }

  /// One flight of a race: who flies which race map.
  struct RaceFlight {
    bool challenger = false;
    int map = 0;
  };

  /// Flies `flights` (replaying stored ones) as race `race`'s flights `first`, `first` + 1, …,
  /// stores them and appends their samples. Returns false when cancelled.
  bool FlyRace(int race, int first, const ParamValues& challenger,
               const std::vector<RaceFlight>& flights,
               std::vector<optimizers::RaceSample>& challenger_samples) {
    std::vector<Outcome> out(flights.size());
    TaskGroup group;
    for (std::size_t i = 0; i < flights.size(); ++i) {
      const RaceFlight f = flights[i];
      const ParamValues params = f.challenger ? challenger : incumbent_;
      Outcome* slot = &out[i];
      if (auto replayed = log_.Replayed(EvalKind::kRace, race, first + static_cast<int>(i), params)) {
        *slot = std::move(*replayed);
        continue;
      }
      const std::uint64_t map_seed = e_.RaceMapSeed(repeat_, f.map);
      const std::uint64_t seed = e_.RaceFlightSeed(repeat_, f.map);
      c_.scheduler.Submit(group, Priority::kFlight, [this, slot, map_seed, params, seed] {
        FlyInto(c_, map_seed, params, seed, false, {}, *slot);
      });
    }
    c_.scheduler.Wait(group);
    if (c_.CancelRequested()) return false;
    for (std::size_t i = 0; i < flights.size(); ++i) {
      Outcome& o = out[i];
      if (!o.replayed) {
        o.objective.terms["race_map"] = flights[i].map;
        o.objective.terms["challenger"] = flights[i].challenger ? 1.0 : 0.0;
        o.objective.terms["flight_no"] = summary_.flights + 1;
      }
      log_.Store(EvalKind::kRace, race, first + static_cast<int>(i), o);
      ++summary_.flights;
      ++summary_.race_flights;
      if (o.status != EvalStatus::kOk) ++summary_.failed;
      if (o.replayed) ++summary_.replayed;
      const optimizers::RaceSample sample = Sample(o);
      (flights[i].challenger ? challenger_samples : incumbent_samples_).push_back(sample);
      every_flight_.push_back({sample.failed, o.objective.value, o.params});
      TellSurrogate(flights[i].challenger ? challenger : incumbent_, o.objective.value);
    }
    return true;
  }

  /// race.tell: a race flight of `params` becomes an observation of bo's or bo_pso's GP.
  void TellSurrogate(const ParamValues& params, double value) {
    if (!e_.race.tell) return;
    optimizers::BayesOpt* bo = method_ == Method::kBo ? single_bo_ : bo_pso_.bo.get();
    if (bo == nullptr) return;
    const auto names = bo->Space().Names();
    Eigen::VectorXd x(static_cast<Eigen::Index>(names.size()));
    for (std::size_t i = 0; i < names.size(); ++i) x[static_cast<Eigen::Index>(i)] = params.at(names[i]);
    (void)bo->Observe(x, value);
  }

  /// Races `challenger` against the incumbent (optimizers::RunRace); a winner becomes the
  /// incumbent. The race's outcome is stored as kind "incumbent". Returns false when cancelled.
  bool RaceAgainst(ParamValues challenger) {
    const int race = summary_.races++;
    const bool queued = pending_ && pending_->point == challenger;
    const int depth = queued ? pending_->depth : 0;
    const bool halving = depth > 0;
    const int extrapolation = queued ? pending_->extrapolation : 0;
    const ParamValues failed = halving ? pending_->failed : ParamValues{};
    pending_.reset();
    raced_.push_back(Unit(challenger));
    std::vector<optimizers::RaceSample> samples;
    int flown = 0;
    bool cancelled = false;
    auto extend = [&](int n) {
      std::vector<RaceFlight> flights;
      for (int j = static_cast<int>(incumbent_samples_.size()); j < n; ++j) flights.push_back({false, j});
      for (int j = static_cast<int>(samples.size()); j < n; ++j) flights.push_back({true, j});
      if (summary_.flights + static_cast<int>(flights.size()) > FlightBudget()) return false;
      if (!FlyRace(race, flown, challenger, flights, samples)) {
        cancelled = true;
        return false;
      }
      flown += static_cast<int>(flights.size());
      Report();  // after each stage: a long race shows progress, and a cut can fall inside it
      return true;
    };
    auto d = optimizers::RunRace(e_.race, &incumbent_samples_, &samples, extend);
    if (cancelled) return false;
    if (d.verdict == optimizers::RaceVerdict::kAccept && e_.race.failure_margin < 1.0) {
      gate_ = {0.0, 0.0};
      if (!WithinFailureMargin(challenger, &gate_->first, &gate_->second)) {
        d.verdict = optimizers::RaceVerdict::kReject;
        d.reason = "fails more often than the incumbent by the model";
      }
    }
    if (d.verdict == optimizers::RaceVerdict::kReject && !d.stopped &&
        depth < e_.race.backoff && FailedWhileFaster(samples)) {
      pending_ = Pending{Halfway(challenger), depth + 1, challenger};
    }
    if (d.verdict == optimizers::RaceVerdict::kAccept) {
      const ParamValues previous = std::exchange(incumbent_, std::move(challenger));
      incumbent_samples_ = std::move(samples);
      ++summary_.incumbent_changes;
      if (halving && e_.race.bisect && depth < e_.race.backoff) {
        pending_ = Pending{Halfway(failed), depth + 1, failed};  // halfway to the failed point
      } else if (!halving && extrapolation < e_.race.extrapolate) {
        pending_ = Pending{Beyond(previous), 0, {}, extrapolation + 1};  // one more such step
      }
    }
    StoreRaceOutcome(race, d, depth, extrapolation);
    return true;
  }

  /// race.backoff: the challenger failed a race map and was faster than the incumbent on the
  /// maps neither side failed.
  [[nodiscard]] bool FailedWhileFaster(const std::vector<optimizers::RaceSample>& challenger) const {
    const std::size_t n = std::min(challenger.size(), incumbent_samples_.size());
    int failures = 0;
    int clean = 0;
    double difference = 0.0;
    for (std::size_t j = 0; j < n; ++j) {
      const auto& c = challenger[j];
      const auto& i = incumbent_samples_[j];
      failures += c.failed ? 1 : 0;
      if (c.failed || i.failed) continue;
      ++clean;
      difference += c.value - i.value;
    }
    return failures > 0 && clean > 0 && difference < 0.0;
  }

  /// The point halfway between the incumbent and `challenger` in the unit cube of the tuned
  /// space (integers rounded), over the challenger's other parameters.
  [[nodiscard]] ParamValues Halfway(const ParamValues& challenger) const {
    return AtUnit(0.5 * (Unit(incumbent_) + Unit(challenger)), challenger);
  }

  /// race.extrapolate: the incumbent moved on by its last step from `previous` (the unit cube of
  /// the tuned space, clamped to it; integers rounded), over the incumbent's other parameters.
  [[nodiscard]] ParamValues Beyond(const ParamValues& previous) const {
    return AtUnit((2.0 * Unit(incumbent_) - Unit(previous)).cwiseMax(0.0).cwiseMin(1.0),
                  incumbent_);
  }

  /// The point at unit-cube place `u` of the tuned space (integers rounded), over `over`'s other
  /// parameters.
  [[nodiscard]] ParamValues AtUnit(const Eigen::VectorXd& u, const ParamValues& over) const {
    return Merge(over, e_.space.ToNamed(e_.space.FromUnit(e_.space.SnapUnit(u))));
  }

  /// Kind "incumbent", iteration = race: the incumbent after the race and its mean f_l.
  void StoreRaceOutcome(int race, const optimizers::RaceDecision& d, int backoff,
                        int extrapolation) {
    if (log_.Replayed(EvalKind::kIncumbent, race, 0, incumbent_)) return;
    Outcome o;
    o.params = incumbent_;
    o.objective.value = incumbent_samples_.empty() ? e_.objective.failure_value
                                                   : MeanOf(incumbent_samples_);
    o.objective.terms = {{"accepted", d.verdict == optimizers::RaceVerdict::kAccept ? 1.0 : 0.0},
                         {"p_value", d.p_value},
                         {"mean_difference", d.mean_difference},
                         {"maps", d.maps},
                         {"incumbent_maps", static_cast<double>(incumbent_samples_.size())},
                         {"flight_no", summary_.flights}};
    if (d.stopped) o.objective.terms["stopped"] = 1.0;  // cut by the budget before its verdict
    if (backoff > 0) o.objective.terms["backoff"] = backoff;  // halvings towards the incumbent
    if (extrapolation > 0) o.objective.terms["extrapolation"] = extrapolation;  // steps beyond
    if (gate_) {
      o.objective.terms["gate_p_fail"] = gate_->first;
      o.objective.terms["gate_p_fail_incumbent"] = gate_->second;
      gate_.reset();
    }
    if (challenger_estimate_) {
      o.objective.terms["challenger_p_fail"] = challenger_estimate_->failure_probability;
      o.objective.terms["challenger_mean"] = challenger_estimate_->mean;
      o.objective.terms["challenger_score"] = challenger_estimate_->score;
      challenger_estimate_.reset();
    }
    o.started = o.finished = Now();
    log_.Store(EvalKind::kIncumbent, race, 0, o);
  }

  /// The defaults this trial falls back to (bo_pso: with the experiment's `start:`).
  ParamValues TrialDefaults() const {
    return method_ == Method::kBoPso ? bo_pso_defaults_ : DefaultsOf(e_);
  }

  /// Objective term `name` of `o`; NaN when absent (so every comparison with it fails).
  static double Term(const Outcome& o, const char* name) {
    const auto it = o.objective.terms.find(name);
    return it == o.objective.terms.end() ? std::numeric_limits<double>::quiet_NaN() : it->second;
  }

  /// A re-flight passes: it completed, collided with nothing and, unless
  /// recommend.emergency_stops allows them, made no emergency stop.
  bool Passes(const Outcome& o) const {
    return o.status == EvalStatus::kOk && Term(o, "completed") == 1.0 && Term(o, "n_c") == 0.0 &&
           (e_.recommend.emergency_stops || Term(o, "n_e") == 0.0);
  }

  /// The re-flights' smallest clearances c_i keep the margin: mean(c) − z·sd(c) >= clearance
  /// (sd with n − 1; 0 for one flight), a normal fit's 1 − Φ(−z) quantile of the clearance.
  bool KeepsMargin(const std::vector<double>& c) const {
    double mean = 0.0;
    for (double v : c) mean += v / static_cast<double>(c.size());
    double var = 0.0;
    for (double v : c) var += (v - mean) * (v - mean);
    const double sd = c.size() > 1 ? std::sqrt(var / static_cast<double>(c.size() - 1)) : 0.0;
    return std::isfinite(mean) && mean - e_.recommend.z * sd >= e_.recommend.clearance;
  }

  /// Tries the ranked candidates in turn on the repeat's re-flight maps (flight_batch at a time,
  /// a candidate dropped at its first batch with a flight that does not pass, Passes) and
  /// recommends the first whose every re-flight passes and whose clearances keep the margin
  /// (KeepsMargin); the defaults when none does. Stored as kind "recheck" (iteration = rank,
  /// index = re-flight). Returns false when cancelled.
  bool Recheck() {
    if (method_ == Method::kDefault || e_.recommend.candidates <= 0) return true;
    const std::vector<ParamValues> cands = RankedCandidates();
    for (std::size_t rank = 0; rank < cands.size(); ++rank) {
      const int r = static_cast<int>(rank);
      bool pass = true;
      double sum = 0.0;
      std::vector<double> clearances;
      for (int j = 0; j < e_.recommend.flights && pass;) {
        const int k = std::min(FlightBatch(), e_.recommend.flights - j);
        std::vector<Outcome> out(static_cast<std::size_t>(k));
        TaskGroup group;
        for (int i = 0; i < k; ++i) {
          const int index = j + i;
          Outcome* slot = &out[static_cast<std::size_t>(i)];
          if (auto replayed = log_.Replayed(EvalKind::kRecheck, r, index, cands[rank])) {
            *slot = std::move(*replayed);
            continue;
          }
          const std::uint64_t map_seed = e_.RecheckMapSeed(repeat_, index);
          const std::uint64_t seed = e_.RecheckFlightSeed(repeat_, index);
          const ParamValues params = cands[rank];
          c_.scheduler.Submit(group, Priority::kFlight, [this, slot, map_seed, params, seed] {
            FlyInto(c_, map_seed, params, seed, false, {}, *slot);
          });
        }
        c_.scheduler.Wait(group);
        if (c_.CancelRequested()) return false;
        for (int i = 0; i < k; ++i) {
          const Outcome& o = out[static_cast<std::size_t>(i)];
          log_.Store(EvalKind::kRecheck, r, j + i, o);
          ++summary_.recheck_flights;
          if (o.replayed) ++summary_.replayed;
          pass = pass && Passes(o);
          sum += o.objective.value;
          clearances.push_back(Term(o, "min_clearance"));
        }
        j += k;
      }
      if (pass && KeepsMargin(clearances)) {
        summary_.recommended = cands[rank];
        summary_.recommended_value = sum / e_.recommend.flights;
        summary_.recommended_rank = r;
        return true;
      }
    }
    summary_.recommended = TrialDefaults();
    summary_.recommended_value = std::numeric_limits<double>::infinity();
    summary_.recommended_rank = -1;
    return true;
  }

  struct Flown {
    bool failed = false;
    double value = 0.0;
    ParamValues params;
  };

  Context& c_;
  const Experiment& e_;
  Method method_;
  int repeat_;
  std::uint64_t seed_;
  EvaluationLog log_;
  QueryBuffer buffer_;  // bo_pso
  TrialSummary summary_;
  bool have_best_ = false;
  std::vector<Flown> flown_;  // every flight told, in order
  std::unique_ptr<optimizers::Optimizer> single_opt_;  // random, pso, bo
  optimizers::BayesOpt* single_bo_ = nullptr;          // bo: single_opt_ as BayesOpt
  ParamValues bo_pso_defaults_;                        // bo_pso: defaults with e_.start
  // bo_pso
  BoPsoOptimizers bo_pso_;
  int generation_ = 0;
  ParamValues theta_s_start_;
  ParamValues flying_short_;  // θ_s of the last round flown (n_d counts its changes)
  std::mutex live_mutex_;
  ParamValues live_best_;
  // racing
  ParamValues incumbent_;
  std::vector<optimizers::RaceSample> incumbent_samples_;
  std::vector<Eigen::VectorXd> raced_;  // unit-cube points raced (and the first incumbent)
  std::vector<Flown> every_flight_;     // tuning and race flights, failed as a race counts it
  std::optional<optimizers::ChallengerEstimate> challenger_estimate_;  // two_part: the last one
  std::optional<std::pair<double, double>> gate_;  // failure_margin: p of challenger, incumbent
  /// The next challenger, raced at once: a race.backoff point (its halvings so far, and the
  /// challenger whose failure began them; race.bisect halves towards it after a win) or a
  /// race.extrapolate step (how many in a row).
  struct Pending {
    ParamValues point;
    int depth = 0;
    ParamValues failed;
    int extrapolation = 0;
  };
  std::optional<Pending> pending_;
};

}  // namespace

struct TrialRunner::Impl {
  Impl(const Experiment& experiment, const RunOptions& run_options, int threads,
       EvaluationStore* store)
      : options(run_options),
        scheduler(threads),
        c{experiment, options, scheduler, pool, store, scheduler.Threads(), Clock::now()} {}
  RunOptions options;
  Scheduler scheduler;
  WorldPool pool;
  Context c;
};

TrialRunner::TrialRunner(const Experiment& experiment, const RunOptions& options, int threads,
                         EvaluationStore* store)
    : impl_(std::make_unique<Impl>(experiment, options, threads, store)) {
  impl_->c.trials_total = static_cast<int>(experiment.methods.size()) * experiment.repeats;
  // The first map of every repeat (and of the validation) is made before any flight, so a
  // layout that cannot be generated stops the run before work starts.
  for (int repeat = 0; repeat < experiment.repeats; ++repeat) {
    (void)impl_->c.Map(experiment.FlightMapSeed(repeat, 0));
  }
  if (options.validate && experiment.validation.maps > 0) {
    (void)experiment.planner.PrepareMap(experiment.HeldOutMapSeed(0));
  }
}

TrialRunner::~TrialRunner() = default;

bool TrialRunner::Run(Method method, int repeat, TrialSummary& summary) {
  QT_DEMAND(repeat >= 0 && repeat < impl_->c.e.repeats,
            "repeat " + std::to_string(repeat) + " out of range");
  Trial trial(impl_->c, method, repeat);
  const bool done = trial.Run();
  summary = trial.Summary();
  return done;
}

void TrialRunner::SetTrialCounts(int done, int total) {
  impl_->c.trials_done = done;
  impl_->c.trials_total = total;
}

long TrialRunner::Flights() const { return impl_->c.flights.load(); }
long TrialRunner::Resolves() const { return impl_->c.resolves.load(); }
int TrialRunner::Worlds() const { return impl_->pool.Size(); }
double TrialRunner::ElapsedSeconds() const {
  return std::chrono::duration<double>(Clock::now() - impl_->c.start).count();
}

const Columns<TrialSummary>& TrialSummaryColumns() {
  using T = TrialSummary;
  static const Columns<T> columns =
      Columns<T>()
          .Text("method", &T::method, "the trial's method")
          .Integer("repeat", &T::repeat, "the repeat")
          .Integer("trial_id", &T::trial_id, "the store's id of the trial (0 without a store)")
          .Values("best", &T::best, "parameters of the best flight")
          .Real("best_value", &T::best_value, "the best flight's f_l")
          .Values("recommended", &T::recommended, "the point the method recommends")
          .Real("recommended_value", &T::recommended_value, "its estimated f_l")
          .Integer("recommended_rank", &T::recommended_rank,
                   "rank of the candidate whose re-flights passed; -1 when none")
          .Integer("recheck_flights", &T::recheck_flights, "re-flights flown to pick it")
          .Integer("flights", &T::flights, "every flight of the trial")
          .Integer("short_evals", &T::short_evals, "θ_s candidates scored")
          .Integer("failed", &T::failed, "failed evaluations")
          .Integer("replayed", &T::replayed, "evaluations taken from the store on resume")
          .Integer("races", &T::races, "races run")
          .Integer("race_flights", &T::race_flights, "flights flown in races")
          .Integer("incumbent_changes", &T::incumbent_changes, "races the challenger won")
          .Integer("context_changes", &T::context_changes, "bo_pso: changes of the flying θ_s");
  return columns;
}

RunSummary RunExperiment(const Experiment& experiment, const RunOptions& options) {
  RunSummary summary;
  summary.threads = options.threads > 0 ? options.threads : experiment.threads;
  std::unique_ptr<ResultStore> store;
  if (!options.store_path.empty()) {
    store = std::make_unique<ResultStore>(options.store_path, experiment, summary.threads,
                                          options.resume);
  }
  TrialRunner runner(experiment, options, summary.threads, store.get());
  const int total = static_cast<int>(experiment.methods.size()) * experiment.repeats;
  int trials_done = 0;
  for (int repeat = 0; repeat < experiment.repeats && summary.status == RunStatus::kCompleted;
       ++repeat) {
    for (Method method : experiment.methods) {
      runner.SetTrialCounts(trials_done, total);
      TrialSummary trial;
      const bool done = runner.Run(method, repeat, trial);
      summary.trials.push_back(trial);
      ++trials_done;
      if (!done) {
        summary.status = RunStatus::kCancelled;
        summary.message = "cancelled";
        break;
      }
    }
  }
  long validation_flights = 0;
  if (summary.status == RunStatus::kCompleted && options.validate &&
      experiment.validation.maps > 0) {
    std::vector<std::int64_t> ids;
    for (const auto& t : summary.trials) ids.push_back(t.trial_id);
    summary.validation = RunValidation(experiment, summary.trials, ids, store.get(),
                                       summary.threads, options, &validation_flights);
    if (summary.validation.empty()) {
      summary.status = RunStatus::kCancelled;
      summary.message = "cancelled";
    }
  }
  summary.flights = runner.Flights() + validation_flights;
  summary.resolves = runner.Resolves();
  summary.worlds = runner.Worlds();
  summary.wall_s = runner.ElapsedSeconds();
  return summary;
}

}  // namespace quadtune::engine
