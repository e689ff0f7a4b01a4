#pragma once
/// \file
/// Shared by the fuzz targets: each target hands the fuzzer's bytes to one of quadtune's file
/// readers, through a real file (so the readers' file handling is fuzzed too). Bad input must
/// end in ConfigError (or, for the results store, a runtime_error naming the file); anything
/// else — a crash, a hang, a sanitizer report or another exception — is a finding.
///
/// Built two ways (test/fuzz/CMakeLists.txt): with clang's libFuzzer (QUADTUNE_FUZZ=ON,
/// scripts/fuzz.sh), and in every build with replay_main.cpp, which feeds the stored corpus in
/// test/fuzz/corpus/<target>/ through the same entry point as a ctest case.

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

namespace quadtune::fuzz {

/// Writes `data` to a per-process file named `name` in the temporary folder; returns its path.
inline std::string WriteInput(const std::uint8_t* data, std::size_t size, const std::string& name) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("quadtune_fuzz_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string path = (dir / name).string();
  std::ofstream(path, std::ios::binary | std::ios::trunc)
      .write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  return path;
}

}  // namespace quadtune::fuzz
