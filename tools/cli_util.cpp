#include "cli_util.hpp"

#include "vdbmap/atomic_file.hpp"

#include <cstdio>
#include <unistd.h>

namespace vdbmap::cli {

Progress::Progress(std::string label)
    : label_(std::move(label)), tty_(::isatty(STDERR_FILENO) != 0) {}

void Progress::update(std::size_t done, std::size_t total) {
  const double elapsed = since_start_.s();
  const double rate = elapsed > 0 ? double(done) / elapsed : 0.0;
  const double eta = rate > 0 ? double(total - done) / rate : 0.0;
  if (tty_) {
    const int width = 30;
    const int filled = total ? int(width * double(done) / double(total)) : width;
    std::fprintf(stderr, "\r%s [%.*s%*s] %zu/%zu  %.1f frames/s  ETA %.0f s ", label_.c_str(), filled,
                 "##############################", width - filled, "", done, total, rate, eta);
    std::fflush(stderr);
    return;
  }
  const int decile = total ? int(10.0 * double(done) / double(total)) : 10;
  if (decile != last_decile_) {
    last_decile_ = decile;
    std::fprintf(stderr, "%s: %zu/%zu frames, %.1f frames/s, ETA %.0f s\n", label_.c_str(), done, total, rate, eta);
  }
}

void Progress::finish() {
  if (tty_) std::fprintf(stderr, "\n");
}

void writeJson(const std::filesystem::path& path, const nlohmann::json& json) {
  vdbmap::writeFileAtomically(path, [&](std::ostream& out) { out << json.dump(2) << "\n"; });
}

}  // namespace vdbmap::cli
