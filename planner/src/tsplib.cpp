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

// File content for an error message: shortened to 40 bytes, control bytes (below 0x20, and 0x7f)
// written as \xNN so that a hostile file cannot drive the terminal.
std::string shown(const std::string& s) {
  constexpr std::size_t kMaxShown = 40;
  static const char* const kHex = "0123456789abcdef";
  std::string out;
  for (std::size_t i = 0; i < s.size() && i < kMaxShown; ++i) {
    const auto c = static_cast<unsigned char>(s[i]);
    if (c < 0x20 || c == 0x7f) {
      out += "\\x";
      out += kHex[c >> 4];
      out += kHex[c & 0xf];
    } else {
      out += s[i];
    }
  }
  if (s.size() > kMaxShown) out += "...";
  return out;
}

// Bytes from the stream's position to its end, or -1 when the stream cannot seek (a pipe).
std::streamoff bytesLeft(std::istream& in) {
  const std::streampos here = in.tellg();
  if (here == std::streampos(-1)) return -1;
  in.seekg(0, std::ios::end);
  const std::streampos end = in.tellg();
  in.clear();
  in.seekg(here);
  if (end == std::streampos(-1) || !in) return -1;
  return std::streamoff(end - here);
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
  [[noreturn]] void fail(const std::string& what) const { failAt(line_number_, what); }
  [[noreturn]] void failAt(std::size_t line, const std::string& what) const {
    throw std::runtime_error(source_ + ":" + std::to_string(line) + ": " + what);
  }

  bool nextLine(std::string& line) {
    if (!std::getline(*weights_in_, line)) return false;
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
      if (colon == std::string::npos) fail("expected 'KEY: value' in the header, got '" + shown(text) + "'");
      if (key == "NAME") {
        instance_.name = value;
      } else if (key == "TYPE") {
        instance_.type = value;
        if (upper(value) != "ATSP" && upper(value) != "TSP")
          fail("TYPE '" + shown(value) + "' is not supported (ATSP or TSP)");
      } else if (key == "COMMENT") {
        instance_.comment += (instance_.comment.empty() ? "" : "; ") + value;
      } else if (key == "DIMENSION") {
        long long n = 0;
        const auto [end, ec] = std::from_chars(value.data(), value.data() + value.size(), n);
        if (ec != std::errc() || end != value.data() + value.size() || n < 1 || std::size_t(n) > kMaxAtspNodes)
          fail("DIMENSION '" + shown(value) + "' is not an integer in [1, " + std::to_string(kMaxAtspNodes) + "]");
        dimension_ = std::size_t(n);
        dimension_line_ = line_number_;
      } else if (key == "EDGE_WEIGHT_TYPE") {
        if (upper(value) != "EXPLICIT")
          fail("EDGE_WEIGHT_TYPE '" + shown(value) + "' is not supported (EXPLICIT only)");
        explicit_weights_ = true;
      } else if (key == "EDGE_WEIGHT_FORMAT") {
        if (upper(value) != "FULL_MATRIX")
          fail("EDGE_WEIGHT_FORMAT '" + shown(value) + "' is not supported (FULL_MATRIX only)");
        full_matrix_ = true;
      } else if (key.size() > 8 && key.compare(key.size() - 8, 8, "_SECTION") == 0) {
        fail("section " + shown(key) + " is not supported (EDGE_WEIGHT_SECTION only)");
      }  // other keys (CAPACITY, ...) carry nothing a full matrix needs
    }
    fail("no EDGE_WEIGHT_SECTION");
  }

  void checkHeaderComplete() const {
    if (dimension_ == 0) fail("EDGE_WEIGHT_SECTION before DIMENSION");
    if (!explicit_weights_) fail("EDGE_WEIGHT_SECTION without 'EDGE_WEIGHT_TYPE: EXPLICIT'");
    if (!full_matrix_) fail("EDGE_WEIGHT_SECTION without 'EDGE_WEIGHT_FORMAT: FULL_MATRIX'");
  }

  // DIMENSION^2 weights of at least one digit and a separator each (the last needs none) must fit
  // in what follows EDGE_WEIGHT_SECTION. When they cannot, the matrix (8 * DIMENSION^2 bytes) is
  // not allocated: the weights are still read, to report the first bad token or where the file
  // ends, so a short file declaring DIMENSION 20000 fails at once instead of taking 3 GB. A stream
  // that cannot seek (a pipe) is read into memory first so that its length is known.
  void readWeights() {
    std::streamoff left = bytesLeft(in_);
    if (left < 0) {
      buffered_ << in_.rdbuf();
      buffered_.clear();  // an empty rest sets failbit
      weights_in_ = &buffered_;
      left = bytesLeft(buffered_);
    }
    const std::size_t n = dimension_;
    const bool fits = left < 0 || n * n <= (std::size_t(left) + 1) / 2;
    const std::string too_short =
        fits ? std::string()
             : " (DIMENSION " + std::to_string(n) + " on line " + std::to_string(dimension_line_) + " needs at least " +
                   std::to_string(2 * n * n - 1) + " bytes of weights, the file has " + std::to_string(left) + ")";
    if (fits) instance_.costs = CostMatrix(n);
    std::size_t count = 0;
    bool at_eof = false;
    std::string line, token;
    while (nextLine(line)) {
      std::istringstream tokens(line);
      while (tokens >> token) {
        if (at_eof) fail("unexpected '" + shown(token) + "' after EOF");
        if (count == n * n) {
          if (upper(token) == "EOF") {
            at_eof = true;
            continue;
          }
          fail("more than DIMENSION^2 = " + std::to_string(n * n) + " weights (extra token '" + shown(token) + "')");
        }
        if (upper(token) == "EOF")
          fail("EOF after " + std::to_string(count) + " of DIMENSION^2 = " + std::to_string(n * n) + " weights" +
               too_short);
        std::int64_t value = 0;
        const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
        if (ec != std::errc() || end != token.data() + token.size())
          fail("weight " + std::to_string(count) + " (row " + std::to_string(count / n) + ", column " +
               std::to_string(count % n) + ") '" + shown(token) + "' is not an integer");
        if (fits) instance_.costs(count / n, count % n) = value;
        ++count;
      }
    }
    if (count < n * n)
      fail("file ends after " + std::to_string(count) + " of DIMENSION^2 = " + std::to_string(n * n) + " weights" +
           too_short);
    if (!fits)  // unreachable while the bound holds; kept so that a short file can never pass
      failAt(dimension_line_, "DIMENSION " + std::to_string(n) + ": the weights do not fit the file" + too_short);
  }

  std::istream& in_;
  std::istream* weights_in_ = &in_;  ///< in_, or buffered_ when in_ cannot seek
  std::stringstream buffered_;
  std::string source_;
  std::size_t line_number_ = 0;
  std::size_t dimension_ = 0, dimension_line_ = 0;
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
