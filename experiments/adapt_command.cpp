// `quadtune adapt`: the paper's changing-environment experiment (Sec. IV-B). One flight adapts
// v_des online (engine::OnlineAdapter); baselines fly the same map and seed with fixed v_des.
// Writes per-flight logs, a CSV along the path, every BO trial, a per-zone summary (JSON and
// Markdown) and a figure.
//
// Thread safety: runs on the main thread only.
#include <fmt/ranges.h>
#include <spdlog/spdlog.h>
#include <yaml-cpp/yaml.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <exception>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "commands.hpp"
#include "file_kind.hpp"
#include "limits.hpp"
#include "quadtune/common/cancel.hpp"
#include "quadtune/common/parallel_for.hpp"
#include "quadtune/common/text_file.hpp"
#include "quadtune/common/yaml.hpp"
#include "quadtune/engine/adaptation/corridor_study.hpp"
#include "quadtune/engine/adaptation/online_adaptation.hpp"
#include "quadtune/engine/distributed/distributed.hpp"
#include "quadtune/layout/layout.hpp"
#include "quadtune/sim/flight.hpp"
#include "result_dir.hpp"

namespace quadtune::cli {
namespace {

namespace fs = std::filesystem;

struct AdaptArgs {
  std::string experiment;
  std::string out = "results/adapt";
  std::optional<std::uint64_t> seed;
  bool plot = true;
  bool overwrite = false;        ///< replace the results already in OUT
  std::vector<std::string> set;  ///< --set KEY=VALUE edits of the experiment file
  int threads = 1;               ///< flights flown at once
  int corridors = 0;             ///< > 0: the corridor study over this many corridors
  std::string policy;            ///< a policy file replacing adaptation.policy (may be empty)
};

/// Per-zone statistics of one flight.
struct ZoneSummary {
  double time = 0.0;        // time spent in the zone (s)
  double v_des_sum = 0.0;   // Σ v_des in force · dt
  double speed_sum = 0.0;   // Σ speed · dt
  double chosen_sum = 0.0;  // Σ chosen v_des over adopted segments with P_s in the zone
  int adopted = 0;
  int segments = 0;
  int trials = 0;
  int failed_trials = 0;
};

/// path.csv: the state log along the path, with the v_des in force and the zone.
std::vector<ZoneSummary> WritePathCsv(const std::string& path, const engine::AdaptFlight& f,
                                      const layout::LayoutOptions& options) {
  std::vector<ZoneSummary> zones(options.zones.size());
  std::ofstream out(path);
  out.precision(9);
  out << "t,x,y,z,s,v_des,speed,zone,zone_spacing\n";
  const auto& log = f.result.log;
  double s = 0.0;
  for (std::size_t i = 0; i < log.size(); ++i) {
    const auto& r = log[i];
    if (i > 0) s += (r.p_W - log[i - 1].p_W).norm();
    const int z = engine::ZoneIndex(options, r.p_W.x());
    const double speed = r.v_W.norm();
    out << r.t << ',' << r.p_W.x() << ',' << r.p_W.y() << ',' << r.p_W.z() << ',' << s << ','
        << r.v_des << ',' << speed << ',' << z << ','
        << (z >= 0 ? options.zones[static_cast<std::size_t>(z)].spacing : 0.0) << '\n';
    if (z >= 0 && i + 1 < log.size()) {
      const double dt = log[i + 1].t - r.t;
      ZoneSummary& zs = zones[static_cast<std::size_t>(z)];
      zs.time += dt;
      zs.v_des_sum += r.v_des * dt;
      zs.speed_sum += speed * dt;
    }
  }
  for (const auto& seg : f.segments) {
    const int z = engine::ZoneIndex(options, seg.p_s_W.x());
    if (z < 0) continue;
    ZoneSummary& zs = zones[static_cast<std::size_t>(z)];
    ++zs.segments;
    if (seg.outcome == engine::AdaptationSegment::Outcome::kAdopted) {
      ++zs.adopted;
      zs.chosen_sum += seg.v_des;
    }
  }
  for (const auto& t : f.trials) {
    const int z = engine::ZoneIndex(options, t.p_s_W.x());
    if (z < 0) continue;
    ++zones[static_cast<std::size_t>(z)].trials;
    if (!t.success) ++zones[static_cast<std::size_t>(z)].failed_trials;
  }
  return zones;
}

void WriteTrialsCsv(const std::string& path, const engine::AdaptFlight& f,
                    const layout::LayoutOptions& options) {
  std::ofstream out(path);
  out.precision(9);
  out << "segment,trial,time,p_s_x,p_s_y,p_s_z,zone,v_des,success,status,t_exe,jerk_integral,"
         "min_clearance,J_c,J_r,from_policy,f_s,compute_units,chosen\n";
  for (const auto& t : f.trials) {
    out << t.segment << ',' << t.trial << ',' << t.time << ',' << t.p_s_W.x() << ',' << t.p_s_W.y()
        << ',' << t.p_s_W.z() << ',' << engine::ZoneIndex(options, t.p_s_W.x()) << ',' << t.v_des
        << ',' << (t.success ? 1 : 0) << ',' << t.status << ',' << t.t_exe << ',' << t.jerk_integral
        << ',' << t.min_clearance << ',' << t.j_c << ',' << t.j_r << ',' << (t.from_policy ? 1 : 0)
        << ',' << t.f_s << ',' << t.compute_units << ',' << (t.chosen ? 1 : 0) << '\n';
  }
}

void WriteSegmentsCsv(const std::string& path, const engine::AdaptFlight& f,
                      const layout::LayoutOptions& options) {
  std::ofstream out(path);
  out.precision(9);
  out << "segment,t0,split_time,p_s_x,p_s_y,p_s_z,zone,speed_s,free_range,policy_v_des,"
         "v_des_before,v_des,trials,successes,best_trial,best_f_s,outcome\n";
  for (const auto& s : f.segments) {
    out << s.index << ',' << s.t0 << ',' << s.split_time << ',' << s.p_s_W.x() << ',' << s.p_s_W.y()
        << ',' << s.p_s_W.z() << ',' << engine::ZoneIndex(options, s.p_s_W.x()) << ',' << s.speed_s
        << ',' << s.free_range << ',' << s.policy_v_des << ',' << s.v_des_before << ',' << s.v_des
        << ',' << s.trials << ',' << s.successes << ',' << s.best_trial << ',' << s.best_f_s << ','
        << quadtune::ToString(s.outcome) << '\n';
  }
}

double Ratio(double num, double den) { return den > 0.0 ? num / den : 0.0; }

std::atomic<bool> g_adapt_interrupted{false};
void OnAdaptSignal(int) { g_adapt_interrupted.store(true); }

engine::AdaptExperiment LoadAdaptRun(const AdaptArgs& a) {
  engine::CheckSingleProcessLaunch(engine::MpiLaunchSize(), "adapt");
  CheckFileKind(a.experiment, FileKind::kAdaptation);
  // --policy replaces adaptation.policy before the file is read (checked on its own first, so
  // that its errors name it), as if given by --set.
  std::vector<std::string> set = a.set;
  if (!a.policy.empty()) {
    const YamlMap policy = YamlMap::LoadFile(a.policy);
    (void)engine::ContextPolicy::FromYaml(policy);
    YAML::Emitter flow;
    flow << YAML::Flow << policy.node();
    set.push_back(std::string("adaptation.policy=") + flow.c_str());
  }
  engine::AdaptExperiment e = LoadAdaptExperiment(a.experiment, set);
  if (a.seed) e.SetSeed(*a.seed);
  CheckThreadsFitAddressSpace(a.threads, "", "--threads");
  return e;
}

void LogSegment(const layout::Layout& layout, const engine::AdaptationSegment& s) {
  const int z = engine::ZoneIndex(layout.options, s.p_s_W.x());
  // A context-mode segment plans no trials: its line ends with the outcome.
  const std::string trials = s.trials > 0 ? fmt::format(" ({}/{} trials ok, best f_s {:.2f})",
                                                        s.successes, s.trials, s.best_f_s)
                                          : std::string();
  spdlog::info(
      "segment {:3d} P_s x {:5.1f} m (zone {}): free range {:.2f} m, v_des {:.2f} -> {:.2f} m/s, "
      "{}{}",
      s.index, s.p_s_W.x(), z >= 0 ? fmt::format("{:.1f} m", layout.options.zones[z].spacing) : "-",
      s.free_range, s.v_des_before, s.v_des, quadtune::ToString(s.outcome), trials);
}

// Flies every policy on the one layout, up to `threads` at once; walls[i] gets each wall time.
std::vector<engine::AdaptFlight> FlyPolicies(const engine::AdaptExperiment& e,
                                             const layout::Layout& layout, int threads,
                                             std::vector<double>& walls) {
  const std::vector<engine::FlightPolicy> policies = engine::CorridorPolicies(e);
  std::vector<engine::AdaptFlight> flown(policies.size());
  walls.assign(policies.size(), 0.0);
  ParallelFor(std::max(1, threads), std::size_t{0}, policies.size(), [&](std::size_t i) {
    const auto start = std::chrono::steady_clock::now();
    flown[i] = engine::RunAdaptFlight(
        e, layout, policies[i], [&](const engine::AdaptationSegment& s) { LogSegment(layout, s); },
        &g_adapt_interrupted);
    walls[i] = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  });
  return flown;
}

nlohmann::json FlightJson(const engine::AdaptFlight& f, double wall,
                          const std::vector<ZoneSummary>& zones,
                          const layout::LayoutOptions& options) {
  const auto& m = f.result.metrics;
  nlohmann::json fj = {{"label", f.label},
                       {"adapted", f.adapted},
                       {"v_des", f.v_des},
                       {"status", sim::ToString(m.status)},
                       {"message", m.message},
                       {"flight_time", m.flight_time},
                       {"collisions", m.collisions},
                       {"emergency_stops", m.emergency_stops},
                       {"mean_speed", m.mean_speed},
                       {"max_speed", m.max_speed},
                       {"distance", m.distance},
                       {"min_clearance", m.min_clearance},
                       {"jerk_integral", m.jerk_integral},
                       {"plans", m.plans},
                       {"failed_plans", m.failed_plans},
                       {"segments", f.segments.size()},
                       {"trials", f.trials.size()},
                       {"wall_s", wall},
                       {"directory", f.label}};
  for (std::size_t i = 0; i < zones.size(); ++i) {
    const ZoneSummary& z = zones[i];
    nlohmann::json zj = {{"zone", i},
                         {"spacing", options.zones[i].spacing},
                         {"time", z.time},
                         {"mean_v_des", Ratio(z.v_des_sum, z.time)},
                         {"mean_speed", Ratio(z.speed_sum, z.time)}};
    if (f.adapted) {
      zj["mean_chosen_v_des"] = Ratio(z.chosen_sum, z.adopted);
      zj["segments"] = z.segments;
      zj["adopted"] = z.adopted;
      zj["trials"] = z.trials;
      zj["failed_trials"] = z.failed_trials;
    }
    fj["zones"].push_back(zj);
  }
  return fj;
}

// The finding to check: lower v_des in the dense zones than in the sparse ones (mean chosen
// v_des over the adopted segments of the first flight, by zone).
void AddFinding(nlohmann::json& summary, const std::vector<ZoneSummary>& adapted_zones,
                const layout::LayoutOptions& options, double dense_below) {
  double dense = 0.0, sparse = 0.0;
  int n_dense = 0, n_sparse = 0;
  for (std::size_t i = 0; i < adapted_zones.size(); ++i) {
    const ZoneSummary& z = adapted_zones[i];
    if (z.adopted == 0) continue;
    const double v = z.chosen_sum / z.adopted;
    const bool is_dense = options.zones[i].spacing < dense_below;
    (is_dense ? dense : sparse) += v;
    ++(is_dense ? n_dense : n_sparse);
  }
  if (n_dense > 0 && n_sparse > 0) {
    summary["finding"] = {{"dense_below", dense_below},
                          {"dense_mean_chosen_v_des", dense / n_dense},
                          {"sparse_mean_chosen_v_des", sparse / n_sparse},
                          {"lower_in_dense", dense / n_dense < sparse / n_sparse}};
  }
}

void WriteSummaryMd(const std::string& path, const engine::AdaptExperiment& e,
                    const layout::Layout& layout, const std::vector<engine::AdaptFlight>& flights,
                    const std::vector<std::vector<ZoneSummary>>& zone_tables,
                    const nlohmann::json& summary, double wall) {
  std::ofstream md(path);
  md << "# " << e.name << ": online v_des adaptation (seed " << e.seed << ")\n\n";
  md << "Mean v_des in force / mean actual speed (m/s), time-weighted, per zone (mean obstacle "
        "spacing).\n\n| flight | status | t_f (s) | collisions | emergency stops |";
  for (const auto& z : layout.options.zones) md << fmt::format(" {:.1f} m |", z.spacing);
  md << "\n|---|---|---|---|---|";
  for (std::size_t i = 0; i < layout.options.zones.size(); ++i) md << "---|";
  md << '\n';
  for (std::size_t k = 0; k < flights.size(); ++k) {
    const auto& m = flights[k].result.metrics;
    md << fmt::format("| {} | {} | {:.2f} | {} | {} |", flights[k].label, sim::ToString(m.status),
                      m.flight_time, m.collisions, m.emergency_stops);
    for (const auto& z : zone_tables[k]) {
      md << fmt::format(" {:.2f} / {:.2f} |", Ratio(z.v_des_sum, z.time),
                        Ratio(z.speed_sum, z.time));
    }
    md << '\n';
  }
  md << "\nAdapted flight per zone (segments by the zone of P_s):\n\n"
        "| zone spacing (m) | segments | adopted | mean chosen v_des (m/s) | trials | failed "
        "trials |\n|---|---|---|---|---|---|\n";
  const auto& adapted_zones = zone_tables.front();
  for (std::size_t i = 0; i < adapted_zones.size(); ++i) {
    const ZoneSummary& z = adapted_zones[i];
    md << fmt::format("| {:.1f} | {} | {} | {:.2f} | {} | {} |\n", layout.options.zones[i].spacing,
                      z.segments, z.adopted, Ratio(z.chosen_sum, z.adopted), z.trials,
                      z.failed_trials);
  }
  if (summary.contains("finding")) {
    md << fmt::format(
        "\nMean chosen v_des: dense zones (< {:.1f} m) {:.2f} m/s, sparse zones "
        "{:.2f} m/s.\n",
        e.dense_below, summary["finding"]["dense_mean_chosen_v_des"].get<double>(),
        summary["finding"]["sparse_mean_chosen_v_des"].get<double>());
  }
  md << fmt::format("\nWall time {:.1f} s.\n", wall);
}

nlohmann::json SummaryHead(const AdaptArgs& a, const engine::AdaptExperiment& e,
                           const layout::Layout& layout) {
  nlohmann::json summary;
  summary["experiment"] = e.name;
  summary["file"] = a.experiment;
  summary["seed"] = e.seed;
  summary["lookahead"] = e.adaptation.lookahead;
  summary["v_des_bounds"] = {e.adaptation.v_min, e.adaptation.v_max};
  summary["trials_per_segment"] = e.adaptation.trials_per_segment;
  summary["mode"] = quadtune::ToString(e.adaptation.mode);
  summary["risk_weight"] = e.adaptation.risk_weight;
  for (std::size_t i = 0; i < layout.options.zones.size(); ++i) {
    const auto& z = layout.options.zones[i];
    summary["zones"].push_back(
        {{"index", i},
         {"x_min", z.x_min},
         {"x_max", z.x_max},
         {"spacing", z.spacing},
         {"achieved", i < layout.stats.zones.size() ? layout.stats.zones[i].spacing.mean : 0.0}});
  }
  return summary;
}

void LogLayout(const AdaptArgs& a, const engine::AdaptExperiment& e, const layout::Layout& layout) {
  spdlog::info(
      "adapt '{}' ({}): planner {}, {} obstacles over {:.0f} m, {} zones, seed {}, mode {}, "
      "R {:.1f} m, v_des in [{}, {}], {} trials per segment, baselines {}",
      e.name, a.experiment, e.planner_type, layout.obstacles.size(),
      layout.goal_W().x() - layout.start_W().x(), layout.options.zones.size(), e.seed,
      quadtune::ToString(e.adaptation.mode), e.adaptation.lookahead, e.adaptation.v_min,
      e.adaptation.v_max, e.adaptation.trials_per_segment, fmt::join(e.baselines, ", "));
  for (const auto& z : layout.stats.zones) {
    spdlog::info(
        "  zone x in [{:.1f}, {:.1f}] m: target spacing {:.2f} m, achieved centre "
        "spacing {:.3f} m, free gap {:.3f} m",
        z.x_min, z.x_max, z.target_spacing, z.spacing.mean, z.gap.mean);
  }
}

int RunAdaptOneMap(const AdaptArgs& a, const engine::AdaptExperiment& e) {
  const auto wall_start = std::chrono::steady_clock::now();
  const layout::Layout layout = layout::GenerateLayout(e.layout, e.seed);
  layout.Save((fs::path(a.out) / "layout.yaml").string());
  LogLayout(a, e, layout);
  std::vector<double> walls;
  std::vector<engine::AdaptFlight> flights = FlyPolicies(e, layout, a.threads, walls);
  if (g_adapt_interrupted.load()) {
    spdlog::error("adapt interrupted; no flight written");
    return 130;
  }
  nlohmann::json summary = SummaryHead(a, e, layout);
  std::vector<std::vector<ZoneSummary>> zone_tables;
  for (std::size_t run = 0; run < flights.size(); ++run) {
    const engine::AdaptFlight& f = flights[run];
    const auto& m = f.result.metrics;
    const std::string dir = (fs::path(a.out) / f.label).string();
    sim::WriteFlightFiles(dir, f.result, layout.obstacles,
                          sim::Mission::GoTo(layout.start_W(), layout.goal_W()));
    zone_tables.push_back(WritePathCsv((fs::path(dir) / "path.csv").string(), f, layout.options));
    if (f.adapted) {
      WriteTrialsCsv((fs::path(dir) / "trials.csv").string(), f, layout.options);
      WriteSegmentsCsv((fs::path(dir) / "segments.csv").string(), f, layout.options);
    }
    spdlog::info(
        "{}: {}, t_f {:.2f} s, collisions {}, emergency stops {}, mean speed {:.2f} "
        "m/s, {} segments, {} trials ({:.1f} s wall)",
        f.label, sim::ToString(m.status), m.flight_time, m.collisions, m.emergency_stops,
        m.mean_speed, f.segments.size(), f.trials.size(), walls[run]);
    summary["flights"].push_back(FlightJson(f, walls[run], zone_tables.back(), layout.options));
  }
  AddFinding(summary, zone_tables.front(), layout.options, e.dense_below);
  const double wall =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  summary["wall_s"] = wall;
  std::ofstream(fs::path(a.out) / "summary.json") << summary.dump(1) << '\n';
  WriteSummaryMd((fs::path(a.out) / "summary.md").string(), e, layout, flights, zone_tables,
                 summary, wall);
  spdlog::info("wrote {}/summary.json, summary.md and one directory per flight ({:.1f} s)", a.out,
               wall);
  if (a.plot) {
    if (RunPlotScript("adapt '" + a.out + "'") != 0) return 1;
    spdlog::info("figure: {}/adapt.png", a.out);
  }
  return 0;
}

void WriteCorridorsCsv(const std::string& path, const std::vector<engine::CorridorFlight>& rows) {
  std::ofstream out(path);
  out.precision(9);
  out << "corridor_seed,policy,f_l,flight_time,collisions,emergency_stops,status,mean_speed,"
         "v_des_dense,v_des_sparse,segments\n";
  for (const auto& r : rows) {
    out << r.corridor_seed << ',' << r.policy << ',' << r.f_l << ',' << r.flight_time << ','
        << r.collisions << ',' << r.emergency_stops << ',' << r.status << ',' << r.mean_speed << ','
        << r.v_des_dense << ',' << r.v_des_sparse << ',' << r.segments << '\n';
  }
}

void WriteCorridorsMd(const std::string& path, const engine::AdaptExperiment& e,
                      const std::vector<engine::CorridorFlight>& rows,
                      const engine::CorridorComparison& c, int count, double wall) {
  std::ofstream md(path);
  md << "# " << e.name << ": " << count << " corridors of changing density\n\n"
     << "f_l = t_f + t_f·n_c + " << e.w_e << "·n_e per flight (" << e.failure_value
     << " when it does not finish). Best fixed: the baseline v_des with the lowest mean f_l on "
        "the other corridors (leave-one-out), flown on this one. v_des dense / sparse: "
        "time-weighted v_des in force over zones of spacing below / from "
     << e.dense_below
     << " m.\n\n| corridor seed | policy | f_l | t_f (s) | collisions | "
        "emergency stops | v_des dense / sparse (m/s) |\n|---|---|---|---|---|---|---|\n";
  for (const auto& r : rows) {
    md << fmt::format("| {} | {} | {:.2f} | {:.2f} | {} | {} | {:.2f} / {:.2f} |\n",
                      r.corridor_seed, r.policy, r.f_l, r.flight_time, r.collisions,
                      r.emergency_stops, r.v_des_dense, r.v_des_sparse);
  }
  md << "\n| corridor seed | best fixed (chosen on the others) | its f_l | its collisions |\n"
        "|---|---|---|---|\n";
  for (const auto& v : c.corridors) {
    md << fmt::format("| {} | {} | {:.2f} | {} |\n", v.corridor_seed, v.best_fixed,
                      v.best_fixed_f_l, v.best_fixed_collisions);
  }
  md << fmt::format(
      "\n| policy | mean f_l | collisions | v_des lower in dense zones |\n"
      "|---|---|---|---|\n| best fixed (leave-one-out) | {:.2f} | {} | – |\n",
      c.best_fixed_mean_f_l, c.best_fixed_collisions);
  for (const auto& a : c.adaptive) {
    md << fmt::format("| {} | {:.2f} | {} | {} of {} |\n", a.policy, a.mean_f_l, a.collisions,
                      a.lower_in_dense, a.corridors);
  }
  md << fmt::format("\nWall time {:.0f} s.\n", wall);
}

int RunCorridorCommand(const AdaptArgs& a, const engine::AdaptExperiment& e) {
  const auto start = std::chrono::steady_clock::now();
  engine::CorridorOptions options;
  options.first_seed = e.seed;
  options.count = a.corridors;
  options.threads = a.threads;
  spdlog::info("adapt '{}': {} corridors (seeds {} … {}), policies adapted ({}){}, fixed {}",
               e.name, a.corridors, e.seed, e.seed + a.corridors - 1,
               quadtune::ToString(e.adaptation.mode),
               engine::CorridorPolicies(e).size() > e.baselines.size() + 1 ? ", context" : "",
               fmt::join(e.baselines, ", "));
  std::vector<engine::CorridorFlight> rows;
  try {
    rows = engine::RunCorridors(
        e, options,
        [&](const engine::CorridorFlight& r, int done, int total) {
          const double elapsed =
              std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
          spdlog::info(
              "corridor {} {}: f_l {:.2f}, t_f {:.2f} s, collisions {}, v_des dense "
              "{:.2f} / sparse {:.2f} m/s ({}/{} flights, ETA {:.0f} s)",
              r.corridor_seed, r.policy, r.f_l, r.flight_time, r.collisions, r.v_des_dense,
              r.v_des_sparse, done, total, elapsed / done * (total - done));
        },
        &g_adapt_interrupted);
  } catch (const Cancelled&) {
    spdlog::error("adapt interrupted; no corridor table written");
    return 130;
  }
  const engine::CorridorComparison c = engine::CompareCorridors(rows);
  const double wall =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  WriteCorridorsCsv((fs::path(a.out) / "corridors.csv").string(), rows);
  WriteCorridorsMd((fs::path(a.out) / "corridors.md").string(), e, rows, c, a.corridors, wall);
  spdlog::info("best fixed (leave-one-out): mean f_l {:.2f}, {} collisions", c.best_fixed_mean_f_l,
               c.best_fixed_collisions);
  for (const auto& ad : c.adaptive) {
    spdlog::info("{}: mean f_l {:.2f}, {} collisions, v_des lower in dense zones on {} of {}",
                 ad.policy, ad.mean_f_l, ad.collisions, ad.lower_in_dense, ad.corridors);
  }
  spdlog::info("wrote {}/corridors.csv and corridors.md ({:.0f} s)", a.out, wall);
  return 0;
}

int RunAdapt(const AdaptArgs& a) {
  const engine::AdaptExperiment e = LoadAdaptRun(a);
  const ResultDir out_dir(a.out, ResultDirPolicy{false, a.overwrite, false});
  // SIGINT/SIGTERM end every flight at its next tick: nothing is written, exit 130.
  std::signal(SIGINT, OnAdaptSignal);
  std::signal(SIGTERM, OnAdaptSignal);
  if (a.corridors > 0) return RunCorridorCommand(a, e);
  return RunAdaptOneMap(a, e);
}

}  // namespace

engine::AdaptExperiment LoadAdaptExperiment(const std::string& path,
                                            const std::vector<std::string>& sets) {
  const std::string dir_of_file = fs::path(path).parent_path().string();
  try {
    return engine::AdaptExperiment::FromString(ApplyAssignments(ReadFileText(path), sets, path),
                                               path, dir_of_file.empty() ? "." : dir_of_file);
  } catch (const ConfigError& error) {
    BlameSet(error, sets);  // a typo in a --set key is the option's fault
    throw;
  }
}

void RegisterAdapt(CLI::App& app, int& exit_code) {
  static AdaptArgs args;
  auto* cmd = app.add_subcommand(
      "adapt",
      "changing-environment experiment: adapt v_des online by BO (paper Sec. IV-B) and "
      "compare with fixed v_des");
  cmd->add_option("experiment", args.experiment, "experiment file (YAML)")->required();
  cmd->add_option("--out", args.out, "output directory")->capture_default_str();
  cmd->add_option("--seed", args.seed, "seed of the layout, the world and BO (default: the file's)")
      ->check(SeedValidator());
  cmd->add_option("--threads", args.threads,
                  "flights flown at once (the adapted flight and each baseline)")
      ->capture_default_str()
      ->check(CountIn(1, engine::kMaxThreads, kThreadsWhy));
  cmd->add_option("--set", args.set,
                  "KEY=VALUE: change the experiment file's dotted KEY, e.g. --set "
                  "adaptation.trials_per_segment=4 --set 'baselines=[2.0]' (repeatable)");
  AddNoPlotFlag(*cmd, args.plot, "skip the figure");
  cmd->add_option("--policy", args.policy,
                  "context policy file (as `quadtune policy` writes it) replacing the experiment "
                  "file's adaptation.policy");
  cmd->add_flag("--overwrite", args.overwrite, "replace the results already in OUT");
  cmd->add_option("--corridors", args.corridors,
                  "fly N corridors (seeds SEED … SEED + N − 1) with every policy and write "
                  "corridors.csv and corridors.md instead of one map's flights")
      ->check(CountIn(1, 10000, "corridors"));
  cmd->callback([&exit_code] { exit_code = RunAdapt(args); });
}

}  // namespace quadtune::cli
