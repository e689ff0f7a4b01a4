#include "quadtune/engine/tuning/sweep.hpp"

#include <algorithm>
#include <boost/random/sobol.hpp>
#include <chrono>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <map>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <sstream>
#include <limits>
#include <stdexcept>
#include <thread>

#include "quadtune/common/error.hpp"
#include "quadtune/common/random.hpp"
#include "quadtune/common/text_file.hpp"
#include "quadtune/engine/tuning/scheduler.hpp"

namespace quadtune::engine {
namespace {

using Clock = std::chrono::steady_clock;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

/// S_i and ST_i of every parameter and the variance, over the base rows `rows`.
struct Estimate {
  double mean = 0.0, variance = 0.0;
  std::vector<double> s1, st;
};

Estimate EstimateOver(const std::vector<double>& f_a, const std::vector<double>& f_b,
                      const std::vector<std::vector<double>>& f_ab, const std::vector<int>& rows) {
  Estimate e;
  const double n = static_cast<double>(rows.size());
  double sum = 0.0;
  for (int r : rows) sum += f_a[static_cast<std::size_t>(r)] + f_b[static_cast<std::size_t>(r)];
  e.mean = sum / (2.0 * n);
  double ss = 0.0;
  for (int r : rows) {
    const double da = f_a[static_cast<std::size_t>(r)] - e.mean;
    const double db = f_b[static_cast<std::size_t>(r)] - e.mean;
    ss += da * da + db * db;
  }
  e.variance = ss / (2.0 * n);
  for (const auto& ab : f_ab) {
    double first = 0.0, total = 0.0;
    for (int r : rows) {
      const auto k = static_cast<std::size_t>(r);
      first += f_b[k] * (ab[k] - f_a[k]);
      total += (f_a[k] - ab[k]) * (f_a[k] - ab[k]);
    }
    const bool flat = e.variance <= 0.0;
    e.s1.push_back(flat ? kNaN : first / n / e.variance);
    e.st.push_back(flat ? kNaN : total / (2.0 * n) / e.variance);
  }
  return e;
}

/// Linear-interpolated quantile q of sorted values.
double Quantile(const std::vector<double>& sorted, double q) {
  if (sorted.empty()) return kNaN;
  const double pos = q * static_cast<double>(sorted.size() - 1);
  const auto lo = static_cast<std::size_t>(std::floor(pos));
  const std::size_t hi = std::min(lo + 1, sorted.size() - 1);
  return sorted[lo] + (pos - static_cast<double>(lo)) * (sorted[hi] - sorted[lo]);
}

/// Percentile interval of `values` (NaNs dropped) at `confidence`.
std::pair<double, double> Interval(std::vector<double> values, double confidence) {
  values.erase(std::remove_if(values.begin(), values.end(), [](double v) { return std::isnan(v); }),
               values.end());
  std::sort(values.begin(), values.end());
  const double tail = 0.5 * (1.0 - confidence);
  return {Quantile(values, tail), Quantile(values, 1.0 - tail)};
}

std::vector<double> Ranks(const std::vector<double>& x) {
  std::vector<std::size_t> order(x.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return x[a] < x[b]; });
  std::vector<double> rank(x.size());
  for (std::size_t i = 0; i < order.size();) {
    std::size_t j = i;
    while (j + 1 < order.size() && x[order[j + 1]] == x[order[i]]) ++j;
    const double mean_rank = 0.5 * static_cast<double>(i + j) + 1.0;
    for (std::size_t k = i; k <= j; ++k) rank[order[k]] = mean_rank;
    i = j + 1;
  }
  return rank;
}

double Pearson(const std::vector<double>& x, const std::vector<double>& y) {
  const double n = static_cast<double>(x.size());
  double mx = 0.0, my = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    mx += x[i] / n;
    my += y[i] / n;
  }
  double sxy = 0.0, sxx = 0.0, syy = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    sxy += (x[i] - mx) * (y[i] - my);
    sxx += (x[i] - mx) * (x[i] - mx);
    syy += (y[i] - my) * (y[i] - my);
  }
  return sxx > 0.0 && syy > 0.0 ? sxy / std::sqrt(sxx * syy) : kNaN;
}

}  // namespace

