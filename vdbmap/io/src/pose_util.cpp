#include "pose_util.hpp"

#include "vdbmap/io/tum_trajectory.hpp"

#include <Eigen/Geometry>
#include <Eigen/SVD>

#include <cmath>
#include <sstream>

namespace vdbmap::io::detail {

std::string poseFromTum(const double v[7], Pose3d& T) {
  for (int i = 0; i < 7; ++i)
    if (!std::isfinite(v[i])) return "pose has a non-finite value";
  const double n = std::sqrt(v[3] * v[3] + v[4] * v[4] + v[5] * v[5] + v[6] * v[6]);
  if (std::abs(n - 1.0) > kQuaternionNormTolerance) {
    std::ostringstream s;
    s << "quaternion norm is " << n << ", not 1 (tolerance " << kQuaternionNormTolerance << ")";
    return s.str();
  }
  T = poseFromTranslationQuaternion(Vec3d(v[0], v[1], v[2]), v[3], v[4], v[5], v[6]);
  return {};
}

std::string poseFromMatrix(const double* m, int rows, Pose3d& T) {
  for (int i = 0; i < rows * 4; ++i)
    if (!std::isfinite(m[i])) return "pose has a non-finite value";
  if (rows == 4 && (m[12] != 0.0 || m[13] != 0.0 || m[14] != 0.0 || m[15] != 1.0))
    return "pose matrix's last row is not 0 0 0 1";
  Eigen::Matrix3d R;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) R(r, c) = m[r * 4 + c];
  const double ortho_err = (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  const double det = R.determinant();
  if (ortho_err > kRotationMatrixTolerance || std::abs(det - 1.0) > kRotationMatrixTolerance) {
    std::ostringstream s;
    s << "rotation is not orthonormal with determinant +1 (max |R^T R - I| = " << ortho_err << ", det = " << det
      << ", tolerance " << kRotationMatrixTolerance << ")";
    return s.str();
  }
  T = Pose3d::Identity();
  // The nearest rotation (Frobenius norm): R = U V^T from the SVD R = U S V^T. Files hold 6-8
  // digits, so their matrices are orthonormal only to ~1e-5.
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(R, Eigen::ComputeFullU | Eigen::ComputeFullV);
  T.linear() = svd.matrixU() * svd.matrixV().transpose();
  T.translation() = Vec3d(m[3], m[7], m[11]);
  return {};
}

}  // namespace vdbmap::io::detail
