// pose.cpp -- Pose <-> x y z roll pitch yaw, and pose errors.
#include <indurop/kinematics/pose.hpp>

#include <kdl/frames.hpp>

#include <algorithm>
#include <cmath>

namespace irp::kin {

Pose Pose::fromXyzRpy(const double v[6]) noexcept {
    Pose p;
    p.position = Eigen::Vector3d(v[0], v[1], v[2]);
    double x, y, z, w;
    KDL::Rotation::RPY(v[3], v[4], v[5]).GetQuaternion(x, y, z, w);
    p.orientation = Eigen::Quaterniond(w, x, y, z).normalized();
    return p;
}

void Pose::toXyzRpy(double v[6]) const noexcept {
    v[0] = position.x();
    v[1] = position.y();
    v[2] = position.z();
    const Eigen::Quaterniond &q = orientation;
    KDL::Rotation::Quaternion(q.x(), q.y(), q.z(), q.w()).GetRPY(v[3], v[4], v[5]);
}

double positionError(const Pose &a, const Pose &b) noexcept { return (a.position - b.position).norm(); }

double orientationError(const Pose &a, const Pose &b) noexcept {
    // 2 atan2(|v|, |w|) of the relative quaternion: accurate near 0, where acos(w) is not.
    Eigen::Quaterniond d = a.orientation.conjugate() * b.orientation;
    return 2.0 * std::atan2(d.vec().norm(), std::abs(d.w()));
}

}  // namespace irp::kin
