// Fuzz target: TUM trajectories (io::readTumTrajectory), strict and lenient about time order;
// a trajectory that parses is then used as groundtruth.txt and corrections/ are (poses at stamps
// and a correction applied to itself), where hostile stamps meet the interpolation.
#include "fuzz_support.hpp"

#include "vdbmap/io/pose_interpolation.hpp"
#include "vdbmap/io/tum_trajectory.hpp"

#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace vdbmap;
  const std::filesystem::path file = fuzz::freshScratchDir() / "groundtruth.txt";
  fuzz::writeFile(file, data, size);
  fuzz::expectRefusalOrSuccess([&] { io::readTumTrajectory(file, /*require_increasing=*/false); });
  fuzz::expectRefusalOrSuccess([&] {
    std::vector<std::size_t> lines;
    const std::vector<io::StampedPose> poses = io::readTumTrajectory(file, /*require_increasing=*/true, &lines);
    if (lines.size() != poses.size()) std::abort();  // one line number per pose, as documented
    if (poses.empty()) return;
    for (const io::StampedPose& p : poses) io::poseAt(poses, p.timestamp_s);
    for (std::size_t k = 1; k < poses.size(); ++k)
      io::poseAt(poses, 0.5 * (poses[k - 1].timestamp_s + poses[k].timestamp_s));
    io::applyCorrection(poses, poses);
    formatTumLine(poses.front());
  });
  return 0;
}