Eigen::VectorXd SaltelliDesign::Point(int p) const {
  QT_DEMAND(p >= 0 && p < Points(), "design point out of range");
  const int block = Block(p);
  const int row = Row(p);
  if (block == 1) return b.row(row).transpose();
  Eigen::VectorXd x = a.row(row).transpose();
  if (block >= 2) x[block - 2] = b(row, block - 2);
  return x;
}

SaltelliDesign MakeSaltelliDesign(int n, int d, std::uint64_t seed) {
  if (n < 1)
    throw ConfigError("", "points",
                      "the design needs at least 1 base row, got " + std::to_string(n));
  if (d < 1 || 2 * d > 3667) {
    throw ConfigError(
        "", "parameters",
        "a Saltelli design needs 1 to 1833 parameters (Sobol' tables), got " + std::to_string(d));
  }
  boost::random::sobol sobol(static_cast<std::size_t>(2 * d));
  std::vector<std::uint64_t> shift(static_cast<std::size_t>(2 * d), 0);
  if (seed != 0) {
    Rng rng(DeriveSeed(seed, {0x50b0}));
    for (auto& s : shift) s = rng();
  }
  SaltelliDesign design;
  design.a.resize(n, d);
  design.b.resize(n, d);
  for (int r = 0; r < n; ++r) {
    for (int j = 0; j < 2 * d; ++j) {
      const std::uint64_t bits =
          static_cast<std::uint64_t>(sobol()) ^ shift[static_cast<std::size_t>(j)];
      // Top 53 bits → [0, 1), the same double on every platform.
      const double u = static_cast<double>(bits >> 11) * 0x1.0p-53;
      if (j < d) {
        design.a(r, j) = u;
      } else {
        design.b(r, j - d) = u;
      }
    }
  }
  return design;
}

SobolIndices EstimateSobolIndices(const std::vector<double>& f_a, const std::vector<double>& f_b,
                                  const std::vector<std::vector<double>>& f_ab, int bootstrap,
                                  std::uint64_t seed, double confidence) {
  const std::size_t n = f_a.size();
  if (n < 2 || f_b.size() != n) {
    throw std::invalid_argument("EstimateSobolIndices: f_a and f_b need the same N >= 2 values");
  }
  for (const auto& ab : f_ab) {
    if (ab.size() != n)
      throw std::invalid_argument("EstimateSobolIndices: every f_ab needs N values");
  }
  if (bootstrap < 1) throw std::invalid_argument("EstimateSobolIndices: bootstrap >= 1");
  std::vector<int> rows(n);
  for (std::size_t r = 0; r < n; ++r) rows[r] = static_cast<int>(r);
  const Estimate full = EstimateOver(f_a, f_b, f_ab, rows);
  const std::size_t d = f_ab.size();
  std::vector<std::vector<double>> s1(d), st(d);
  Rng rng(DeriveSeed(seed, {0xb007}));
  for (int b = 0; b < bootstrap; ++b) {
    for (auto& r : rows) r = static_cast<int>(UniformInt(rng, 0, static_cast<std::int64_t>(n) - 1));
    const Estimate e = EstimateOver(f_a, f_b, f_ab, rows);
    for (std::size_t i = 0; i < d; ++i) {
      s1[i].push_back(e.s1[i]);
      st[i].push_back(e.st[i]);
    }
  }
  SobolIndices out;
  out.mean = full.mean;
  out.variance = full.variance;
  for (std::size_t i = 0; i < d; ++i) {
    SobolIndex x;
    x.s1 = full.s1[i];
    x.st = full.st[i];
    if (full.variance > 0.0) {
      std::tie(x.s1_lo, x.s1_hi) = Interval(s1[i], confidence);
      std::tie(x.st_lo, x.st_hi) = Interval(st[i], confidence);
    } else {
      x.s1_lo = x.s1_hi = x.st_lo = x.st_hi = kNaN;
    }
    out.index.push_back(x);
  }
  return out;
}

