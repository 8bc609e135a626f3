#include "vdbmap/types.hpp"

#include <cmath>

namespace vdbmap {

Pose3d poseFromTranslationQuaternion(const Vec3d& t, double qx, double qy, double qz, double qw) {
  Eigen::Quaterniond q(qw, qx, qy, qz);
  Pose3d T = Pose3d::Identity();
  // A zero quaternion cannot be normalised; keep its NaNs so that validation rejects the pose.
  const double n = q.norm();
  T.linear() = (n > 0.0 ? Eigen::Quaterniond(q.coeffs() / n) : q).toRotationMatrix();
  T.translation() = t;
  return T;
}

bool isValidRigidTransform(const Pose3d& T, double tolerance) {
  if (!T.matrix().allFinite()) return false;
  const Eigen::Matrix3d R = T.linear();
  if (!(R.transpose() * R).isApprox(Eigen::Matrix3d::Identity(), tolerance) &&
      ((R.transpose() * R) - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() > tolerance)
    return false;
  return std::abs(R.determinant() - 1.0) <= tolerance;
}

}  // namespace vdbmap
