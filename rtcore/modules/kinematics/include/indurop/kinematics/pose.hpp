// pose.hpp -- the kinematics' value types: six joint values, a Cartesian pose, and the
// "x y z roll pitch yaw" form of the cell's shared variables (dTarget, dWorldPos).
//
// Units: m and rad.  Roll, pitch and yaw are the URDF's (and KDL's) fixed-axis angles:
// R = Rz(yaw) * Ry(pitch) * Rx(roll).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace irp::kin {

inline constexpr int kAxes = 6;                  // the arm's joint count; Robot::load refuses others
using Joints = Eigen::Matrix<double, kAxes, 1>;  // rad, rad/s, rad/s^2
using Matrix6 = Eigen::Matrix<double, 6, 6>;
using Vector6 = Eigen::Matrix<double, 6, 1>;

struct Pose {
    Eigen::Vector3d position = Eigen::Vector3d::Zero();               // m, in the base frame
    Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();  // unit quaternion

    // From / to {x, y, z, roll, pitch, yaw}.  toXyzRpy gives pitch in [-pi/2, pi/2]; at
    // pitch = +-pi/2 (gimbal lock) it gives roll = 0.
    static Pose fromXyzRpy(const double xyzrpy[6]) noexcept;
    void toXyzRpy(double xyzrpy[6]) const noexcept;

    Eigen::Matrix3d rotation() const { return orientation.toRotationMatrix(); }
};

// Distance between the positions (m) and the angle of the relative rotation (rad, 0..pi).
double positionError(const Pose &a, const Pose &b) noexcept;
double orientationError(const Pose &a, const Pose &b) noexcept;

}  // namespace irp::kin