double SpearmanCorrelation(const std::vector<double>& x, const std::vector<double>& y) {
  if (x.size() != y.size()) throw std::invalid_argument("SpearmanCorrelation: sizes differ");
  if (x.size() < 2) return kNaN;
  return Pearson(Ranks(x), Ranks(y));
}

const std::vector<std::string>& SweepOutputNames() {
  static const std::vector<std::string> names{"f_l", "t_f", "n_c", "n_e", "f_s"};
  return names;
}

namespace {

/// Runs one flight into `out` on a pooled world (queries recorded into `queries` when given).
/// Never throws.
void FlySweep(const Experiment& e, WorldPool& pool, const Opaque& map, const ParamValues& params,
              std::uint64_t seed, const std::atomic<bool>* cancel, std::vector<Opaque>* queries,
              SweepFlight& out) {
  out.flight_seed = seed;
  FlightRequest request;
  request.map = map;
  request.params = params;
  request.seed = seed;
  if (queries != nullptr) request.on_query = [queries](const Opaque& q) { queries->push_back(q); };
  if (cancel != nullptr) request.cancelled = [cancel] { return cancel->load(); };
  bool threw = false;
  const FlightRecord rec = FlyOnPool(e.planner, pool, request, &threw);
  if (threw && queries != nullptr) queries->clear();
  out.objective = LongTermObjective(rec, e.objective);
  out.status = rec.status;
  out.message = rec.message;
}

/// What a journal belongs to: the sweep's sizes, its seed and the experiment's text (FNV-1a).
nlohmann::json JournalHeader(const Experiment& e, const SweepOptions& o) {
  std::uint64_t h = 1469598103934665603ULL;
  for (const unsigned char c : e.text) h = (h ^ c) * 1099511628211ULL;
  return {{"quadtune_sweep_journal", 1}, {"points", o.points}, {"maps", o.maps},
          {"queries", o.queries}, {"seed", o.seed}, {"experiment", std::to_string(h)}};
}

/// The sweep's journal (SweepOptions::journal): finished flights ("f": point · K + map) and
/// re-solves ("r": slot) as JSON lines after a header; thread-safe appends.
class SweepJournal {
 public:
  SweepJournal(const std::string& path, const nlohmann::json& header) : path_(path) {
    if (PathExists(path)) Load(header);
    out_.open(path, std::ios::app);
    if (!out_) throw ConfigError(path, "journal", "cannot be written");
    if (!loaded_header_) Append(header);
  }
  const SweepFlight* Flight(long index) const {
    const auto it = flights_.find(index);
    return it == flights_.end() ? nullptr : &it->second;
  }
  const std::pair<ObjectiveValue, char>* Resolve(long slot) const {
    const auto it = resolves_.find(slot);
    return it == resolves_.end() ? nullptr : &it->second;
  }
  void RecordFlight(long index, const SweepFlight& f) {
    if (f.status == EvalStatus::kCancelled) return;
    Append({{"f", index}, {"v", f.objective.value}, {"t", f.objective.terms},
            {"s", ToString(f.status)}, {"m", f.message}});
  }
  void RecordResolve(long slot, const ObjectiveValue& v, char failed) {
    Append({{"r", slot}, {"v", v.value}, {"t", v.terms}, {"x", failed != 0}});
  }

