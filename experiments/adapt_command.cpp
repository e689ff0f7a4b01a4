// `quadtune adapt`: the paper's changing-environment experiment (Sec. IV-B). One flight adapts
// v_des online (engine::OnlineAdapter); baselines fly the same map and seed with fixed v_des.
// Writes per-flight logs, a CSV along the path, every BO trial, a per-zone summary (JSON and
// Markdown) and a figure.
//
// Thread safety: runs on the main thread only.
#include <fmt/ranges.h>
#include <spdlog/spdlog.h>

#include <atomic>
#include <csignal>
#include <chrono>
#include <exception>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "file_kind.hpp"
#include "commands.hpp"
#include "limits.hpp"
#include "result_dir.hpp"
#include "quadtune/common/text_file.hpp"
#include "quadtune/common/yaml.hpp"
#include "quadtune/engine/distributed.hpp"
#include "quadtune/engine/online_adaptation.hpp"
#include "quadtune/layout/layout.hpp"
#include "quadtune/sim/flight.hpp"

namespace quadtune::cli {
namespace {

namespace fs = std::filesystem;

struct AdaptArgs {
  std::string experiment;
  std::string out = "results/adapt";
  std::optional<std::uint64_t> seed;
  bool plot = true;
  bool overwrite = false;  ///< replace the results already in OUT
  std::vector<std::string> set;  ///< --set KEY=VALUE edits of the experiment file
  int threads = 1;               ///< flights flown at once
};

/// Index of the zone holding x (the last zone also takes its upper end), or -1.
int ZoneOf(const layout::LayoutOptions& options, double x) {
  const auto& zones = options.zones;
  for (std::size_t i = 0; i < zones.size(); ++i) {
    const bool last = i + 1 == zones.size();
    if (x >= zones[i].x_min && (x < zones[i].x_max || (last && x <= zones[i].x_max))) {
      return static_cast<int>(i);
    }
  }
  return -1;
}

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
    const int z = ZoneOf(options, r.p_W.x());
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
    const int z = ZoneOf(options, seg.p_s_W.x());
    if (z < 0) continue;
    ZoneSummary& zs = zones[static_cast<std::size_t>(z)];
    ++zs.segments;
    if (seg.outcome == engine::AdaptationSegment::Outcome::kAdopted) {
      ++zs.adopted;
      zs.chosen_sum += seg.v_des;
    }
  }
  for (const auto& t : f.trials) {
    const int z = ZoneOf(options, t.p_s_W.x());
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
         "min_clearance,J_c,f_s,compute_units,chosen\n";
  for (const auto& t : f.trials) {
    out << t.segment << ',' << t.trial << ',' << t.time << ',' << t.p_s_W.x() << ','
        << t.p_s_W.y() << ',' << t.p_s_W.z() << ',' << ZoneOf(options, t.p_s_W.x()) << ','
        << t.v_des << ',' << (t.success ? 1 : 0) << ',' << t.status << ',' << t.t_exe << ','
        << t.jerk_integral << ',' << t.min_clearance << ',' << t.j_c << ',' << t.f_s << ','
        << t.compute_units << ',' << (t.chosen ? 1 : 0) << '\n';
  }
}

void WriteSegmentsCsv(const std::string& path, const engine::AdaptFlight& f,
                      const layout::LayoutOptions& options) {
  std::ofstream out(path);
  out.precision(9);
  out << "segment,t0,split_time,p_s_x,p_s_y,p_s_z,zone,speed_s,v_des_before,v_des,trials,"
         "successes,best_trial,best_f_s,outcome\n";
  for (const auto& s : f.segments) {
    out << s.index << ',' << s.t0 << ',' << s.split_time << ',' << s.p_s_W.x() << ','
        << s.p_s_W.y() << ',' << s.p_s_W.z() << ',' << ZoneOf(options, s.p_s_W.x()) << ','
        << s.speed_s << ',' << s.v_des_before << ',' << s.v_des << ',' << s.trials << ','
        << s.successes << ',' << s.best_trial << ',' << s.best_f_s << ','
        << quadtune::ToString(s.outcome) << '\n';
  }
}

double Ratio(double num, double den) { return den > 0.0 ? num / den : 0.0; }

std::atomic<bool> g_adapt_interrupted{false};
void OnAdaptSignal(int) { g_adapt_interrupted.store(true); }

int RunAdapt(const AdaptArgs& a) {
  engine::CheckSingleProcessLaunch(engine::MpiLaunchSize(), "adapt");
  CheckFileKind(a.experiment, FileKind::kAdaptation);
  const auto wall_start = std::chrono::steady_clock::now();
  const std::string dir_of_file = fs::path(a.experiment).parent_path().string();
  engine::AdaptExperiment e = engine::AdaptExperiment::FromString(
      ApplyAssignments(ReadFileText(a.experiment), a.set, a.experiment), a.experiment,
      dir_of_file.empty() ? "." : dir_of_file);
  if (a.seed) e.SetSeed(*a.seed);
  CheckThreadsFitAddressSpace(a.threads, "", "--threads");
  const ResultDir out_dir(a.out, ResultDirPolicy{false, a.overwrite, false});
  const layout::Layout layout = layout::GenerateLayout(e.layout, e.seed);
  layout.Save((fs::path(a.out) / "layout.yaml").string());
  spdlog::info(
      "adapt '{}' ({}): planner {}, {} obstacles over {:.0f} m, {} zones, seed {}, "
      "R {:.1f} m, v_des in [{}, {}], {} trials per segment, baselines {}",
      e.name, a.experiment, e.planner_type, layout.obstacles.size(),
      layout.goal_W().x() - layout.start_W().x(), layout.options.zones.size(), e.seed,
      e.adaptation.lookahead, e.adaptation.v_min, e.adaptation.v_max,
      e.adaptation.trials_per_segment, fmt::join(e.baselines, ", "));
  for (const auto& z : layout.stats.zones) {
    spdlog::info("  zone x in [{:.1f}, {:.1f}] m: target spacing {:.2f} m, achieved {:.3f} m",
                 z.x_min, z.x_max, z.target_spacing, z.spacing.mean);
  }

  std::vector<std::optional<double>> runs{std::nullopt};
  for (double v : e.baselines) runs.emplace_back(v);
  nlohmann::json summary;
  summary["experiment"] = e.name;
  summary["file"] = a.experiment;
  summary["seed"] = e.seed;
  summary["lookahead"] = e.adaptation.lookahead;
  summary["v_des_bounds"] = {e.adaptation.v_min, e.adaptation.v_max};
  summary["trials_per_segment"] = e.adaptation.trials_per_segment;
  for (std::size_t i = 0; i < layout.options.zones.size(); ++i) {
    const auto& z = layout.options.zones[i];
    summary["zones"].push_back({{"index", i}, {"x_min", z.x_min}, {"x_max", z.x_max},
                                {"spacing", z.spacing},
                                {"achieved", i < layout.stats.zones.size()
                                                 ? layout.stats.zones[i].spacing.mean
                                                 : 0.0}});
  }
  std::vector<std::vector<ZoneSummary>> zone_tables;
  std::vector<engine::AdaptFlight> flights;
  // The flights are independent: up to `threads` of them fly at once; their files are written
  // in order afterwards.
  std::vector<engine::AdaptFlight> flown(runs.size());
  std::vector<double> walls(runs.size(), 0.0);
  // SIGINT/SIGTERM end every flight at its next tick: nothing is written, exit 130.
  std::signal(SIGINT, OnAdaptSignal);
  std::signal(SIGTERM, OnAdaptSignal);
  {
    std::atomic<std::size_t> next{0};
    std::mutex error_mutex;
    std::exception_ptr error;
    const auto worker = [&] {
      for (std::size_t i = next++; i < runs.size(); i = next++) {
        try {
          const auto fly_start = std::chrono::steady_clock::now();
          flown[i] = engine::RunAdaptFlight(
              e, layout, runs[i], [&](const engine::AdaptationSegment& s) {
                const int z = ZoneOf(layout.options, s.p_s_W.x());
                spdlog::info(
                    "segment {:3d} P_s x {:5.1f} m (zone {}): v_des {:.2f} -> {:.2f} m/s, {} "
                    "({}/{} trials ok, best f_s {:.2f})",
                    s.index, s.p_s_W.x(),
                    z >= 0 ? fmt::format("{:.1f} m", layout.options.zones[z].spacing) : "-",
                    s.v_des_before, s.v_des, quadtune::ToString(s.outcome), s.successes,
                    s.trials, s.best_f_s);
              },
              &g_adapt_interrupted);
          walls[i] =
              std::chrono::duration<double>(std::chrono::steady_clock::now() - fly_start).count();
        } catch (...) {
          const std::lock_guard<std::mutex> lock(error_mutex);
          if (!error) error = std::current_exception();
        }
      }
    };
    const std::size_t workers =
        std::min(runs.size(), static_cast<std::size_t>(std::max(1, a.threads)));
    std::vector<std::thread> pool;
    for (std::size_t w = 1; w < workers; ++w) pool.emplace_back(worker);
    worker();
    for (auto& t : pool) t.join();
    if (error) std::rethrow_exception(error);
  }
  if (g_adapt_interrupted.load()) {
    spdlog::error("adapt interrupted; no flight written");
    return 130;
  }
  for (std::size_t run = 0; run < runs.size(); ++run) {
    engine::AdaptFlight f = std::move(flown[run]);
    const double fly_wall = walls[run];
    const auto& m = f.result.metrics;
    const std::string dir = (fs::path(a.out) / f.label).string();
    sim::WriteFlightFiles(dir, f.result, layout.obstacles,
                               sim::Mission::GoTo(layout.start_W(), layout.goal_W()));
    std::vector<ZoneSummary> zones =
        WritePathCsv((fs::path(dir) / "path.csv").string(), f, layout.options);
    if (f.adapted) {
      WriteTrialsCsv((fs::path(dir) / "trials.csv").string(), f, layout.options);
      WriteSegmentsCsv((fs::path(dir) / "segments.csv").string(), f, layout.options);
    }
    spdlog::info("{}: {}, t_f {:.2f} s, collisions {}, emergency stops {}, mean speed {:.2f} "
                 "m/s, {} segments, {} trials ({:.1f} s wall)",
                 f.label, sim::ToString(m.status), m.flight_time, m.collisions,
                 m.emergency_stops, m.mean_speed, f.segments.size(), f.trials.size(), fly_wall);
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
                         {"wall_s", fly_wall},
                         {"directory", f.label}};
    for (std::size_t i = 0; i < zones.size(); ++i) {
      const ZoneSummary& z = zones[i];
      nlohmann::json zj = {{"zone", i},
                           {"spacing", layout.options.zones[i].spacing},
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
    summary["flights"].push_back(fj);
    zone_tables.push_back(std::move(zones));
    flights.push_back(std::move(f));
  }

  // The finding to check: lower v_des in the dense zones than in the sparse ones.
  const auto& adapted_zones = zone_tables.front();
  double dense = 0.0, sparse = 0.0;
  int n_dense = 0, n_sparse = 0;
  for (std::size_t i = 0; i < adapted_zones.size(); ++i) {
    const ZoneSummary& z = adapted_zones[i];
    if (z.adopted == 0) continue;
    const double v = z.chosen_sum / z.adopted;
    if (layout.options.zones[i].spacing < 1.5) {
      dense += v;
      ++n_dense;
    } else {
      sparse += v;
      ++n_sparse;
    }
  }
  if (n_dense > 0 && n_sparse > 0) {
    summary["finding"] = {{"dense_mean_chosen_v_des", dense / n_dense},
                          {"sparse_mean_chosen_v_des", sparse / n_sparse},
                          {"lower_in_dense", dense / n_dense < sparse / n_sparse}};
  }
  const double wall =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  summary["wall_s"] = wall;
  std::ofstream(fs::path(a.out) / "summary.json") << summary.dump(1) << '\n';

  {
    std::ofstream md(fs::path(a.out) / "summary.md");
    md << "# " << e.name << ": online v_des adaptation (seed " << e.seed << ")\n\n";
    md << "Mean v_des in force / mean actual speed (m/s), time-weighted, per zone (mean obstacle "
          "spacing).\n\n| flight | status | t_f (s) | collisions | emergency stops |";
    for (const auto& z : layout.options.zones) md << fmt::format(" {:.1f} m |", z.spacing);
    md << "\n|---|---|---|---|---|";
    for (std::size_t i = 0; i < layout.options.zones.size(); ++i) md << "---|";
    md << '\n';
    for (std::size_t k = 0; k < flights.size(); ++k) {
      const auto& m = flights[k].result.metrics;
      md << fmt::format("| {} | {} | {:.2f} | {} | {} |", flights[k].label,
                        sim::ToString(m.status), m.flight_time, m.collisions,
                        m.emergency_stops);
      for (const auto& z : zone_tables[k]) {
        md << fmt::format(" {:.2f} / {:.2f} |", Ratio(z.v_des_sum, z.time),
                          Ratio(z.speed_sum, z.time));
      }
      md << '\n';
    }
    md << "\nAdapted flight per zone (segments by the zone of P_s):\n\n"
          "| zone spacing (m) | segments | adopted | mean chosen v_des (m/s) | trials | failed "
          "trials |\n|---|---|---|---|---|---|\n";
    for (std::size_t i = 0; i < adapted_zones.size(); ++i) {
      const ZoneSummary& z = adapted_zones[i];
      md << fmt::format("| {:.1f} | {} | {} | {:.2f} | {} | {} |\n",
                        layout.options.zones[i].spacing, z.segments, z.adopted,
                        Ratio(z.chosen_sum, z.adopted), z.trials, z.failed_trials);
    }
    if (summary.contains("finding")) {
      md << fmt::format("\nMean chosen v_des: dense zones (< 1.5 m) {:.2f} m/s, sparse zones "
                        "{:.2f} m/s.\n",
                        summary["finding"]["dense_mean_chosen_v_des"].get<double>(),
                        summary["finding"]["sparse_mean_chosen_v_des"].get<double>());
    }
    md << fmt::format("\nWall time {:.1f} s.\n", wall);
  }
  spdlog::info("wrote {}/summary.json, summary.md and one directory per flight ({:.1f} s)", a.out,
               wall);
  if (a.plot) {
    if (RunPlotScript("adapt '" + a.out + "'") != 0) return 1;
    spdlog::info("figure: {}/adapt.png", a.out);
  }
  return 0;
}

}  // namespace

void RegisterAdapt(CLI::App& app, int& exit_code) {
  static AdaptArgs args;
  auto* cmd = app.add_subcommand(
      "adapt", "changing-environment experiment: adapt v_des online by BO (paper Sec. IV-B) and "
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
  cmd->add_flag("--overwrite", args.overwrite, "replace the results already in OUT");
  cmd->callback([&exit_code] { exit_code = RunAdapt(args); });
}

}  // namespace quadtune::cli
