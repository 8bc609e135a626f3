// Test data locations: the project's own fixtures (data/, always there) and the shared data folder
// (../shared/data, or $VDBMAP_SHARED_DATA), which a clone elsewhere may not have.
#pragma once

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

namespace vdbmap::test {

/// The exit code of a test case that skipped itself; every suite's CTest entries declare it as
/// SKIP_RETURN_CODE, so CTest reports such a case as skipped, never as passed.
inline constexpr int kSkipReturnCode = 77;

/// The shared data folder: $VDBMAP_SHARED_DATA when set (as the scripts set it), else the one
/// beside the source tree.
inline std::filesystem::path sharedDataDir() {
  const char* env = std::getenv("VDBMAP_SHARED_DATA");
  return env && *env ? std::filesystem::path(env) : std::filesystem::path(VDBMAP_SHARED_DATA_DIR);
}

/// `rel` under the shared data folder. When it is missing, the running test case is skipped: it
/// says why on stderr and exits the process with kSkipReturnCode (CTest runs one case per process;
/// run by hand, the executable stops at the first such case).
inline std::filesystem::path requireSharedData(const std::string& rel) {
  const std::filesystem::path path = sharedDataDir() / rel;
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) {
    std::fprintf(stderr, "SKIPPED: shared data not found at %s (set VDBMAP_SHARED_DATA)\n", path.c_str());
    std::fflush(stderr);
    std::_Exit(kSkipReturnCode);
  }
  return path;
}

/// The project's embedded worlds (data/worlds), always present.
inline std::filesystem::path embeddedWorld(const std::string& rel) {
  return std::filesystem::path(VDBMAP_TEST_DATA_DIR) / "worlds" / rel;
}

}  // namespace vdbmap::test