 private:
  void Append(const nlohmann::json& line) {
    const std::lock_guard lock(mutex_);
    out_ << line.dump() << '\n';
    out_.flush();
  }
  void Load(const nlohmann::json& header) {
    std::ifstream in(path_);
    std::string text;
    int line_no = 0;
    while (std::getline(in, text)) {
      ++line_no;
      const nlohmann::json j = nlohmann::json::parse(text, nullptr, false);
      if (line_no == 1) {
        if (j != header) {
          throw ConfigError(path_, "--resume",
                            "the journal belongs to another sweep (" + text + "; this one is " +
                                header.dump() + ")");
        }
        loaded_header_ = true;
        continue;
      }
      if (j.is_discarded()) break;  // a line cut by the interruption: the rest is redone
      ObjectiveValue v;
      v.value = j.at("v").get<double>();
      v.terms = j.at("t").get<std::map<std::string, double>>();
      if (j.contains("f")) {
        SweepFlight f;
        f.objective = v;
        f.status = FromString<EvalStatus>(j.at("s").get<std::string>()).value_or(EvalStatus::kFailed);
        f.message = j.at("m").get<std::string>();
        flights_[j.at("f").get<long>()] = f;
      } else {
        resolves_[j.at("r").get<long>()] = {v, static_cast<char>(j.at("x").get<bool>() ? 1 : 0)};
      }
    }
  }

  std::string path_;
  bool loaded_header_ = false;
  std::map<long, SweepFlight> flights_;
  std::map<long, std::pair<ObjectiveValue, char>> resolves_;
  std::mutex mutex_;
  std::ofstream out_;
};

/// Waits for `group`, reporting progress about twice a second.
void WaitReporting(Scheduler& scheduler, TaskGroup& group, const SweepOptions& o,
                   const std::atomic<int>& flights, int flights_total,
                   const std::atomic<long>& resolves, long resolves_total, Clock::time_point t0) {
  const auto report = [&] {
    if (!o.on_progress) return;
    SweepProgress p;
    p.flights_done = flights.load();
    p.flights_total = flights_total;
    p.resolves_done = resolves.load();
    p.resolves_total = resolves_total;
    p.elapsed_s = std::chrono::duration<double>(Clock::now() - t0).count();
    o.on_progress(p);
  };
  auto last = Clock::now();
  while (!group.Done()) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    if (o.cancel != nullptr && o.cancel->load()) scheduler.Cancel();
    if (Clock::now() - last >= std::chrono::milliseconds(500)) {
      last = Clock::now();
      report();
    }
  }
  scheduler.Wait(group);
  report();
}

}  // namespace

