// TSPLIB reader for explicit full-matrix instances (the ATSP benchmark files).
//
// Accepted: header lines "KEY: value" with any spacing around the colon; TYPE ATSP (or TSP);
// EDGE_WEIGHT_TYPE EXPLICIT; EDGE_WEIGHT_FORMAT FULL_MATRIX; then EDGE_WEIGHT_SECTION with
// n * n integers read as a token stream (rows may wrap across lines); an optional "EOF" line.
// The diagonal is kept as read (TSPLIB fills it with junk such as 9999); the solver ignores it.
#pragma once

#include "vdbmap/planner/atsp.hpp"

#include <filesystem>
#include <istream>
#include <string>

namespace vdbmap::planner {

struct TsplibInstance {
  std::string name;     ///< NAME, or the file's stem when absent
  std::string type;     ///< TYPE as written (ATSP or TSP)
  std::string comment;  ///< COMMENT lines joined by "; "
  CostMatrix costs;     ///< DIMENSION x DIMENSION
};

/// Reads a TSPLIB file. Throws std::runtime_error naming the file, the line and the field or
/// token on a missing file, an unsupported format, a bad number, or too few or too many weights.
TsplibInstance readTsplib(const std::filesystem::path& path);

/// Parses TSPLIB text from a stream; `source` names it in error messages.
TsplibInstance parseTsplib(std::istream& in, const std::string& source);

}  // namespace vdbmap::planner
