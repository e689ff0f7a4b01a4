// WriteStudyFiles (study.hpp): a study's outcome as OUT/study.json and OUT/validation.csv.
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <system_error>

#include "quadtune/engine/tuning/study.hpp"

namespace quadtune::engine {
namespace {

namespace fs = std::filesystem;

nlohmann::json ToJson(const ParamValues& values) {
  nlohmann::json j = nlohmann::json::object();
  for (const auto& [k, v] : values) j[k] = v;
  return j;
}

std::string CsvField(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string out = "\"";
  for (char ch : s) out += ch == '"' ? std::string("\"\"") : std::string(1, ch);
  return out + "\"";
}

nlohmann::json ToJson(const StudyStageResult& stage) {
  nlohmann::json sj;
  sj["name"] = stage.name;
  sj["start_from"] = stage.start_from;
  sj["start"] = ToJson(stage.start);
  sj["store"] = stage.store;
  sj["best"] = ToJson(stage.best);
  sj["wall_s"] = stage.wall_s;
  nlohmann::json space = nlohmann::json::array();
  for (const auto& prm : stage.space) {
    space.push_back(
        {{"name", prm.name}, {"lower", prm.lower}, {"upper", prm.upper}, {"log", prm.log_scale}});
  }
  sj["space"] = space;
  return sj;
}

/// Throws filesystem_error naming `path` when `out` (writing it) has failed.
void Check(const std::ofstream& out, const fs::path& path) {
  if (!out) {
    throw fs::filesystem_error("cannot write the file", path,
                               std::make_error_code(std::errc::io_error));
  }
}

void WriteValidationCsv(const StudyOutcome& o, const fs::path& path) {
  std::ofstream csv(path);
  Check(csv, path);
  csv << "point,label,source_stage,method,repeat,flight,map_seed,status,completed,flight_time,"
         "collisions,emergency_stops,plans,failed_plans,f_l,params\n";
  for (const StudyValidationFlight& v : o.validation) {
    csv << v.point << ',' << CsvField(v.label) << ',' << v.source_stage << ',' << v.method << ','
        << v.repeat << ',' << v.flight << ',' << v.map_seed << ',' << ToString(v.status) << ','
        << (v.completed ? 1 : 0) << ',' << v.flight_time << ',' << v.collisions << ','
        << v.emergency_stops << ',' << v.plans << ',' << v.failed_plans << ',' << v.f_l << ','
        << CsvField(ToJson(v.params).dump()) << '\n';
  }
  csv.flush();
  Check(csv, path);
}

void WriteStudyJson(const StudyOutcome& o, const fs::path& path) {
  nlohmann::json index;
  index["name"] = o.name;
  index["file"] = o.file;
  index["seed"] = o.seed;
  index["sweep_key"] = o.sweep_key;
  index["validation_flights"] = o.validation_flights;
  index["points"] = nlohmann::json::array();
  for (const StudyPointResult& p : o.points) {
    nlohmann::json point;
    point["label"] = p.label;
    point["value"] = p.value;
    point["stages"] = nlohmann::json::array();
    for (const StudyStageResult& stage : p.stages) point["stages"].push_back(ToJson(stage));
    index["points"].push_back(point);
  }
  std::ofstream out(path);
  Check(out, path);
  out << index.dump(2) << "\n";
  out.flush();
  Check(out, path);
}

}  // namespace

void WriteStudyFiles(const StudyOutcome& outcome, const std::string& out_dir) {
  WriteValidationCsv(outcome, fs::path(out_dir) / "validation.csv");
  if (!outcome.points.empty()) WriteStudyJson(outcome, fs::path(out_dir) / "study.json");
}

}  // namespace quadtune::engine
