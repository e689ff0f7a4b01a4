// `quadtune sweep`: variance-based parameter importance (Sobol' indices) of an experiment's f_l,
// its terms and f_s over the parameter box (engine/tuning/sweep.hpp), optionally at several layouts
// (obstacle densities), with tables and a figure.
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "commands.hpp"
#include "limits.hpp"
#include "file_kind.hpp"
#include "result_dir.hpp"
#include "quadtune/common/error.hpp"
#include "quadtune/engine/distributed/distributed.hpp"
#include "quadtune/engine/planners/planners.hpp"
#include "quadtune/engine/tuning/sweep.hpp"

namespace quadtune::cli {
namespace {

namespace fs = std::filesystem;

std::atomic<bool> g_sweep_interrupted{false};
void OnSweepSignal(int) { g_sweep_interrupted.store(true); }

struct SweepArgs {
  std::string experiment;
  std::string out;
  int points = 64;
  int maps = 2;
  int queries = 32;
  long long seed = -1;  ///< < 0: the experiment's seed
  int threads = 0;      ///< 0: the experiment's threads
  int bootstrap = 1000;
  std::vector<std::string> set;
  std::vector<std::string> layouts;  ///< values of layout_key, one sweep each
  std::string layout_key = "planner.layout_file";
  bool overwrite = false;
  bool resume = false;
  bool plot = true;
  bool quiet = false;
};

/// The journal of layout group `group` in OUT (engine::SweepOptions::journal).
std::string JournalPath(const std::string& out, std::size_t group) {
  return (fs::path(out) / (group == 0 ? std::string("sweep.journal")
                                      : "sweep_" + std::to_string(group) + ".journal"))
      .string();
}

/// One sweep of the command: a layout (or the experiment as given) and its result.
struct Group {
  std::string label;
  std::string value;              ///< the layout_key value ("" without --layouts)
  double spacing = std::nan("");  ///< the layout's target spacing (m), when it has one zone
  engine::Experiment experiment;
  engine::SweepResult result;
};

/// A CSV-safe message (no commas, quotes or line breaks).
std::string CsvText(std::string s) {
  for (char& c : s) {
    if (c == ',' || c == '"' || c == '\n' || c == '\r') c = ';';
  }
  return s;
}

std::string Num(double v) { return std::isfinite(v) ? fmt::format("{:.10g}", v) : "nan"; }

bool IsShort(const engine::Experiment& e, const std::string& name) {
  return std::find(e.short_names.begin(), e.short_names.end(), name) != e.short_names.end();
}

/// A design block's name: A, B, or AB<i> for A_B^(i) (i = the parameter's index).
std::string BlockName(int block) {
  if (block == 0) return "A";
  if (block == 1) return "B";
  return fmt::format("AB{}", block - 2);
}

/// The f_l terms written per flight (every term LongTermObjective reports, first flight's order).
std::vector<std::string> TermNames(const std::vector<Group>& groups) {
  std::vector<std::string> names;
  for (const auto& g : groups) {
    for (const auto& f : g.result.flights) {
      for (const auto& [name, v] : f.objective.terms) {
        if (std::find(names.begin(), names.end(), name) == names.end()) names.push_back(name);
      }
    }
  }
  return names;
}

void WriteSweepCsv(const std::vector<Group>& groups, const fs::path& path) {
  std::ofstream out(path);
  const auto& names = groups.front().result.names;
  const auto terms = TermNames(groups);
  out << "layout,point,block,row,map";
  for (const auto& n : names) out << ',' << n;
  out << ",f_l";
  for (const auto& t : terms) out << ',' << t;
  out << ",status,map_seed,flight_seed,message\n";
  for (const auto& g : groups) {
    for (const auto& f : g.result.flights) {
      const auto& pt = g.result.points[static_cast<std::size_t>(f.point)];
      out << g.label << ',' << f.point << ',' << BlockName(pt.block) << ',' << pt.row << ','
          << f.map;
      for (const auto& n : names) out << ',' << Num(pt.params.at(n));
      out << ',' << Num(f.objective.value);
      for (const auto& t : terms) {
        const auto it = f.objective.terms.find(t);
        out << ',' << (it == f.objective.terms.end() ? std::string("nan") : Num(it->second));
      }
      out << ',' << quadtune::ToString(f.status) << ',' << f.map_seed << ',' << f.flight_seed << ','
          << CsvText(f.message) << '\n';
    }
  }
}

void WritePointsCsv(const std::vector<Group>& groups, const fs::path& path) {
  std::ofstream out(path);
  const auto& names = groups.front().result.names;
  out << "layout,point,block,row";
  for (const auto& n : names) out << ',' << n;
  out << ",f_l,t_f,n_c,n_e,failed_flights,f_s,failed_resolves\n";
  for (const auto& g : groups) {
    for (std::size_t p = 0; p < g.result.points.size(); ++p) {
      const auto& pt = g.result.points[p];
      out << g.label << ',' << p << ',' << BlockName(pt.block) << ',' << pt.row;
      for (const auto& n : names) out << ',' << Num(pt.params.at(n));
      out << ',' << Num(pt.f_l);
      for (const char* t : {"t_f", "n_c", "n_e"}) {
        const auto it = pt.terms.find(t);
        out << ',' << (it == pt.terms.end() ? std::string("nan") : Num(it->second));
      }
      out << ',' << pt.failed_flights << ',' << Num(pt.f_s) << ',' << pt.failed_resolves << '\n';
    }
  }
}

/// Which short-term score shares f_l's tendency: every f_s term against f_l.
void WriteAgreement(std::ostream& md, const engine::SweepResult& r) {
  md << "Candidate short-term scores against f_l: Spearman over every point, and over the "
        "changes between each base row A and its A_B^(i) for the short-term parameters i (one "
        "θ_s parameter changed, θ_l fixed: what PSO's tendency does to f_l).\n\n"
     << "| score | Spearman with f_l | Spearman of the changes | pairs |\n|---|---|---|---|\n";
  for (const auto& a : r.agreement) {
    const auto r3 = [](double v) { return std::isfinite(v) ? fmt::format("{:.3f}", v) : "–"; };
    md << fmt::format("| {} | {} | {} | {} |\n", a.name, r3(a.spearman),
                      r3(a.spearman_short_changes), a.pairs);
  }
  md << '\n';
}

void WriteIndices(const std::vector<Group>& groups, const SweepArgs& a, const fs::path& csv_path,
                  const fs::path& md_path) {
  std::ofstream csv(csv_path);
  csv << "layout,spacing,output,parameter,kind,S1,S1_lo,S1_hi,ST,ST_lo,ST_hi,mean,variance,N,"
         "maps,spearman_fs_fl\n";
  std::ofstream md(md_path);
  md << "# Parameter importance: Sobol' indices\n\n"
     << "First-order S1 (Saltelli 2010) and total-effect ST (Jansen) with 95% bootstrap intervals ("
     << a.bootstrap << " resamples of the N base rows). f_l, t_f, n_c and n_e are means over the "
     << "same maps per point; f_s is the mean short-term objective over a fixed subset of planning "
     << "queries recorded at the default parameters, and depends on θ_s only: its θ_l indices are "
     << "exactly 0 (points differing only in θ_l share their re-solves). An output that did not "
     << "vary has no indices (nan).\n";
  for (const auto& g : groups) {
    const auto& r = g.result;
    const std::size_t n = r.points.size() / (r.names.size() + 2);
    md << "\n## " << g.label;
    if (std::isfinite(g.spacing)) md << fmt::format(" (spacing {:g} m)", g.spacing);
    md << "\n\n"
       << fmt::format(
              "N = {}, d = {}, {} map(s), {} flights ({} failed), {} of {} recorded queries "
              "re-solved for {} distinct θ_s. Spearman rank correlation of f_s and mean "
              "f_l over the {} points: **{}**.\n\n",
              n, r.names.size(), r.map_seeds.size(), r.flights.size(),
              std::count_if(r.flights.begin(), r.flights.end(),
                            [](const auto& f) { return f.status != engine::EvalStatus::kOk; }),
              r.queries_used, r.queries_recorded, r.distinct_short, r.points.size(),
              fmt::format("{:.3f}", r.spearman_fs_fl));
    WriteAgreement(md, r);
    md << "| output | mean | parameter | kind | S1 [95% CI] | ST [95% CI] |\n"
       << "|---|---|---|---|---|---|\n";
    for (const auto& o : r.outputs) {
      for (std::size_t i = 0; i < r.names.size(); ++i) {
        const auto& x = o.indices.index[i];
        const char* kind = IsShort(g.experiment, r.names[i]) ? "short" : "long";
        csv << g.label << ',' << Num(g.spacing) << ',' << o.name << ',' << r.names[i] << ',' << kind
            << ',' << Num(x.s1) << ',' << Num(x.s1_lo) << ',' << Num(x.s1_hi) << ',' << Num(x.st)
            << ',' << Num(x.st_lo) << ',' << Num(x.st_hi) << ',' << Num(o.indices.mean) << ','
            << Num(o.indices.variance) << ',' << n << ',' << r.map_seeds.size() << ','
            << Num(r.spearman_fs_fl) << '\n';
        md << fmt::format(
            "| {} | {} | {} | {} | {:.3f} [{:.3f}, {:.3f}] | {:.3f} [{:.3f}, {:.3f}] |\n",
            i == 0 ? o.name : "", i == 0 ? fmt::format("{:.4g}", o.indices.mean) : "", r.names[i],
            kind, x.s1, x.s1_lo, x.s1_hi, x.st, x.st_lo, x.st_hi);
      }
    }
  }
}

void WriteSummary(const std::vector<Group>& groups, const SweepArgs& a, std::uint64_t seed,
                  double wall_s, const fs::path& path) {
  nlohmann::json j;
  j["experiment"] = a.experiment;
  j["points"] = a.points;
  j["maps"] = a.maps;
  j["queries"] = a.queries;
  j["seed"] = seed;
  j["bootstrap"] = a.bootstrap;
  j["threads"] = a.threads > 0 ? a.threads : groups.front().experiment.threads;
  j["wall_s"] = wall_s;
  j["set"] = a.set;
  for (const auto& g : groups) {
    nlohmann::json gj;
    gj["label"] = g.label;
    if (!g.value.empty()) gj[a.layout_key] = g.value;
    if (std::isfinite(g.spacing)) gj["spacing"] = g.spacing;
    gj["parameters"] = g.result.names;
    gj["short_term"] = g.experiment.short_names;
    gj["long_term"] = g.experiment.long_names;
    gj["design_points"] = g.result.points.size();
    gj["flights"] = g.result.flights.size();
    gj["failed_flights"] =
        std::count_if(g.result.flights.begin(), g.result.flights.end(),
                      [](const auto& f) { return f.status != engine::EvalStatus::kOk; });
    gj["map_seeds"] = g.result.map_seeds;
    gj["queries_recorded"] = g.result.queries_recorded;
    gj["queries_used"] = g.result.queries_used;
    gj["distinct_short"] = g.result.distinct_short;
    gj["resolves"] = g.result.resolves;
    gj["wall_s"] = g.result.wall_s;
    gj["spearman_fs_fl"] = std::isfinite(g.result.spearman_fs_fl)
                               ? nlohmann::json(g.result.spearman_fs_fl)
                               : nlohmann::json(nullptr);
    for (const auto& ag : g.result.agreement) {
      const auto num = [](double v) {
        return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr);
      };
      gj["short_term_agreement"].push_back({{"score", ag.name},
                                            {"spearman", num(ag.spearman)},
                                            {"spearman_short_changes",
                                             num(ag.spearman_short_changes)},
                                            {"pairs", ag.pairs}});
    }
    j["layouts"].push_back(gj);
  }
  std::ofstream(path) << j.dump(1) << '\n';
}

/// The progress printer: on a terminal a line rewritten in place; otherwise an info line every
/// 30 s (and at the end of each layout).
std::function<void(const engine::SweepProgress&)> Printer(bool tty, bool quiet, std::size_t group,
                                                          std::size_t groups) {
  auto last =
      std::make_shared<std::chrono::steady_clock::time_point>(std::chrono::steady_clock::now());
  return [=](const engine::SweepProgress& p) {
    const double work = p.flights_total + 0.01 * static_cast<double>(p.resolves_total);
    const double done = p.flights_done + 0.01 * static_cast<double>(p.resolves_done);
    const double eta = done > 0 ? p.elapsed_s * (work - done) / done : 0.0;
    const std::string line =
        fmt::format("layout {}/{}: flights {}/{}, re-solves {}/{}, elapsed {:.0f} s, ETA {:.0f} s",
                    group + 1, groups, p.flights_done, p.flights_total, p.resolves_done,
                    p.resolves_total, p.elapsed_s, eta);
    if (quiet) return spdlog::debug("{}", line);
    if (tty) {
      std::fprintf(stderr, "\r\033[K%s", line.c_str());
      std::fflush(stderr);
      return;
    }
    const auto now = std::chrono::steady_clock::now();
    const bool end = p.flights_done == p.flights_total && p.resolves_done == p.resolves_total;
    if (end || now - *last >= std::chrono::seconds(30)) {
      *last = now;
      spdlog::info("{}", line);
    }
  };
}

/// The sweep's layouts: the experiment as given, or once per --layouts value with the layout key
/// set to it, labelled; `spacing` for an ipopt planner's uniform forest.
std::vector<Group> LoadGroups(const SweepArgs& a) {
  std::vector<Group> groups;
  if (a.layouts.empty()) {
    Group g;
    g.experiment = LoadExperiment(a.experiment, a.set);
    g.label = g.experiment.name;
    groups.push_back(std::move(g));
  }
  for (const auto& value : a.layouts) {
    Group g;
    auto sets = a.set;
    sets.push_back(a.layout_key + "=" + value);
    g.experiment = engine::Experiment::LoadFile(a.experiment, sets);
    g.value = value;
    // A layout file is labelled by its name (forest_1p3), any other value as written.
    const fs::path file(value);
    g.label = CsvText(file.extension() == ".yaml" ? file.stem().string() : value);
    groups.push_back(std::move(g));
  }
  for (auto& g : groups) {
    if (const auto* ipopt = g.experiment.planner.Extract<engine::IpoptPlanner>()) {
      if (ipopt->options().layout.zones.empty()) g.spacing = ipopt->options().layout.spacing;
    }
  }
  return groups;
}

int RunSweepCommand(const SweepArgs& a) {
  engine::CheckSingleProcessLaunch(engine::MpiLaunchSize(), "sweep");
  CheckFileKind(a.experiment, FileKind::kExperiment);
  CheckOutputDir(a.out, "--out");
  if (a.resume && !PathExists(JournalPath(a.out, 0))) {
    throw ConfigError(a.out, "--resume",
                      "holds no sweep to continue (no sweep.journal); run the sweep without "
                      "--resume");
  }
  if (!a.resume && HoldsFiles(a.out) && !a.overwrite) {
    throw ConfigError(a.out, "--out",
                      "the output directory exists and is not empty; choose another --out, "
                      "pass --overwrite to replace its sweep files, or --resume to continue an "
                      "interrupted sweep");
  }
  // Every configuration error is reported here, before any flight.
  std::vector<Group> groups = LoadGroups(a);
  const engine::Experiment& first = groups.front().experiment;
  const std::uint64_t seed = a.seed >= 0 ? static_cast<std::uint64_t>(a.seed) : first.seed;
  engine::SweepOptions options;
  options.points = a.points;
  options.maps = a.maps;
  options.queries = a.queries;
  options.seed = seed;
  options.threads = a.threads > 0 ? a.threads : first.threads;
  options.bootstrap = a.bootstrap;
  options.cancel = &g_sweep_interrupted;
  const int d = first.space.Dim();
  // Before the lock: a refusal leaves OUT as it was.
  engine::CheckSweepOptions(options, d);
  CheckThreadsFitAddressSpace(a.threads, first.threads, a.experiment);
  // Held until the files are written: a second sweep into OUT is refused meanwhile.
  ResultDirPolicy lock;
  lock.lock_only = true;
  const ResultDir out_dir(a.out, lock);
  for (std::size_t i = 0; !a.resume && i < groups.size(); ++i) fs::remove(JournalPath(a.out, i));
  const long long design_points = static_cast<long long>(a.points) * (d + 2);
  spdlog::info(
      "sweep of '{}' ({}): planner {}, {} parameters, N = {} → {} points × {} maps = {} "
      "flights per layout, {} layout(s), {} re-solved queries, seed {}, {} threads",
      first.name, a.experiment, first.planner.Name(), d, a.points, design_points, a.maps,
      design_points * a.maps, groups.size(), a.queries, seed, options.threads);
  std::signal(SIGINT, OnSweepSignal);
  std::signal(SIGTERM, OnSweepSignal);
  const bool tty = isatty(fileno(stderr)) != 0 && !a.quiet;
  const auto t0 = std::chrono::steady_clock::now();
  for (std::size_t i = 0; i < groups.size(); ++i) {
    options.on_progress = Printer(tty, a.quiet, i, groups.size());
    options.journal = JournalPath(a.out, i);
    groups[i].result = engine::RunSweep(groups[i].experiment, options);
    if (tty) std::fprintf(stderr, "\n");
    if (groups[i].result.status != engine::RunStatus::kCompleted) {
      spdlog::error("sweep interrupted; the finished flights and re-solves are in {}; continue "
                    "with the same command and --resume",
                    options.journal);
      return 130;
    }
    const auto& r = groups[i].result;
    spdlog::info("layout {}: {} flights, {} re-solves in {:.1f} s; Spearman(f_s, f_l) = {:.3f}",
                 groups[i].label, r.flights.size(), r.resolves, r.wall_s, r.spearman_fs_fl);
  }
  const double wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const fs::path out(a.out);
  // With --overwrite, no file of an earlier sweep may survive next to this one's.
  for (const char* file :
       {"sweep.csv", "points.csv", "indices.csv", "indices.md", "summary.json", "sweep.png"}) {
    fs::remove(out / file);
  }
  WriteSweepCsv(groups, out / "sweep.csv");
  WritePointsCsv(groups, out / "points.csv");
  WriteIndices(groups, a, out / "indices.csv", out / "indices.md");
  WriteSummary(groups, a, seed, wall_s, out / "summary.json");
  spdlog::info("wrote {}/sweep.csv, points.csv, indices.csv, indices.md, summary.json ({:.1f} s)",
               a.out, wall_s);
  for (std::size_t i = 0; i < groups.size(); ++i) fs::remove(JournalPath(a.out, i));
  if (a.plot) return RunPlotScript("sweep '" + a.out + "'");
  return 0;
}

}  // namespace

