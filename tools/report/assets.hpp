// The page's files, embedded in the program at build time (embed_assets.cmake): the HTML
// template, the style, the script, and the vendored three.js with its licence.
#pragma once

#include <string_view>

namespace vdbmap::report {

/// The embedded file `name` (e.g. "report.js", "three.module.min.js"); throws std::out_of_range
/// for an unknown name.
std::string_view asset(std::string_view name);

}  // namespace vdbmap::report
