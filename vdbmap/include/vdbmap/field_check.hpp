// Range checks in the validate() of parameter structs: one message format for every library,
// "OWNER.FIELD must be in RANGE[, got VALUE]".
#pragma once

#include <string>

namespace vdbmap {

class FieldCheck {
 public:
  /// `owner`: the struct's name as users write it (e.g. "FrontierConfig").
  explicit FieldCheck(std::string owner) : owner_(std::move(owner)) {}

  /// Throws std::invalid_argument "OWNER.FIELD must be in RANGE" (RANGE in words: "[1, 64]",
  /// "(0, 1e4]", "non-empty finite boxes").
  [[noreturn]] void fail(const std::string& field, const std::string& range) const;
  /// The same followed by ", got VALUE", printed by a stream (1.79769e+308, never 309 digits).
  [[noreturn]] void fail(const std::string& field, const std::string& range, double value) const;
  /// Throws (with the value) unless lo <= value <= hi; NaN fails. The range reads "[lo, hi]".
  void inRange(const std::string& field, double value, double lo, double hi) const;

 private:
  std::string owner_;
};

}  // namespace vdbmap