namespace {

/// Step 1: the planning queries of one flight at the defaults on each map, in map order.
std::vector<Opaque> RecordQueries(const Experiment& e, const SweepOptions& o, Scheduler& scheduler,
                                  WorldPool& pool, const std::vector<Opaque>& maps,
                                  const ParamValues& defaults) {
  const auto k_maps = maps.size();
  std::vector<std::vector<Opaque>> recorded(k_maps);
  TaskGroup group;
  std::vector<SweepFlight> rec(k_maps);
  for (std::size_t ku = 0; ku < k_maps; ++ku) {
    const auto k = static_cast<int>(ku);
    scheduler.Submit(group, Priority::kFlight, [&, k, ku] {
      FlySweep(e, pool, maps[ku], defaults,
               DeriveSeed(o.seed, {0xde, static_cast<std::uint64_t>(k)}), o.cancel, &recorded[ku],
               rec[ku]);
    });
  }
  scheduler.Wait(group);
  std::vector<Opaque> all;
  for (const auto& r : recorded) all.insert(all.end(), r.begin(), r.end());
  return all;
}

/// A seeded partial Fisher–Yates draw of `count` of `queries`, kept in recording order.
std::vector<Opaque> DrawQueries(const std::vector<Opaque>& queries, int count, std::uint64_t seed) {
  std::vector<std::size_t> idx(queries.size());
  for (std::size_t i = 0; i < idx.size(); ++i) idx[i] = i;
  const std::size_t q = std::min(idx.size(), static_cast<std::size_t>(count));
  Rng rng(seed);
  for (std::size_t i = 0; i < q; ++i) {
    const auto j = static_cast<std::size_t>(
        UniformInt(rng, static_cast<std::int64_t>(i), static_cast<std::int64_t>(idx.size()) - 1));
    std::swap(idx[i], idx[j]);
  }
  idx.resize(q);
  std::sort(idx.begin(), idx.end());
  std::vector<Opaque> chosen;
  for (std::size_t i : idx) chosen.push_back(queries[i]);
  return chosen;
}

/// Step 2: the design points into result.points; returns the distinct θ_s among them, and the
/// index into those of every point in *short_of_point.
std::vector<ParamValues> DesignPoints(const Experiment& e, const SaltelliDesign& design,
                                      SweepResult& result, std::vector<int>* short_of_point) {
  const int points = design.Points();
  result.points.resize(static_cast<std::size_t>(points));
  std::map<std::vector<double>, int> short_index;
  std::vector<ParamValues> short_values;
  short_of_point->assign(static_cast<std::size_t>(points), 0);
  for (int p = 0; p < points; ++p) {
    SweepPoint& pt = result.points[static_cast<std::size_t>(p)];
    pt.block = design.Block(p);
    pt.row = design.Row(p);
    pt.params = e.space.ToNamed(e.space.FromUnit(design.Point(p)));
    std::vector<double> key;
    ParamValues theta_s;
    for (const auto& name : e.short_names) {
      key.push_back(pt.params.at(name));
      theta_s[name] = pt.params.at(name);
    }
    const auto [it, inserted] = short_index.emplace(key, static_cast<int>(short_values.size()));
    if (inserted) short_values.push_back(theta_s);
    (*short_of_point)[static_cast<std::size_t>(p)] = it->second;
  }
  return short_values;
}

/// Step 3's flights: every design point on every map, into result.flights (sized here).
void SubmitFlights(const Experiment& e, const SweepOptions& o, Scheduler& scheduler,
                   TaskGroup& group, WorldPool& pool, const std::vector<Opaque>& maps,
                   const ParamValues& defaults, std::atomic<int>& flights_done,
                   SweepJournal* journal, SweepResult& result) {
  const int points = static_cast<int>(result.points.size());
  const int k_maps = static_cast<int>(maps.size());
  result.flights.resize(static_cast<std::size_t>(points * k_maps));
  for (int p = 0; p < points; ++p) {
    ParamValues params = defaults;
    for (const auto& [name, v] : result.points[static_cast<std::size_t>(p)].params)
      params[name] = v;
    for (int k = 0; k < k_maps; ++k) {
      SweepFlight* out = &result.flights[static_cast<std::size_t>(p * k_maps + k)];
      out->point = p;
      out->map = k;
      out->map_seed = result.map_seeds[static_cast<std::size_t>(k)];
      const std::uint64_t seed =
          DeriveSeed(o.seed, {0xf1, static_cast<std::uint64_t>(p), static_cast<std::uint64_t>(k)});
      const Opaque* map = &maps[static_cast<std::size_t>(k)];
      const long index = static_cast<long>(p) * k_maps + k;
      if (const SweepFlight* done = journal != nullptr ? journal->Flight(index) : nullptr) {
        out->objective = done->objective;
        out->status = done->status;
        out->message = done->message;
        out->flight_seed = seed;
        flights_done.fetch_add(1);
        continue;
      }
      scheduler.Submit(group, Priority::kFlight, [&, out, params, seed, map, index] {
        FlySweep(e, pool, *map, params, seed, o.cancel, nullptr, *out);
        if (journal != nullptr) journal->RecordFlight(index, *out);
        flights_done.fetch_add(1);
      });
    }
  }
}

/// Step 3's re-solves: every distinct θ_s on every query; slot s·Q + j of `solved` and
/// `solve_failed` (sized by the caller) for θ_s s and query j.
void SubmitResolves(const Experiment& e, Scheduler& scheduler, TaskGroup& group,
                    const std::vector<Opaque>& queries,
                    const std::vector<ParamValues>& short_values,
                    std::vector<ObjectiveValue>& solved, std::vector<char>& solve_failed,
                    std::atomic<long>& resolves_done, SweepJournal* journal) {
  const std::size_t q = queries.size();
  for (std::size_t s = 0; s < short_values.size(); ++s) {
    for (std::size_t j = 0; j < q; ++j) {
      const std::size_t slot = s * q + j;
      if (const auto* done = journal != nullptr ? journal->Resolve(static_cast<long>(slot)) : nullptr) {
        solved[slot] = done->first;
        solve_failed[slot] = done->second;
        resolves_done.fetch_add(1);
        continue;
      }
      scheduler.Submit(group, Priority::kShort, [&, s, j, slot] {
        ResolveRecord rec;
        try {
          rec = e.planner.Resolve(queries[j], short_values[s]);
        } catch (const std::exception& ex) {
          rec = ResolveRecord{};
          rec.status = EvalStatus::kFailed;
          rec.message = std::string("exception: ") + ex.what();
        }
        solved[slot] = ShortTermObjective(rec, e.objective, e.mode);
        solve_failed[slot] = rec.status != EvalStatus::kOk ? 1 : 0;
        const bool cancelled = rec.status == EvalStatus::kCancelled;
        if (journal != nullptr && !cancelled) {
          journal->RecordResolve(static_cast<long>(slot), solved[slot], solve_failed[slot]);
        }
        resolves_done.fetch_add(1);
      });
    }
  }
}

/// Step 4: per-point means over the maps and the queries, in index order.
void AveragePerPoint(const Experiment& e, int k_maps, std::size_t q,
                     const std::vector<int>& short_of_point,
                     const std::vector<ObjectiveValue>& solved,
                     const std::vector<char>& solve_failed, SweepResult& result) {
  for (std::size_t p = 0; p < result.points.size(); ++p) {
    SweepPoint& pt = result.points[p];
    for (int k = 0; k < k_maps; ++k) {
      const SweepFlight& f =
          result.flights[p * static_cast<std::size_t>(k_maps) + static_cast<std::size_t>(k)];
      pt.f_l += f.objective.value / k_maps;
      for (const auto& [name, v] : f.objective.terms) pt.terms[name] += v / k_maps;
      if (f.status != EvalStatus::kOk) ++pt.failed_flights;
    }
    const auto s = static_cast<std::size_t>(short_of_point[p]);
    if (q == 0) {
      pt.f_s = e.objective.failure_value;
    }
    for (std::size_t j = 0; j < q; ++j) {
      pt.f_s += solved[s * q + j].value / static_cast<double>(q);
      for (const auto& [name, v] : solved[s * q + j].terms) {
        pt.short_terms[name] += v / static_cast<double>(q);
      }
      pt.failed_resolves += solve_failed[s * q + j];
    }
  }
}

/// Each candidate short-term score (f_s and its terms) against f_l: over every point, and as
/// changes between each base row A and its AB_i for the short-term parameters i.
std::vector<ShortTermAgreement> ShortTermAgreements(const SweepResult& r,
                                                    const std::vector<bool>& is_short) {
  std::vector<std::string> names{"f_s"};
  if (!r.points.empty()) {
    for (const auto& [name, v] : r.points.front().short_terms) names.push_back(name);
  }
  const auto score = [](const SweepPoint& pt, const std::string& name) {
    if (name == "f_s") return pt.f_s;
    const auto it = pt.short_terms.find(name);
    return it == pt.short_terms.end() ? 0.0 : it->second;
  };
  std::map<std::pair<int, int>, const SweepPoint*> by_block_row;
  for (const auto& pt : r.points) by_block_row[{pt.block, pt.row}] = &pt;
  std::vector<ShortTermAgreement> out;
  for (const auto& name : names) {
    ShortTermAgreement a;
    a.name = name;
    std::vector<double> s_all, l_all, ds, dl;
    for (const auto& pt : r.points) {
      s_all.push_back(score(pt, name));
      l_all.push_back(pt.f_l);
    }
    a.spearman = SpearmanCorrelation(s_all, l_all);
    for (const auto& pt : r.points) {
      const int i = pt.block - 2;  // AB_i: A with parameter i from B
      if (i < 0 || i >= static_cast<int>(is_short.size()) || !is_short[static_cast<std::size_t>(i)]) {
        continue;
      }
      const auto base = by_block_row.find({0, pt.row});
      if (base == by_block_row.end()) continue;
      ds.push_back(score(pt, name) - score(*base->second, name));
      dl.push_back(pt.f_l - base->second->f_l);
    }
    a.pairs = static_cast<int>(ds.size());
    a.spearman_short_changes =
        ds.size() >= 3 ? SpearmanCorrelation(ds, dl) : std::numeric_limits<double>::quiet_NaN();
    out.push_back(a);
  }
  return out;
}

/// Step 5: Sobol' indices of every output (n base rows, d parameters) and the rank correlation
/// of f_s and f_l.
void EstimateIndices(const SweepOptions& o, int n, int d, const std::vector<bool>& is_short,
                     SweepResult& result) {
  std::vector<double> f_l_all, f_s_all;
  for (const auto& pt : result.points) {
    f_l_all.push_back(pt.f_l);
    f_s_all.push_back(pt.f_s);
  }
  result.spearman_fs_fl = SpearmanCorrelation(f_s_all, f_l_all);
  result.agreement = ShortTermAgreements(result, is_short);
  for (std::size_t out_i = 0; out_i < SweepOutputNames().size(); ++out_i) {
    const std::string& name = SweepOutputNames()[out_i];
    const auto value = [&](int p) {
      const SweepPoint& pt = result.points[static_cast<std::size_t>(p)];
      if (name == "f_l") return pt.f_l;
      if (name == "f_s") return pt.f_s;
      const auto it = pt.terms.find(name);
      return it == pt.terms.end() ? 0.0 : it->second;
    };
    std::vector<double> f_a, f_b;
    std::vector<std::vector<double>> f_ab(static_cast<std::size_t>(d));
    for (int r = 0; r < n; ++r) {
      f_a.push_back(value(r));
      f_b.push_back(value(n + r));
      for (int i = 0; i < d; ++i)
        f_ab[static_cast<std::size_t>(i)].push_back(value((2 + i) * n + r));
    }
    result.outputs.push_back(
        {name,
         EstimateSobolIndices(f_a, f_b, f_ab, o.bootstrap,
                              DeriveSeed(o.seed, {0xb5, static_cast<std::uint64_t>(out_i)}))});
  }
}

}  // namespace

