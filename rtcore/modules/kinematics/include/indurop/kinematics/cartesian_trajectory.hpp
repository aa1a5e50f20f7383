// cartesian_trajectory.hpp -- MoveL: the tip moves on the straight line from its pose at the
// start to the target, its orientation interpolated by slerp (a rotation about one fixed axis at
// a rate proportional to the position's), both driven by one path parameter s (0 -> 1) timed by
// a trapezoidal profile.
//
// Planning (allocation-free, bounded: at most kMaxGrid + 1 IK solutions):
//   1. the path is sampled on a grid of s (about every 1 cm or 1 degree); each grid point is
//      solved by IK continued from the previous one (no change of arm configuration on the way),
//      and dq/ds there is J^-1 * xi (the pseudo-inverse where J is singular), with xi the path's
//      constant twist per unit of s;
//   2. the path speed and acceleration are the requested fractions of the Cartesian maxima
//      (translation and rotation), lowered where needed so that every joint stays within its
//      velocity limit (|dq/ds| * ds/dt) and its acceleration limit (|dq/ds| * d2s/dt2 +
//      |d2q/ds2| * (ds/dt)^2) everywhere on the grid, with a safety margin: the plan is re-timed,
//      and speedScale() says by how much;
//   3. it is refused, with the joint and the place along the path, when a grid point is out of
//      reach, outside the joint limits, at a singularity, or when the re-timing would need less
//      than kMinSpeedScale of the requested speed (the line passes too close to a singularity).
// Sampling: s(t) from the profile, the pose on the line, IK from the grid's Hermite interpolation
// (one or two Newton steps), joint velocities from the Jacobian.  Allocation-free.
#pragma once

#include <indurop/kinematics/pose.hpp>
#include <indurop/kinematics/profile.hpp>
#include <indurop/kinematics/robot.hpp>

#include <array>

namespace irp::kin {

struct CartesianLimits {
    double speed = 0.5;      // m/s of the tip
    double accel = 2.0;      // m/s^2
    double rot_speed = 1.5;  // rad/s of the tip's orientation
    double rot_accel = 6.0;  // rad/s^2
};

enum class PlanError {
    None,
    OutsideLimits,  // a point of the line needs a joint outside its limits
    Unreachable,    // a point of the line (or the target) is out of reach
    Singular,       // the line crosses a singularity (the motion is impossible there, or changes configuration)
    TooSlow,        // the line passes so close to a singularity that it would crawl
};
const char *describe(PlanError error) noexcept;

struct PlanReport {
    PlanError error = PlanError::None;
    int joint = -1;          // the joint concerned (0-based), or -1
    double s = 0;            // where along the line (0 = start, 1 = target)
    double speed_scale = 1;  // planned path speed / the requested one (< 1: slowed by a joint)
    char text[200] = {};     // one sentence for the log (formatted without allocation)
    explicit operator bool() const noexcept { return error == PlanError::None; }
};

struct CartesianSample {
    Joints q = Joints::Zero();   // rad
    Joints qd = Joints::Zero();  // rad/s
    double s = 0;                // path parameter
    double sd = 0;               // its rate, 1/s
    bool done = false;           // at the target (or where a stop ended), at rest
    bool ok = true;              // false: IK did not converge on this sample (q is the grid's estimate)
};

class CartesianTrajectory {
public:
    static constexpr int kMaxGrid = 128;
    static constexpr double kMinSpeedScale = 0.02;
    static constexpr double kVelocityMargin = 0.95;      // of each joint's velocity limit
    static constexpr double kAccelerationMargin = 0.90;  // of each joint's acceleration limit

    explicit CartesianTrajectory(const Robot &robot) : robot_(&robot) {}

    // From standstill at joint values `from` to standstill at `target`.  vmax, amax: the joints'
    // limits; cart: the Cartesian maxima; speed, accel: fractions of cart in (0, 1].  On refusal
    // the trajectory is left empty (duration 0, at `from`).
    PlanReport plan(const Joints &from, const Pose &target, const Joints &vmax, const Joints &amax,
                    const CartesianLimits &cart, double speed, double accel) noexcept;

    CartesianSample sample(double t) const noexcept;

    // Decelerate from time t along the line, at the largest rate the limits allow.
    void stop(double t) noexcept;

    double duration() const noexcept { return profile_.duration(); }
    bool stopping() const noexcept { return profile_.stopping(); }
    const Joints &finalPosition() const noexcept { return q_end_; }
    const Pose &startPose() const noexcept { return start_; }
    const Pose &targetPose() const noexcept { return target_; }
    Pose poseAt(double s) const noexcept;
    double speedScale() const noexcept { return speed_scale_; }
    int gridSize() const noexcept { return grid_; }

private:
    Joints seedAt(double s) const noexcept;      // Hermite interpolation of the grid
    Joints seedRateAt(double s) const noexcept;  // its derivative, dq/ds

    const Robot *robot_;
    Pose start_, target_;
    Eigen::Vector3d delta_p_ = Eigen::Vector3d::Zero();  // target - start position
    Eigen::Vector3d axis_local_ = Eigen::Vector3d::UnitZ();
    double angle_ = 0;
    Vector6 xi_ = Vector6::Zero();  // twist per unit of s (base frame, reference point at the tip)
    int grid_ = 0;                  // grid intervals; the grid has grid_ + 1 points
    std::array<Joints, kMaxGrid + 1> q_{}, dq_{};
    Joints q_end_ = Joints::Zero();
    double stop_decel_ = 1, speed_scale_ = 1;
    Trapezoid profile_;
};

}  // namespace irp::kin