void RegisterSweep(CLI::App& app, int& exit_code) {
  static SweepArgs args;
  auto* cmd = app.add_subcommand(
      "sweep",
      "parameter importance: Sobol' indices (S1, ST) of f_l, its terms and f_s over the "
      "experiment's parameter box, from a Saltelli design flown on common maps");
  cmd->add_option("experiment", args.experiment, "experiment file (YAML)")->required();
  cmd->add_option("--out", args.out,
                  "output directory (must be empty or new; locked while the sweep runs)")
      ->required();
  cmd->add_option("--points", args.points, "N base rows of the design (N·(d+2) points)")
      ->capture_default_str()
      ->check(CLI::Range(2, kMaxSweepPoints));
  cmd->add_option("--maps", args.maps, "K maps every point flies on")
      ->capture_default_str()
      ->check(CLI::Range(1, kMaxSweepMaps));
  cmd->add_option("--queries", args.queries, "Q recorded planning queries re-solved per θ_s")
      ->capture_default_str()
      ->check(CLI::Range(1, kMaxSweepQueries));
  cmd->add_option("--seed", args.seed, "sweep seed (default: the experiment's)")
      ->check(SeedValidator());
  cmd->add_option("--threads", args.threads, "worker threads (default: the experiment's)")
      ->check(CountIn(1, engine::kMaxThreads, kThreadsWhy));
  cmd->add_option("--bootstrap", args.bootstrap, "bootstrap resamples for the 95% intervals")
      ->capture_default_str()
      ->check(CLI::Range(1, 1000000));
  cmd->add_option("--set", args.set,
                  "KEY=VALUE: change the experiment file's dotted KEY (repeat as needed)");
  cmd->add_option("--layouts", args.layouts,
                  "run the sweep once per value of --layout-key (layout files: one per obstacle "
                  "density); indices per layout");
  cmd->add_option("--layout-key", args.layout_key,
                  "experiment key that each --layouts value sets (an experiment with an inline "
                  "planner.layout takes e.g. planner.layout.spacing and spacings as values)")
      ->capture_default_str();
  cmd->add_flag("--overwrite", args.overwrite, "write into a non-empty --out");
  cmd->add_flag("--resume", args.resume,
                "continue the interrupted sweep in --out (same experiment and options): the "
                "flights and re-solves its journal holds are not run again");
  AddNoPlotFlag(*cmd, args.plot, "do not draw OUT/sweep.png");
  cmd->add_flag("--quiet", args.quiet, "no progress line");
  cmd->callback([&exit_code] { exit_code = RunSweepCommand(args); });
}

}  // namespace quadtune::cli