void CheckSweepOptions(const SweepOptions& o, int dims) {
  const auto bad = [](const char* key, const std::string& what) {
    throw ConfigError("", key, what);
  };
  if (o.points < 2) bad("--points", "need at least 2 base rows, got " + std::to_string(o.points));
  if (o.maps < 1) bad("--maps", "need at least 1 map, got " + std::to_string(o.maps));
  if (o.queries < 1) bad("--queries", "need at least 1 query, got " + std::to_string(o.queries));
  if (o.threads < 1) bad("--threads", "need at least 1 thread, got " + std::to_string(o.threads));
  if (o.bootstrap < 1)
    bad("--bootstrap", "need at least 1 resample, got " + std::to_string(o.bootstrap));
  // In double: N·(d+2)·K of ints is exact far past the limits and cannot overflow.
  const double points = static_cast<double>(o.points) * (static_cast<double>(dims) + 2.0);
  const auto size = [&](const char* key, int factor, const char* factor_key, double limit,
                        const char* what) {
    const double total = points * factor;
    if (total <= limit) return;
    std::ostringstream s;
    s << "got " << o.points << ": " << o.points << " × (" << dims << " parameters + 2) × "
      << factor_key << " " << factor << " = " << std::fixed << std::setprecision(0) << total
      << " " << what << " per layout; at most " << limit << " (a sweep queues every one at once "
      << "and keeps its result in memory): lower --points or " << factor_key;
    bad(key, s.str());
  };
  size("--points", o.maps, "--maps", kMaxSweepFlights, "flights");
  size("--points", o.queries, "--queries", kMaxSweepResolves, "re-solves");
}

