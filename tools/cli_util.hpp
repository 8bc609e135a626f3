// Small helpers shared by the subcommands: progress display and JSON summaries.
#pragma once

#include "vdbmap/timing.hpp"

#include <nlohmann/json.hpp>

#include <cstddef>
#include <filesystem>
#include <string>

namespace vdbmap::cli {

/// A progress bar (frames, rate, ETA) on a terminal; a plain line every 10 % otherwise.
class Progress {
 public:
  explicit Progress(std::string label);
  void update(std::size_t done, std::size_t total);
  void finish();

 private:
  std::string label_;
  bool tty_;
  int last_decile_ = -1;
  Stopwatch since_start_;
};

/// Writes a JSON object to `path` atomically (temporary + rename), pretty-printed.
void writeJson(const std::filesystem::path& path, const nlohmann::json& json);

}  // namespace vdbmap::cli
