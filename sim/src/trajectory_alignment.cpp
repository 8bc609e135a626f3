#include "vdbmap/sim/trajectory_alignment.hpp"

#include <Eigen/Geometry>

#include <cmath>
#include <stdexcept>
#include <string>

namespace vdbmap::sim {

FlatPose alignYawTranslation(const std::vector<Vec3d>& from, const std::vector<Vec3d>& to) {
  if (from.size() != to.size())
    throw std::invalid_argument("alignYawTranslation: " + std::to_string(from.size()) + " points to align with " +
                                std::to_string(to.size()));
  if (from.size() < 2)
    throw std::invalid_argument("alignYawTranslation: needs at least 2 point pairs, got " +
                                std::to_string(from.size()));
  const Eigen::Index n = Eigen::Index(from.size());
  Eigen::MatrixXd src(2, n), dst(2, n);  // dynamic: GCC 12 misreads umeyama's fixed 2-row blocks
  double dz = 0.0;
  for (Eigen::Index i = 0; i < n; ++i) {
    const Vec3d& a = from[std::size_t(i)];
    const Vec3d& b = to[std::size_t(i)];
    if (!a.allFinite() || !b.allFinite())
      throw std::invalid_argument("alignYawTranslation: point pair " + std::to_string(i) + " is not finite");
    src.col(i) = a.head<2>();
    dst.col(i) = b.head<2>();
    dz += b.z() - a.z();
  }
  FlatPose T;
  T.position_W.z() = dz / double(n);
  const Eigen::Vector2d src_mean = src.rowwise().mean(), dst_mean = dst.rowwise().mean();
  if ((src.colwise() - src_mean).squaredNorm() == 0.0) {  // no spread in x-y: no yaw to recover
    T.position_W.head<2>() = dst_mean - src_mean;
    return T;
  }
  const Eigen::MatrixXd M = Eigen::umeyama(src, dst, false);  // 3 x 3, homogeneous
  T.yaw_rad = std::atan2(M(1, 0), M(0, 0));
  T.position_W.head<2>() = M.block(0, 2, 2, 1);
  return T;
}

Vec3d applyAlignment(const FlatPose& T, const Vec3d& p) {
  return Eigen::AngleAxisd(T.yaw_rad, Vec3d::UnitZ()) * p + T.position_W;
}

double alignedRmse(const FlatPose& T, const std::vector<Vec3d>& from, const std::vector<Vec3d>& to) {
  if (from.size() != to.size())
    throw std::invalid_argument("alignedRmse: " + std::to_string(from.size()) + " points against " +
                                std::to_string(to.size()));
  if (from.empty()) return 0.0;
  double sum = 0.0;
  for (std::size_t i = 0; i < from.size(); ++i) sum += (applyAlignment(T, from[i]) - to[i]).squaredNorm();
  return std::sqrt(sum / double(from.size()));
}

}  // namespace vdbmap::sim
