// The page: the template (assets/report.html) with its placeholders filled.
#include "report/assets.hpp"
#include "report/base64.hpp"
#include "report/report.hpp"

#include <algorithm>
#include <cstdint>
#include <map>
#include <stdexcept>
#include <string>

namespace vdbmap::report {
namespace {

std::string base64(std::string_view s) { return report::base64(s.data(), s.size()); }

std::string escapeHtml(const std::string& text) {
  std::string out;
  for (char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

/// Text inside <script>: "</" would end the element early, so it becomes "<\/" (the same string
/// to JSON and to JavaScript).
std::string scriptSafe(std::string text) {
  for (std::size_t at = text.find("</"); at != std::string::npos; at = text.find("</", at + 3)) text.insert(at + 1, "\\");
  return text;
}

/// The template with each "@NAME@" replaced by values[NAME], in one pass (so a value is never
/// searched for placeholders). Every name must occur exactly once.
std::string fill(std::string_view page, const std::map<std::string, std::string>& values) {
  std::string out;
  std::size_t filled = 0, from = 0, at = page.find('@');
  while (at != std::string_view::npos) {
    const std::size_t close = page.find('@', at + 1);
    if (close == std::string_view::npos) break;
    const auto it = values.find(std::string(page.substr(at + 1, close - at - 1)));
    if (it == values.end()) {  // not a placeholder: the second '@' may open one
      at = close;
      continue;
    }
    out.append(page.substr(from, at - from));
    out += it->second;
    ++filled;
    from = close + 1;
    at = page.find('@', from);
  }
  out.append(page.substr(std::min(from, page.size())));
  if (filled != values.size()) throw std::logic_error("the report template does not hold every placeholder once");
  return out;
}

}  // namespace

std::string renderReportHtml(const nlohmann::json& data) {
  const std::string_view page = asset("report.html");
  std::string licence(asset("LICENSE"));
  for (std::size_t at = licence.find("--"); at != std::string::npos; at = licence.find("--", at)) licence.replace(at, 2, "- -");
  return fill(page, {{"TITLE", escapeHtml(data.value("title", std::string("vdbmap report")))},
                     {"STYLE", std::string(asset("report.css"))},
                     {"THREE", base64(asset("three.module.min.js"))},
                     {"ORBIT_CONTROLS", base64(asset("OrbitControls.js"))},
                     {"SCRIPT", scriptSafe(std::string(asset("report.js")))},
                     {"THREE_LICENSE", licence},
                     {"DATA", scriptSafe(data.dump())}});
}

}  // namespace vdbmap::report
