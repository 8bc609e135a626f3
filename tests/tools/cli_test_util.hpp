// Running the `vdbmap` CLI from tests: its exit status, its output in a file, fresh folders.
#pragma once

#include "common/fresh_dir.hpp"

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

namespace vdbmap::test {

/// Runs `vdbmap ARGS` (the build's CLI) with stdout and stderr into out_file; returns the exit status.
inline int runCli(const std::string& args, const std::filesystem::path& out_file) {
  const std::string cmd = std::string(VDBMAP_CLI_PATH) + " " + args + " > " + out_file.string() + " 2>&1";
  return std::system(cmd.c_str());
}

/// A whole file as text (empty when it cannot be read).
inline std::string slurp(const std::filesystem::path& p) {
  std::ifstream in(p);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}


}  // namespace vdbmap::test
