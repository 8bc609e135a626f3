// The TSPLIB full-matrix reader: the shared benchmark files, the format's quirks (wrapped rows,
// junk diagonal, irregular header spacing, EOF), and errors that name the file, line and field.
#include "vdbmap/planner/tsplib.hpp"

#include "common/shared_data.hpp"

#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

using namespace vdbmap::planner;

namespace {

const std::filesystem::path kTsplib = vdbmap::test::sharedDataDir() / "tsplib_atsp";

TsplibInstance parse(const std::string& text) {
  std::istringstream in(text);
  return parseTsplib(in, "test.atsp");
}

const char* const kHeader3 =
    "NAME:tiny\nTYPE : ATSP\nCOMMENT:  three nodes\nDIMENSION  :   3\nEDGE_WEIGHT_TYPE:EXPLICIT\n"
    "EDGE_WEIGHT_FORMAT: FULL_MATRIX \nEDGE_WEIGHT_SECTION\n";

}  // namespace

TEST_CASE("irregular header spacing, wrapped rows, a junk diagonal and EOF", "[tsplib]") {
  const TsplibInstance t = parse(std::string(kHeader3) + " 9999 1 2\n 3\n9999\n4 5 6 9999 \nEOF\n");
  CHECK(t.name == "tiny");
  CHECK(t.type == "ATSP");
  CHECK(t.comment == "three nodes");
  REQUIRE(t.costs.size() == 3);
  CHECK(t.costs(0, 0) == 9999);  // kept as read; the solver ignores the diagonal
  CHECK(t.costs(0, 1) == 1);
  CHECK(t.costs(0, 2) == 2);
  CHECK(t.costs(1, 0) == 3);
  CHECK(t.costs(1, 2) == 4);
  CHECK(t.costs(2, 0) == 5);
  CHECK(t.costs(2, 1) == 6);
  // No EOF line and Windows line ends are fine too.
  const TsplibInstance u = parse(
      "NAME: u\r\nTYPE: ATSP\r\nDIMENSION: 2\r\nEDGE_WEIGHT_TYPE: EXPLICIT\r\n"
      "EDGE_WEIGHT_FORMAT: FULL_MATRIX\r\nEDGE_WEIGHT_SECTION\r\n0 7\r\n8 0\r\n");
  CHECK(u.costs(0, 1) == 7);
  CHECK(u.costs(1, 0) == 8);
}

TEST_CASE("every shared ATSP file parses with its dimension", "[tsplib]") {
  vdbmap::test::requireSharedData("tsplib_atsp/OPTIMA.txt");
  const std::map<std::string, std::size_t> dimensions = {
      {"br17", 17},    {"ftv33", 34},   {"ftv35", 36},   {"ftv38", 39},    {"p43", 43},
      {"ftv44", 45},   {"ftv47", 48},   {"ry48p", 48},   {"ft53", 53},     {"ftv55", 56},
      {"ftv64", 65},   {"ft70", 70},    {"ftv70", 71},   {"kro124p", 100}, {"ftv170", 171},
      {"rbg323", 323}, {"rbg358", 358}, {"rbg403", 403}, {"rbg443", 443}};
  for (const auto& [name, n] : dimensions) {
    const TsplibInstance t = readTsplib(kTsplib / (name + ".atsp"));
    CHECK(t.name == name);
    CHECK(t.costs.size() == n);
  }
  // br17's first row as printed in the file (it wraps after 16 numbers).
  const TsplibInstance br17 = readTsplib(kTsplib / "br17.atsp");
  CHECK(br17.costs(0, 0) == 9999);
  CHECK(br17.costs(0, 1) == 3);
  CHECK(br17.costs(0, 3) == 48);
  CHECK(br17.costs(0, 16) == 5);
  CHECK(br17.costs(1, 0) == 3);
}

TEST_CASE("bad files fail naming the file, the line and the field or token", "[tsplib][bad-input]") {
  CHECK_THROWS_WITH(readTsplib("/nonexistent/x.atsp"), Catch::Contains("/nonexistent/x.atsp"));
  CHECK_THROWS_WITH(parse(std::string(kHeader3) + "0 1 2\n3 x 5\n6 7 0\n"),
                    Catch::Contains("test.atsp:9") && Catch::Contains("'x'") && Catch::Contains("row 1, column 1"));
  CHECK_THROWS_WITH(parse(std::string(kHeader3) + "0 1 2\n3 0\n"), Catch::Contains("after 5 of DIMENSION^2 = 9"));
  CHECK_THROWS_WITH(parse(std::string(kHeader3) + "0 1 2\n3 0 5\n6 7 0 8\n"), Catch::Contains("extra token '8'"));
  CHECK_THROWS_WITH(parse(std::string(kHeader3) + "0 1 2\nEOF\n"), Catch::Contains("EOF after 3"));
  CHECK_THROWS_WITH(parse(std::string(kHeader3) + "0 1 2 3 0 5 6 7 0\nEOF\n1\n"), Catch::Contains("after EOF"));
  CHECK_THROWS_WITH(parse("NAME: a\nDIMENSION: 3\nEDGE_WEIGHT_TYPE: EXPLICIT\nEDGE_WEIGHT_FORMAT: LOWER_DIAG_ROW\n"),
                    Catch::Contains("test.atsp:4") && Catch::Contains("EDGE_WEIGHT_FORMAT"));
  CHECK_THROWS_WITH(
      parse("NAME: a\nEDGE_WEIGHT_TYPE: EXPLICIT\nEDGE_WEIGHT_FORMAT: FULL_MATRIX\nEDGE_WEIGHT_SECTION\n"),
      Catch::Contains("before DIMENSION"));
  CHECK_THROWS_WITH(parse("NAME: a\nDIMENSION: -4\n"), Catch::Contains("test.atsp:2") && Catch::Contains("DIMENSION"));
  CHECK_THROWS_WITH(parse("NAME: a\nTYPE: CVRP\n"), Catch::Contains("TYPE"));
  CHECK_THROWS_WITH(parse("NAME: a\nDIMENSION: 3\n"), Catch::Contains("no EDGE_WEIGHT_SECTION"));
  CHECK_THROWS_WITH(parse("NAME: a\nDIMENSION: 3\nEDGE_WEIGHT_TYPE: EUC_2D\n"), Catch::Contains("EDGE_WEIGHT_TYPE"));
}
