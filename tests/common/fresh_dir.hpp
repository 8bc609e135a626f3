// An empty folder for a test case's files.
#pragma once

#include <filesystem>
#include <string>

namespace vdbmap::test {

/// An empty folder of this name under the temporary directory.
inline std::filesystem::path freshDir(const std::string& name) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / name;
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

}  // namespace vdbmap::test
