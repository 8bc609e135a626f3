// Hostile TSPLIB input: a DIMENSION the file cannot hold fails at once, naming the file, the line
// and DIMENSION, without allocating the DIMENSION^2 matrix (20000 nodes would take 3.2 GB), also
// from a stream that cannot seek; control bytes quoted from the file are escaped.
#include "vdbmap/planner/tsplib.hpp"

#include "vdbmap/test_io_helpers.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <sstream>
#include <streambuf>
#include <string>

using namespace vdbmap::planner;

namespace {

const char* const kHeader20000 =
    "NAME: big\nTYPE: ATSP\nDIMENSION: 20000\nEDGE_WEIGHT_TYPE: EXPLICIT\nEDGE_WEIGHT_FORMAT: FULL_MATRIX\n"
    "EDGE_WEIGHT_SECTION\n";

TsplibInstance parse(const std::string& text) {
  std::istringstream in(text);
  return parseTsplib(in, "test.atsp");
}

/// A stream buffer that cannot seek, like a pipe: tellg() fails on it.
class PipeBuf : public std::streambuf {
 public:
  explicit PipeBuf(std::string text) : text_(std::move(text)) {
    setg(text_.data(), text_.data(), text_.data() + text_.size());
  }

 private:
  std::string text_;
};

TsplibInstance parsePipe(const std::string& text) {
  PipeBuf buf(text);
  std::istream in(&buf);
  return parseTsplib(in, "pipe.atsp");
}

}  // namespace

TEST_CASE("a DIMENSION the file cannot hold fails naming the file, line and DIMENSION before allocating",
          "[tsplib][hostile]") {
  CHECK_THROWS_WITH(parse(std::string(kHeader20000) + "1 2 3\n"),
                    Catch::Contains("test.atsp:7:") &&
                        Catch::Contains("file ends after 3 of DIMENSION^2 = 400000000") &&
                        Catch::Contains("DIMENSION 20000 on line 3") && Catch::Contains("the file has 6)"));
  CHECK_THROWS_WITH(parse(std::string(kHeader20000) + "1 2 3\nEOF\n"),
                    Catch::Contains("EOF after 3") && Catch::Contains("DIMENSION 20000 on line 3"));
  // The first bad token is still the one reported.
  CHECK_THROWS_WITH(parse(std::string(kHeader20000) + "1 x 3\n"),
                    Catch::Contains("test.atsp:7:") && Catch::Contains("'x' is not an integer"));

  vdbmap::test::TempDir dir;
  vdbmap::test::writeText(dir / "big.atsp", std::string(kHeader20000) + "1 2 3\n");
  CHECK_THROWS_WITH(readTsplib(dir / "big.atsp"),
                    Catch::Contains((dir / "big.atsp").string() + ":7:") &&
                        Catch::Contains("DIMENSION 20000 on line 3"));
}

TEST_CASE("a DIMENSION beyond the solver's node limit is refused naming the field", "[tsplib][hostile]") {
  CHECK_THROWS_WITH(parse("NAME: a\nDIMENSION: 70000\n"),
                    Catch::Contains("test.atsp:2:") && Catch::Contains("DIMENSION '70000'") &&
                        Catch::Contains("65536"));
}

TEST_CASE("the byte bound is exact: a matrix written as tightly as possible still parses", "[tsplib][hostile]") {
  const std::string header =
      "NAME: t\nTYPE: ATSP\nDIMENSION: 2\nEDGE_WEIGHT_TYPE: EXPLICIT\nEDGE_WEIGHT_FORMAT: FULL_MATRIX\n"
      "EDGE_WEIGHT_SECTION\n";
  const TsplibInstance t = parse(header + "0 7 8 0");  // 4 weights in 7 bytes, no final newline
  REQUIRE(t.costs.size() == 2);
  CHECK(t.costs(0, 1) == 7);
  CHECK(t.costs(1, 0) == 8);
  CHECK_THROWS_WITH(parse(header + "0 7 8"), Catch::Contains("file ends after 3 of DIMENSION^2 = 4") &&
                                                 Catch::Contains("DIMENSION 2 on line 3"));
}

TEST_CASE("a stream that cannot seek is checked too, and a good one still parses", "[tsplib][hostile]") {
  CHECK_THROWS_WITH(parsePipe(std::string(kHeader20000) + "1 2 3\n"),
                    Catch::Contains("pipe.atsp:7:") && Catch::Contains("DIMENSION 20000 on line 3"));
  const TsplibInstance t = parsePipe(
      "NAME: p\nTYPE: ATSP\nDIMENSION: 2\nEDGE_WEIGHT_TYPE: EXPLICIT\nEDGE_WEIGHT_FORMAT: FULL_MATRIX\n"
      "EDGE_WEIGHT_SECTION\n0 5\n6 0\nEOF\n");
  REQUIRE(t.costs.size() == 2);
  CHECK(t.costs(0, 1) == 5);
  CHECK(t.costs(1, 0) == 6);
  // A header that ends at EDGE_WEIGHT_SECTION, with nothing after it.
  CHECK_THROWS_WITH(parsePipe("NAME: p\nDIMENSION: 2\nEDGE_WEIGHT_TYPE: EXPLICIT\nEDGE_WEIGHT_FORMAT: FULL_MATRIX\n"
                              "EDGE_WEIGHT_SECTION"),
                    Catch::Contains("file ends after 0 of DIMENSION^2 = 4"));
}

TEST_CASE("control bytes quoted from a TSPLIB file are escaped as \\xNN", "[tsplib][hostile]") {
  const auto message = [](const std::string& text) {
    try {
      parse(text);
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  const auto hasRawControl = [](const std::string& s) {
    return std::any_of(s.begin(), s.end(), [](char c) { return static_cast<unsigned char>(c) < 0x20 || c == 0x7f; });
  };
  const std::string type = message("NAME: a\nTYPE: \x1b[2J\x7f\n");
  INFO("message: " << type);
  CHECK(type.find("test.atsp:2:") != std::string::npos);
  CHECK(type.find("TYPE '\\x1b[2J\\x7f'") != std::string::npos);
  CHECK_FALSE(hasRawControl(type));
  const std::string weight = message(
      "NAME: a\nDIMENSION: 2\nEDGE_WEIGHT_TYPE: EXPLICIT\nEDGE_WEIGHT_FORMAT: FULL_MATRIX\nEDGE_WEIGHT_SECTION\n"
      "0 \x07\x08 1 0\n");
  INFO("message: " << weight);
  CHECK(weight.find("test.atsp:6:") != std::string::npos);
  CHECK(weight.find("'\\x07\\x08' is not an integer") != std::string::npos);
  CHECK_FALSE(hasRawControl(weight));
}
