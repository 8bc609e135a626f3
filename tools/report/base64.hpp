// Base64 (RFC 4648, with padding): how the page carries binary arrays and scripts as text.
#pragma once

#include <cstddef>
#include <string>

namespace vdbmap::report {

std::string base64(const void* data, std::size_t bytes);

}  // namespace vdbmap::report
