// Study::LoadFile's checks of a study file and ResultStore's refusals, each shown to name the key
// of the rule that rejects the input (a valid twin of every bad file loads, so the error comes
// from the one edit).
#include <gtest/gtest.h>
#include <sqlite3.h>
#include <sys/wait.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "../config_error_util.hpp"
#include "quadtune/common/error.hpp"
#include "quadtune/engine/experiment/experiment.hpp"
#include "quadtune/engine/store/result_store.hpp"
#include "quadtune/engine/tuning/study.hpp"
#include "test_util.hpp"

namespace quadtune::engine {
namespace {

using quadtune::test::ThrowsConfigError;

/// A study of the toy experiment: a sweep over budget.flights and two stages.
struct StudyFiles {
  explicit StudyFiles(const std::string& name) : dir(test::TempDir("study_" + name)) {
    std::ofstream(dir + "/base.yaml") << test::ToyYaml("[random]");
  }
  /// Writes study.yaml with `sweep` and `stages` (YAML flow text) and returns its path.
  std::string Write(const std::string& sweep, const std::string& stages) const {
    const std::string path = dir + "/study.yaml";
    std::ofstream(path) << "name: s\nseed: 2\nexperiment: base.yaml\n"
                        << "sweep: " << sweep << "\nstages: " << stages
                        << "\nvalidation: {flights: 0}\n";
    return path;
  }
  std::string dir;
};

const std::string kSweep = "{key: budget.flights, values: [4, 6], labels: [a, b]}";
const std::string kStages = "[{name: low}, {name: high, start_from: low}]";

TEST(StudyValidation, TheValidTwinLoads) {
  const StudyFiles f("valid");
  const Study s = Study::LoadFile(f.Write(kSweep, kStages));
  EXPECT_EQ(s.labels, (std::vector<std::string>{"a", "b"}));
  ASSERT_EQ(s.stages.size(), 2u);
  EXPECT_EQ(s.stages[1].start_from, "low");
  EXPECT_EQ(s.sweep_values.size(), 2u);
}

TEST(StudyValidation, RejectsEmptySweepValues) {
  const StudyFiles f("empty_values");
  const std::string path = f.Write("{key: budget.flights, values: []}", kStages);
  EXPECT_TRUE(ThrowsConfigError([&] { (void)Study::LoadFile(path); }, "sweep.values",
                                {"non-empty", "budget.flights", "study.yaml"}));
}

TEST(StudyValidation, RejectsLabelsOfAnotherCount) {
  const StudyFiles f("label_count");
  const std::string path = f.Write("{key: budget.flights, values: [4, 6], labels: [a]}", kStages);
  EXPECT_TRUE(ThrowsConfigError([&] { (void)Study::LoadFile(path); }, "sweep.labels",
                                {"one label per value (2)"}));
}

TEST(StudyValidation, RejectsDuplicateLabels) {
  const StudyFiles f("label_twice");
  const std::string path =
      f.Write("{key: budget.flights, values: [4, 6], labels: [same, same]}", kStages);
  EXPECT_TRUE(ThrowsConfigError([&] { (void)Study::LoadFile(path); }, "sweep.labels",
                                {"both named 'same'"}));
  // Without labels, equal values give equal default labels.
  const std::string values = f.Write("{key: budget.flights, values: [4, 4]}", kStages);
  EXPECT_TRUE(ThrowsConfigError([&] { (void)Study::LoadFile(values); }, "sweep.labels",
                                {"both named '4'"}));
}

TEST(StudyValidation, RejectsAStageDefinedTwice) {
  const StudyFiles f("stage_twice");
  const std::string path = f.Write(kSweep, "[{name: low}, {name: low}]");
  EXPECT_TRUE(ThrowsConfigError([&] { (void)Study::LoadFile(path); }, "stages[1].name",
                                {"'low' is defined twice"}));
}

TEST(StudyValidation, RejectsStartFromAnUnknownOrLaterStage) {
  const StudyFiles f("start_from");
  const std::string unknown = f.Write(kSweep, "[{name: low}, {name: high, start_from: mid}]");
  EXPECT_TRUE(ThrowsConfigError([&] { (void)Study::LoadFile(unknown); }, "stages[1].start_from",
                                {"earlier stage", "'mid'"}));
  // A later stage is not an earlier one.
  const std::string later = f.Write(kSweep, "[{name: low, start_from: high}, {name: high}]");
  EXPECT_TRUE(ThrowsConfigError([&] { (void)Study::LoadFile(later); }, "stages[0].start_from",
                                {"earlier stage", "'high'"}));
}

// ResultStore refusals.

TEST(ResultStoreErrors, ResumeWithoutAStore) {
  const std::string dir = test::TempDir("store_no_resume");
  const Experiment e =
      Experiment::FromString(test::ToyYaml("[random]"), "toy.yaml", QUADTUNE_SOURCE_DIR);
  const std::string path = dir + "/results.sqlite";
  EXPECT_TRUE(ThrowsConfigError([&] { ResultStore s(path, e, 1, /*resume=*/true); }, "--resume",
                                {"no results file to resume from"}));
  EXPECT_FALSE(std::filesystem::exists(path));
}

TEST(ResultStoreErrors, ResumeWithAnotherConfiguration) {
  const std::string dir = test::TempDir("store_other_config");
  const std::string path = dir + "/results.sqlite";
  const Experiment e =
      Experiment::FromString(test::ToyYaml("[random]"), "toy.yaml", QUADTUNE_SOURCE_DIR);
  { ResultStore s(path, e, 1, false); }
  EXPECT_NO_THROW(ResultStore(path, e, 1, true));
  const Experiment other =
      Experiment::FromString(test::ToyYaml("[random]", "", 8), "toy.yaml", QUADTUNE_SOURCE_DIR);
  EXPECT_TRUE(ThrowsConfigError([&] { ResultStore s(path, other, 1, true); }, "--resume",
                                {"another configuration"}));
}

TEST(ResultStoreErrors, OpeningAMissingStoreForExport) {
  const std::string dir = test::TempDir("store_missing");
  EXPECT_TRUE(ThrowsConfigError([&] { ResultStore s(dir + "/none.sqlite"); }, "",
                                {"none.sqlite", "no such results file"}));
}

int RunCli(const std::string& args, const std::string& log) {
  const std::string cmd =
      std::string(QUADTUNE_CLI_PROGRAM) + " " + args + " > '" + log + "' 2>&1";
  const int status = std::system(cmd.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::string ReadAll(const std::string& path) {
  std::ifstream in(path);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// A resumed run whose stored evaluations are not what this run asks (here: one stored long-term
// evaluation's parameters edited) is refused, naming --resume, and leaves the store as it was.
TEST(ResultStoreErrors, ResumedRunThatIsNotAPrefixOfTheStoredOne) {
  const std::string dir = test::TempDir("store_not_prefix");
  const std::string file = dir + "/toy.yaml";
  std::ofstream(file) << test::ToyYaml("[random]");
  ASSERT_EQ(RunCli("--log-level warn run --no-plot " + file + " --out " + dir + "/run --quiet",
                   dir + "/run.log"),
            0)
      << ReadAll(dir + "/run.log");
  const std::string store = dir + "/run/results.sqlite";
  // The unedited store resumes (every row replayed).
  ASSERT_EQ(
      RunCli("--log-level warn run --no-plot " + file + " --out " + dir + "/run --quiet --resume",
             dir + "/resume_ok.log"),
      0)
      << ReadAll(dir + "/resume_ok.log");
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(store.c_str(), &db), SQLITE_OK);
  char* error = nullptr;
  ASSERT_EQ(sqlite3_exec(db,
                         "UPDATE evaluation SET params = '{\"margin\":0.25,\"speed\":1.0}' WHERE "
                         "id = (SELECT MIN(id) FROM evaluation WHERE kind = 'long')",
                         nullptr, nullptr, &error),
            SQLITE_OK)
      << (error ? error : "");
  ASSERT_EQ(sqlite3_changes(db), 1);
  sqlite3_close(db);
  const auto before = test::Deterministic(store);
  EXPECT_EQ(
      RunCli("--log-level warn run --no-plot " + file + " --out " + dir + "/run --quiet --resume",
             dir + "/resume.log"),
      2);
  const std::string log = ReadAll(dir + "/resume.log");
  EXPECT_NE(log.find("--resume"), std::string::npos) << log;
  EXPECT_NE(log.find("not a prefix"), std::string::npos) << log;
  EXPECT_EQ(test::Deterministic(store), before);
}

}  // namespace
}  // namespace quadtune::engine
