#include "vdbmap/io/tum_trajectory.hpp"

#include "vdbmap/atomic_file.hpp"
#include "vdbmap/io/errors.hpp"

#include "pose_util.hpp"
#include "text_util.hpp"

#include <Eigen/Geometry>

#include <cstdio>
#include <sstream>

namespace vdbmap::io {

std::vector<StampedPose> readTumTrajectory(const std::filesystem::path& path, bool require_increasing,
                                           std::vector<std::size_t>* line_numbers) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) throw FileError(path.string() + ": no such file");
  const std::string text = detail::readWholeFile(path);
  detail::LineReader lines(text);
  std::string_view line;
  std::vector<std::string_view> tok;
  std::vector<StampedPose> poses;
  if (line_numbers) line_numbers->clear();
  while (lines.next(line)) {
    const std::string_view t = detail::trim(line);
    if (t.empty() || t.front() == '#') continue;
    const std::size_t ln = lines.lineNumber();
    detail::splitWhitespace(t, tok);
    if (tok.size() != 8) detail::failAt(path, ln, "expected 'timestamp tx ty tz qx qy qz qw' (8 numbers), found " + std::to_string(tok.size()) + " fields");
    double v[8];
    for (int i = 0; i < 8; ++i)
      if (!detail::parseDouble(tok[std::size_t(i)], v[i])) detail::failAt(path, ln, "not a number: " + detail::quoteToken(tok[std::size_t(i)]));
    if (!std::isfinite(v[0])) detail::failAt(path, ln, "timestamp is not finite");
    StampedPose p;
    p.timestamp_s = v[0];
    const std::string why = detail::poseFromTum(v + 1, p.T_W_S);
    if (!why.empty()) detail::failAt(path, ln, why);
    if (require_increasing && !poses.empty() && !(p.timestamp_s > poses.back().timestamp_s)) {
      std::ostringstream s;
      s.precision(17);
      s << "timestamp " << p.timestamp_s << " is not greater than the previous one (" << poses.back().timestamp_s << ")";
      detail::failAt(path, ln, s.str());
    }
    poses.push_back(p);
    if (line_numbers) line_numbers->push_back(ln);
  }
  return poses;
}

std::string formatTimestamp(double timestamp_s) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.6f", timestamp_s);
  return buf;
}

std::string formatTumLine(const StampedPose& pose) {
  const Eigen::Quaterniond q(pose.T_W_S.linear());
  const Vec3d& t = pose.T_W_S.translation();
  char buf[256];
  std::snprintf(buf, sizeof(buf), "%s %.9g %.9g %.9g %.9g %.9g %.9g %.9g", formatTimestamp(pose.timestamp_s).c_str(), t.x(),
                t.y(), t.z(), q.x(), q.y(), q.z(), q.w());
  return buf;
}

void writeTumTrajectory(const std::filesystem::path& path, const std::vector<StampedPose>& poses) {
  writeFileAtomically(path, [&](std::ostream& out) {
    out << "# timestamp tx ty tz qx qy qz qw\n";
    for (const StampedPose& p : poses) out << formatTumLine(p) << '\n';
  });
}

}  // namespace vdbmap::io
