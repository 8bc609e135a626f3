// Reading our log format (docs/formats.md): sensor.json, frames.csv, corrections/, groundtruth.txt.
#include "importers.hpp"

#include "vdbmap/io/errors.hpp"

#include "pose_util.hpp"
#include "text_util.hpp"

#include <algorithm>
#include <sstream>

namespace vdbmap::io::detail {
namespace {

constexpr const char* kFramesHeader = "timestamp,file,tx,ty,tz,qx,qy,qz,qw";

std::string fmt(double v) {
  std::ostringstream s;
  s.precision(17);
  s << v;
  return s.str();
}

std::vector<CorrectionEvent> readCorrections(const std::filesystem::path& dir, const FrameSource& frames) {
  std::vector<CorrectionEvent> events;
  std::error_code ec;
  if (!std::filesystem::exists(dir, ec)) return events;
  if (!std::filesystem::is_directory(dir, ec)) fail(dir, "expected a folder of correction files");
  std::vector<std::filesystem::path> files;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    if (!entry.is_regular_file()) continue;
    if (entry.path().extension() != ".txt") continue;
    files.push_back(entry.path());
  }
  for (const std::filesystem::path& file : files) {
    CorrectionEvent ev;
    ev.file = file;
    if (!parseDouble(file.stem().string(), ev.event_timestamp_s) || !std::isfinite(ev.event_timestamp_s))
      fail(file, "a correction file must be named <event_timestamp>.txt, e.g. 12.500000.txt");
    const std::optional<std::size_t> at = frames.findFrame(ev.event_timestamp_s);
    if (!at) fail(file, "event timestamp " + file.stem().string() + " names no frame of frames.csv");
    ev.event_frame = *at;
    std::vector<std::size_t> lines;
    ev.poses = readTumTrajectory(file, /*require_increasing=*/true, &lines);
    if (ev.poses.empty()) fail(file, "correction lists no pose");
    // Any subset of stamps (applyCorrection interpolates for the rest), within the frames up to
    // the event, where the odometry is known; a stamp within the match tolerance of a frame's
    // becomes that frame's, so that the frame gets the listed pose exactly.
    const double first_s = frames.record(0).timestamp_s;
    for (std::size_t k = 0; k < ev.poses.size(); ++k) {
      double& t = ev.poses[k].timestamp_s;
      if (const std::optional<std::size_t> f = frames.findFrame(t)) t = frames.record(*f).timestamp_s;
      if (t < first_s || t > frames.record(ev.event_frame).timestamp_s)
        failAt(file, lines[k], "timestamp " + formatTimestamp(t) + " is outside the frames up to the event (" +
                                   formatTimestamp(first_s) + " to " + file.stem().string() +
                                   "), where the odometry is unknown");
      if (k > 0 && !(t > ev.poses[k - 1].timestamp_s))
        failAt(file, lines[k], "timestamp " + formatTimestamp(t) + " is not after the previous pose's frame");
    }
    events.push_back(std::move(ev));
  }
  std::sort(events.begin(), events.end(),
            [](const CorrectionEvent& a, const CorrectionEvent& b) { return a.event_timestamp_s < b.event_timestamp_s; });
  for (std::size_t k = 1; k < events.size(); ++k)
    if (events[k].event_frame == events[k - 1].event_frame)
      fail(events[k].file, "names the same frame as " + events[k - 1].file.filename().string());
  return events;
}

}  // namespace

FrameSourceContents readLog(const std::filesystem::path& folder) {
  std::error_code ec;
  if (!std::filesystem::is_directory(folder, ec)) throw FileError(folder.string() + ": no such folder");
  FrameSourceContents c;
  c.format = "log";
  c.root = folder;
  c.sensor = readSensorJson(folder / "sensor.json");
  c.description = "vdbmap log: sensor from sensor.json, poses T_W_S from frames.csv";

  const std::filesystem::path csv = folder / "frames.csv";
  if (!std::filesystem::exists(csv, ec)) fail(csv, "no such file");
  const std::string text = readWholeFile(csv);
  LineReader lines(text);
  std::string_view line;
  std::vector<std::string_view> f;
  bool have_header = false;
  const std::string csv_name = (folder.filename().empty() ? folder.parent_path().filename() : folder.filename()).string() + "/frames.csv";
  while (lines.next(line)) {
    if (trim(line).empty()) continue;
    const std::size_t ln = lines.lineNumber();
    if (!have_header) {
      const std::string_view h = trim(line);
      if (h != kFramesHeader) failAt(csv, ln, std::string("expected the header line '") + kFramesHeader + "'");
      have_header = true;
      continue;
    }
    splitOn(line, ',', f);
    if (f.size() != 9) failAt(csv, ln, "expected 9 comma-separated fields (" + std::string(kFramesHeader) + "), found " + std::to_string(f.size()));
    FrameRecord r;
    r.index = c.records.size();
    r.source = csv_name + ":" + std::to_string(ln);
    if (!parseDouble(f[0], r.timestamp_s) || !std::isfinite(r.timestamp_s))
      failAt(csv, ln, "timestamp " + quoteToken(f[0]) + " is not a finite number");
    if (!c.records.empty() && !(r.timestamp_s > c.records.back().timestamp_s))
      failAt(csv, ln, "timestamp " + fmt(r.timestamp_s) + " is not greater than the previous frame's (" +
                          fmt(c.records.back().timestamp_s) + "): frames must be in time order");
    if (f[1].empty()) failAt(csv, ln, "empty file name");
    const std::filesystem::path file{std::string(f[1])};
    r.file = file.is_absolute() ? file : folder / file;
    double v[7];
    for (int k = 0; k < 7 && r.problem.empty(); ++k)
      if (!parseDouble(f[std::size_t(2 + k)], v[k])) r.problem = "pose value " + quoteToken(f[std::size_t(2 + k)]) + " is not a number";
    if (r.problem.empty()) r.problem = poseFromTum(v, r.T_W_S);
    c.records.push_back(std::move(r));
  }
  if (!have_header) fail(csv, std::string("empty; expected the header line '") + kFramesHeader + "'");

  const FrameSource listing(FrameSourceContents{c.format, c.root, c.sensor, c.records, {}, {}, {}});
  c.corrections = readCorrections(folder / "corrections", listing);
  if (std::filesystem::exists(folder / "groundtruth.txt", ec)) c.ground_truth = readTumTrajectory(folder / "groundtruth.txt");
  return c;
}

}  // namespace vdbmap::io::detail
