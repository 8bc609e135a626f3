// Private helpers of the file readers: whole-file reading, line iteration with line numbers,
// locale-independent number parsing, and error messages of the form "<file>:<line>: <what>".
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace vdbmap::io::detail {

/// The whole content of a file; throws FileError naming the file when it cannot be read.
std::string readWholeFile(const std::filesystem::path& path);

/// "<file>:<line>: <what>" as a FileError. Control bytes in the file name and in `what` (which
/// may quote file content) are escaped with escapeControl().
[[noreturn]] void failAt(const std::filesystem::path& path, std::size_t line, const std::string& what);
/// "<file>: <what>" as a FileError, escaped like failAt().
[[noreturn]] void fail(const std::filesystem::path& path, const std::string& what);

/// Iterates over the lines of a text held in memory, counting from 1; strips a trailing '\r'.
class LineReader {
 public:
  explicit LineReader(std::string_view text) : text_(text) {}
  bool next(std::string_view& line);
  std::size_t lineNumber() const { return line_; }  ///< number of the line last returned
  std::size_t offset() const { return pos_; }       ///< byte offset just past the last line
 private:
  std::string_view text_;
  std::size_t pos_ = 0;
  std::size_t line_ = 0;
};

std::string_view trim(std::string_view s);
/// Splits on spaces and tabs (no empty tokens).
void splitWhitespace(std::string_view s, std::vector<std::string_view>& out);
/// Splits on `sep`, keeping empty fields, trimming spaces around each.
void splitOn(std::string_view s, char sep, std::vector<std::string_view>& out);

/// Parses the whole token as a number (a leading '+' is allowed; "nan" and "inf" are accepted
/// for doubles). Returns false when the token is not a number.
bool parseDouble(std::string_view token, double& value);
bool parseInt64(std::string_view token, std::int64_t& value);

/// A token for error messages: quoted, shortened to 40 bytes, control bytes escaped.
std::string quoteToken(std::string_view token);

}  // namespace vdbmap::io::detail
