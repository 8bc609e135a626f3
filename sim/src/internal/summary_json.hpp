// A run folder's summary.json as JSON (sim-internal): what readExplorationSummary reads, for
// callers that also look at keys ExplorationSummary does not hold (a resumed benchmark's options).
#pragma once

#include "vdbmap/sim/exploration.hpp"

#include <nlohmann/json.hpp>

#include <filesystem>

namespace vdbmap::sim::internal {

/// The file's JSON object. Throws std::runtime_error naming the file when it cannot be opened or is
/// not a JSON object.
nlohmann::json readSummaryJson(const std::filesystem::path& summary_json);

/// The summary `j` (read from `file`, which errors name) holds; throws std::runtime_error naming
/// the file and the key when a key is missing or of another type.
ExplorationSummary explorationSummaryOf(const nlohmann::json& j, const std::filesystem::path& file);

/// A length that may not be known (ExplorationSummary holds those as negative): null in JSON, as
/// summary.json writes and explorationSummaryOf reads it.
inline nlohmann::json knownOrNull(double length_m) {
  return length_m >= 0.0 ? nlohmann::json(length_m) : nlohmann::json(nullptr);
}

}  // namespace vdbmap::sim::internal
