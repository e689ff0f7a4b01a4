// `quadtune policy`: learns the context policy of the changing-environment experiment from a
// density study (engine::LearnContextPolicy): each density's tuned v_des, at the free range
// measured in that density's forest.
//
// Thread safety: runs on the main thread only (the flights through ParallelFor).
#include <spdlog/spdlog.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "commands.hpp"
#include "file_kind.hpp"
#include "limits.hpp"
#include "quadtune/common/error.hpp"
#include "quadtune/common/text_file.hpp"
#include "quadtune/engine/adaptation/corridor_study.hpp"
#include "quadtune/engine/experiment/experiment.hpp"

namespace quadtune::cli {
namespace {

namespace fs = std::filesystem;

struct PolicyArgs {
  std::string experiment;
  std::string study;
  std::string out = "policy.yaml";
  int maps = 4;
  int threads = 1;
  std::vector<double> grid;      // empty: the study's tuned v_des
  std::vector<std::string> set;  // --set KEY=VALUE edits of the experiment file
};

// Validation rows of a study (validation.csv): per label, per tuned repeat, the handed-back
// v_des and the mean held-out f_l.
struct RepeatResult {
  double v_des = 0.0;
  double f_l_sum = 0.0;
  int flights = 0;
};

std::map<std::string, std::map<int, RepeatResult>> ReadValidation(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw ConfigError(path, "", "cannot be read: is this the output folder of a study?");
  std::string line;
  std::getline(in, line);
  const std::string expected =
      "point,label,source_stage,method,repeat,flight,map_seed,status,"
      "completed,flight_time,collisions,emergency_stops,plans,"
      "failed_plans,f_l,params";
  if (line != expected) throw ConfigError(path, "", "is not a study's validation.csv");
  std::map<std::string, std::map<int, RepeatResult>> out;
  while (std::getline(in, line)) {
    std::vector<std::string> cells;
    std::size_t pos = 0;
    for (int i = 0; i < 15; ++i) {
      const std::size_t comma = line.find(',', pos);
      if (comma == std::string::npos) throw ConfigError(path, "", "a row has too few columns");
      cells.push_back(line.substr(pos, comma - pos));
      pos = comma + 1;
    }
    if (cells[3] == "default") continue;
    std::string params = line.substr(pos);
    if (params.size() >= 2 && params.front() == '"') params = params.substr(1, params.size() - 2);
    for (std::size_t q = params.find("\"\""); q != std::string::npos;
         q = params.find("\"\"", q + 1)) {
      params.erase(q, 1);
    }
    const nlohmann::json p = nlohmann::json::parse(params);
    RepeatResult& r = out[cells[1]][std::stoi(cells[4])];
    r.v_des = p.at("v_des").get<double>();
    r.f_l_sum += std::stod(cells[14]);
    ++r.flights;
  }
  return out;
}

std::vector<engine::DensityPoint> StudyDensities(const PolicyArgs& a) {
  const std::string json_path = (fs::path(a.study) / "study.json").string();
  if (!PathExists(json_path)) {
    throw ConfigError(a.study, "",
                      "holds no study.json: give the output folder of `quadtune study`");
  }
  const nlohmann::json study = nlohmann::json::parse(ReadFileText(json_path));
  const auto validation = ReadValidation((fs::path(a.study) / "validation.csv").string());
  const std::string file = study.value("file", std::string());
  const std::string base = fs::path(file).parent_path().string();
  std::vector<engine::DensityPoint> densities;
  for (const auto& point : study.at("points")) {
    engine::DensityPoint d;
    d.label = point.at("label").get<std::string>();
    const auto found = validation.find(d.label);
    if (found == validation.end()) continue;
    const std::string layout = point.at("value").get<std::string>();
    d.layout =
        layout::LayoutOptions::LoadFile(engine::ResolvePath(layout, base.empty() ? "." : base));
    double best = 0.0;
    for (const auto& [repeat, r] : found->second) {
      const double mean = r.f_l_sum / r.flights;
      if (d.v_des == 0.0 || mean < best) {
        best = mean;
        d.v_des = r.v_des;
      }
    }
    spdlog::info(
        "density {}: tuned v_des {:.2f} m/s (the repeat with the lowest held-out mean "
        "f_l, {:.2f})",
        d.label, d.v_des, best);
    densities.push_back(d);
  }
  return densities;
}

// The grid's table beside the policy file: policy.yaml -> policy_grid.csv.
std::string GridPath(const std::string& out) {
  fs::path p(out);
  return (p.parent_path() / (p.stem().string() + "_grid.csv")).string();
}

std::string GridFlag(const std::vector<double>& grid) {
  if (grid.empty()) return "";
  std::string flag = " --grid ";
  for (std::size_t i = 0; i < grid.size(); ++i) {
    flag += (i > 0 ? "," : "") + FormatNumber(grid[i]);
  }
  return flag;
}

int RunPolicy(const PolicyArgs& a) {
  CheckFileKind(a.experiment, FileKind::kAdaptation);
  const engine::AdaptExperiment e = LoadAdaptExperiment(a.experiment, a.set);
  std::vector<engine::DensityPoint> densities = StudyDensities(a);
  std::string source = "the tuned v_des of each density";
  if (!a.grid.empty()) {
    spdlog::info("flying {} v_des on {} maps of each of {} densities ({} threads)", a.grid.size(),
                 a.maps, densities.size(), a.threads);
    const std::vector<engine::GridCell> cells =
        engine::ChooseVDesByGrid(e, densities, a.grid, a.maps, a.threads);
    std::ostringstream csv;
    csv << "label,v_des,flights,mean_f_l,collisions,unfinished,chosen\n";
    for (const engine::GridCell& c : cells) {
      csv << c.label << ',' << c.v_des << ',' << c.flights << ',' << c.mean_f_l << ','
          << c.collisions << ',' << c.unfinished << ',' << (c.chosen ? 1 : 0) << '\n';
      spdlog::info("  density {}: v_des {:.2f} -> mean f_l {:.2f}, {} collisions{}", c.label,
                   c.v_des, c.mean_f_l, c.collisions, c.chosen ? " (chosen)" : "");
    }
    const std::string grid_path = GridPath(a.out);
    WriteFileAtomically(grid_path, csv.str());
    spdlog::info("wrote {}", grid_path);
    source =
        "each density's v_des chosen by the grid in " + fs::path(grid_path).filename().string();
  }
  spdlog::info("measuring the free range of {} densities on {} maps each ({} threads)",
               densities.size(), a.maps, a.threads);
  const engine::ContextPolicy policy = engine::LearnContextPolicy(e, densities, a.maps, a.threads);
  std::ostringstream text;
  std::string sets;
  for (const std::string& kv : a.set) sets += " --set " + kv;
  text << "# Context policy learned by `quadtune policy " << a.experiment << sets << " --study "
       << a.study << " --maps " << a.maps << GridFlag(a.grid) << "`:\n# " << source
       << ", at the mean free range measured in its forest.\n"
       << "# Fly it with adaptation.mode context (or context_prior).\n"
       << policy.ToYamlString();
  WriteFileAtomically(a.out, text.str());
  for (const auto& p : policy.points) {
    spdlog::info("  density {}: free range {:.2f} m -> v_des {:.2f} m/s", p.label, p.free_range,
                 p.v_des);
  }
  spdlog::info("wrote {}", a.out);
  return 0;
}

}  // namespace

void RegisterPolicy(CLI::App& app, int& exit_code) {
  static PolicyArgs args;
  auto* cmd =
      app.add_subcommand("policy",
                         "learn the context policy (v_des per measured free range) of a "
                         "changing-environment experiment from a density study's tuned points");
  cmd->add_option("experiment", args.experiment, "changing-environment experiment file (YAML)")
      ->required();
  cmd->add_option("--study", args.study,
                  "output folder of `quadtune study` (study.json, "
                  "validation.csv)")
      ->required();
  cmd->add_option("--out", args.out, "policy file to write (YAML)")->capture_default_str();
  cmd->add_option("--maps", args.maps, "maps per density on which the free range is measured")
      ->capture_default_str()
      ->check(CountIn(1, 1000, "maps"));
  cmd->add_option("--grid", args.grid,
                  "choose each density's v_des by flying these fixed v_des (m/s, comma-separated) "
                  "on --maps maps of its forest: the lowest mean f_l among those that always "
                  "finished without a collision (writes <out stem>_grid.csv); without it, the "
                  "study's tuned v_des")
      ->delimiter(',');
  cmd->add_option("--set", args.set,
                  "KEY=VALUE: change the experiment file's dotted KEY, e.g. --set "
                  "planner.type=ego (repeatable)");
  cmd->add_option("--threads", args.threads, "flights flown at once")
      ->capture_default_str()
      ->check(CountIn(1, engine::kMaxThreads, kThreadsWhy));
  cmd->callback([&exit_code] { exit_code = RunPolicy(args); });
}

}  // namespace quadtune::cli
