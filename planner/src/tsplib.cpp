// TSPLIB full-matrix reader: a line-oriented header, then the weights as a token stream.
#include "vdbmap/planner/tsplib.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace vdbmap::planner {
namespace {

std::string trim(const std::string& s) {
  const auto first = std::find_if_not(s.begin(), s.end(), [](unsigned char c) { return std::isspace(c); });
  const auto last = std::find_if_not(s.rbegin(), s.rend(), [](unsigned char c) { return std::isspace(c); }).base();
  return first < last ? std::string(first, last) : std::string();
}

std::string upper(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return char(std::toupper(c)); });
  return s;
}

class Parser {
 public:
  Parser(std::istream& in, std::string source) : in_(in), source_(std::move(source)) {}

  TsplibInstance parse() {
    readHeader();
    readWeights();
    return std::move(instance_);
  }

 private:
  [[noreturn]] void fail(const std::string& what) const {
    throw std::runtime_error(source_ + ":" + std::to_string(line_number_) + ": " + what);
  }

  bool nextLine(std::string& line) {
    if (!std::getline(in_, line)) return false;
    ++line_number_;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    return true;
  }

  void readHeader() {
    std::string line;
    while (nextLine(line)) {
      const std::string text = trim(line);
      if (text.empty()) continue;
      const std::size_t colon = text.find(':');
      const std::string key = upper(trim(text.substr(0, colon)));
      const std::string value = colon == std::string::npos ? std::string() : trim(text.substr(colon + 1));
      if (key == "EDGE_WEIGHT_SECTION") {
        checkHeaderComplete();
        return;
      }
      if (key == "EOF") fail("EOF before EDGE_WEIGHT_SECTION");
      if (colon == std::string::npos) fail("expected 'KEY: value' in the header, got '" + text + "'");
      if (key == "NAME") {
        instance_.name = value;
      } else if (key == "TYPE") {
        instance_.type = value;
        if (upper(value) != "ATSP" && upper(value) != "TSP")
          fail("TYPE '" + value + "' is not supported (ATSP or TSP)");
      } else if (key == "COMMENT") {
        instance_.comment += (instance_.comment.empty() ? "" : "; ") + value;
      } else if (key == "DIMENSION") {
        long long n = 0;
        const auto [end, ec] = std::from_chars(value.data(), value.data() + value.size(), n);
        if (ec != std::errc() || end != value.data() + value.size() || n < 1 || std::size_t(n) > kMaxAtspNodes)
          fail("DIMENSION '" + value + "' is not an integer in [1, 65536]");
        dimension_ = std::size_t(n);
      } else if (key == "EDGE_WEIGHT_TYPE") {
        if (upper(value) != "EXPLICIT") fail("EDGE_WEIGHT_TYPE '" + value + "' is not supported (EXPLICIT only)");
        explicit_weights_ = true;
      } else if (key == "EDGE_WEIGHT_FORMAT") {
        if (upper(value) != "FULL_MATRIX")
          fail("EDGE_WEIGHT_FORMAT '" + value + "' is not supported (FULL_MATRIX only)");
        full_matrix_ = true;
      } else if (key.size() > 8 && key.compare(key.size() - 8, 8, "_SECTION") == 0) {
        fail("section " + key + " is not supported (EDGE_WEIGHT_SECTION only)");
      }  // other keys (CAPACITY, ...) carry nothing a full matrix needs
    }
    fail("no EDGE_WEIGHT_SECTION");
  }

  void checkHeaderComplete() const {
    if (dimension_ == 0) fail("EDGE_WEIGHT_SECTION before DIMENSION");
    if (!explicit_weights_) fail("EDGE_WEIGHT_SECTION without 'EDGE_WEIGHT_TYPE: EXPLICIT'");
    if (!full_matrix_) fail("EDGE_WEIGHT_SECTION without 'EDGE_WEIGHT_FORMAT: FULL_MATRIX'");
  }

  void readWeights() {
    const std::size_t n = dimension_;
    instance_.costs = CostMatrix(n);
    std::size_t count = 0;
    bool at_eof = false;
    std::string line, token;
    while (nextLine(line)) {
      std::istringstream tokens(line);
      while (tokens >> token) {
        if (at_eof) fail("unexpected '" + token + "' after EOF");
        if (count == n * n) {
          if (upper(token) == "EOF") {
            at_eof = true;
            continue;
          }
          fail("more than DIMENSION^2 = " + std::to_string(n * n) + " weights (extra token '" + token + "')");
        }
        if (upper(token) == "EOF")
          fail("EOF after " + std::to_string(count) + " of DIMENSION^2 = " + std::to_string(n * n) + " weights");
        std::int64_t value = 0;
        const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
        if (ec != std::errc() || end != token.data() + token.size())
          fail("weight " + std::to_string(count) + " (row " + std::to_string(count / n) + ", column " +
               std::to_string(count % n) + ") '" + token + "' is not an integer");
        instance_.costs(count / n, count % n) = value;
        ++count;
      }
    }
    if (count < n * n)
      fail("file ends after " + std::to_string(count) + " of DIMENSION^2 = " + std::to_string(n * n) + " weights");
  }

  std::istream& in_;
  std::string source_;
  std::size_t line_number_ = 0;
  std::size_t dimension_ = 0;
  bool explicit_weights_ = false, full_matrix_ = false;
  TsplibInstance instance_;
};

}  // namespace

TsplibInstance parseTsplib(std::istream& in, const std::string& source) { return Parser(in, source).parse(); }

TsplibInstance readTsplib(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path.string() + ": cannot open the file");
  TsplibInstance instance = parseTsplib(in, path.string());
  if (instance.name.empty()) instance.name = path.stem().string();
  return instance;
}

}  // namespace vdbmap::planner
