#include "vdbmap/field_check.hpp"

#include <sstream>
#include <stdexcept>

namespace vdbmap {

void FieldCheck::fail(const std::string& field, const std::string& range) const {
  throw std::invalid_argument(owner_ + "." + field + " must be in " + range);
}

void FieldCheck::fail(const std::string& field, const std::string& range, double value) const {
  std::ostringstream msg;
  msg << owner_ << "." << field << " must be in " << range << ", got " << value;
  throw std::invalid_argument(msg.str());
}

void FieldCheck::inRange(const std::string& field, double value, double lo, double hi) const {
  if (value >= lo && value <= hi) return;
  std::ostringstream range;
  range << "[" << lo << ", " << hi << "]";
  fail(field, range.str(), value);
}

}  // namespace vdbmap