SweepResult RunSweep(const Experiment& e, const SweepOptions& o) {
  CheckSweepOptions(o, e.space.Dim());
  const auto t0 = Clock::now();
  SweepResult result;
  result.names = e.space.Names();
  const int d = e.space.Dim();
  const int n = o.points;
  const int k_maps = o.maps;
  const SaltelliDesign design = MakeSaltelliDesign(n, d, DeriveSeed(o.seed, {0xde5}));
  const ParamValues defaults = e.Defaults();

  std::vector<Opaque> maps;
  for (int k = 0; k < k_maps; ++k) {
    result.map_seeds.push_back(DeriveSeed(o.seed, {0x3a, static_cast<std::uint64_t>(k)}));
    maps.push_back(e.planner.PrepareMap(result.map_seeds.back()));
  }

  Scheduler scheduler(o.threads);
  WorldPool pool;
  std::atomic<int> flights_done{0};
  std::atomic<long> resolves_done{0};

  // 1. Queries recorded at the defaults, one flight per map, and the Q used.
  const std::vector<Opaque> recorded = RecordQueries(e, o, scheduler, pool, maps, defaults);
  result.queries_recorded = static_cast<int>(recorded.size());
  const std::vector<Opaque> queries = DrawQueries(recorded, o.queries, DeriveSeed(o.seed, {0x9e}));
  result.queries_used = static_cast<int>(queries.size());

  // 2. The design points, and the distinct θ_s among them.
  std::vector<int> short_of_point;
  const std::vector<ParamValues> short_values = DesignPoints(e, design, result, &short_of_point);
  result.distinct_short = static_cast<int>(short_values.size());

  // 3. Every flight and every re-solve, concurrently (flights first).
  const std::size_t q = queries.size();
  std::vector<ObjectiveValue> solved(short_values.size() * q);
  std::vector<char> solve_failed(short_values.size() * q, 0);
  std::unique_ptr<SweepJournal> journal;
  if (!o.journal.empty()) {
    journal = std::make_unique<SweepJournal>(o.journal, JournalHeader(e, o));
  }
  TaskGroup group;
  SubmitFlights(e, o, scheduler, group, pool, maps, defaults, flights_done, journal.get(),
                result);
  SubmitResolves(e, scheduler, group, queries, short_values, solved, solve_failed, resolves_done,
                 journal.get());
  WaitReporting(scheduler, group, o, flights_done, design.Points() * k_maps, resolves_done,
                static_cast<long>(short_values.size() * q), t0);
  result.resolves = resolves_done.load();
  const bool cancelled = o.cancel != nullptr && o.cancel->load();

  // 4. Per-point means; 5. indices of every output.
  AveragePerPoint(e, k_maps, q, short_of_point, solved, solve_failed, result);
  result.wall_s = std::chrono::duration<double>(Clock::now() - t0).count();
  if (cancelled) {
    result.status = RunStatus::kCancelled;
    return result;
  }
  std::vector<bool> is_short;
  for (const auto& name : result.names) {
    is_short.push_back(std::find(e.short_names.begin(), e.short_names.end(), name) !=
                       e.short_names.end());
  }
  EstimateIndices(o, n, d, is_short, result);
  return result;
}

}  // namespace quadtune::engine
