// Helpers shared by the I/O tests: fixture paths, a self-removing temporary folder, and raw file
// writing for corrupt-input cases.
#pragma once

#include "common/shared_data.hpp"

#include <catch2/catch.hpp>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <unistd.h>

namespace vdbmap::test {

inline std::filesystem::path fixture(const std::string& name) {
  return std::filesystem::path(VDBMAP_TEST_DATA_DIR) / "io" / name;
}
/// `rel` under the shared data folder; the test case is reported skipped when it is missing.
inline std::filesystem::path sharedData(const std::string& rel) { return requireSharedData(rel); }

/// A fresh folder under the system temp dir, removed with its content on destruction.
class TempDir {
 public:
  TempDir() {
    static std::atomic<unsigned> counter{0};
    path_ = std::filesystem::temp_directory_path() /
            ("vdbmap_io_test_" + std::to_string(::getpid()) + "_" + std::to_string(counter++));
    std::filesystem::remove_all(path_);
    std::filesystem::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::filesystem::path& path() const { return path_; }
  std::filesystem::path operator/(const std::string& name) const { return path_ / name; }

 private:
  std::filesystem::path path_;
};

inline void writeText(const std::filesystem::path& path, const std::string& text) {
  std::filesystem::create_directories(path.parent_path());
  std::ofstream out(path, std::ios::binary);
  out << text;
  REQUIRE(out.good());
}

inline std::string readBytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

/// Checks that `expr` throws a std::runtime_error whose message contains every given fragment.
#define VDBMAP_REQUIRE_THROWS_MENTIONING(expr, ...)                                  \
  do {                                                                               \
    bool vdbmap_thrown_ = false;                                                     \
    try {                                                                            \
      (void)(expr);                                                                  \
    } catch (const std::runtime_error& e) {                                          \
      vdbmap_thrown_ = true;                                                         \
      const std::string vdbmap_msg_ = e.what();                                      \
      INFO("message: " << vdbmap_msg_);                                              \
      for (const std::string& frag : std::initializer_list<std::string>{__VA_ARGS__}) \
        CHECK(vdbmap_msg_.find(frag) != std::string::npos);                          \
    }                                                                                \
    CHECK(vdbmap_thrown_);                                                           \
  } while (0)

}  // namespace vdbmap::test
