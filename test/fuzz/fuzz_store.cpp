// Fuzz target: the results store as `quadtune run --resume` opens it (see fuzz_util.hpp). A
// damaged store must be refused with a ConfigError naming it.
#include <string>

#include "fuzz_util.hpp"
#include "quadtune/common/error.hpp"
#include "quadtune/engine/experiment/experiment.hpp"
#include "quadtune/engine/store/result_store.hpp"

namespace {
const quadtune::engine::Experiment& Toy() {
  // The configuration of the corpus's stores (corpus/store/toy_run.sqlite), so that resuming
  // them gets past the configuration check.
  static const quadtune::engine::Experiment e = quadtune::engine::Experiment::FromString(
      "name: fuzz\nmethods: [default]\nplanner: {type: toy}\nparameters:\n"
      "  - {name: speed, lower: 0.5, upper: 6.0}\n  - {name: gain, lower: 0.1, upper: 1.0}\n"
      "short_term: [gain]\nlong_term: [speed]\nbudget: {flights: 2, flight_batch: 1}\n");
  return e;
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = quadtune::fuzz::WriteInput(data, size, "results.sqlite");
  for (const char* suffix : {"-wal", "-shm"}) std::filesystem::remove(path + suffix);
  try {
    quadtune::engine::ResultStore store(path, Toy(), 1, /*resume=*/true);
    (void)store.Evaluations();
  } catch (const quadtune::ConfigError&) {
    // A damaged store, refused as it should be.
  }
  return 0;
}
