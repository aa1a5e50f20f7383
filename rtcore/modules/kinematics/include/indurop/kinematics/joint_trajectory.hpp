// joint_trajectory.hpp -- MoveJ: a synchronized point-to-point move in joint space, and the
// joint-space stop from any moving state.
//
// q(t) = start + direction * sigma(t), with sigma a trapezoidal profile: every joint moves along
// the straight line in joint space, all start and arrive together, and the common profile is the
// fastest one for which every joint stays within speed * its velocity limit and accel * its
// acceleration limit (the joint with the largest travel relative to its limits sets the pace).
// plan() and sample() do not allocate.
#pragma once

#include <indurop/kinematics/pose.hpp>
#include <indurop/kinematics/profile.hpp>

namespace irp::kin {

struct JointSample {
    Joints q = Joints::Zero();    // rad
    Joints qd = Joints::Zero();   // rad/s
    Joints qdd = Joints::Zero();  // rad/s^2
    bool done = false;            // at the end, at rest
};

class JointTrajectory {
public:
    // From standstill at `from` to standstill at `to`.  vmax, amax: the joints' limits (> 0);
    // speed, accel: fractions of them in (0, 1].
    void plan(const Joints &from, const Joints &to, const Joints &vmax, const Joints &amax, double speed,
              double accel) noexcept;

    // From `q0` moving at `qd0` to standstill along the same direction, as fast as amax allows,
    // all joints stopping together.
    void planStop(const Joints &q0, const Joints &qd0, const Joints &amax) noexcept;

    JointSample sample(double t) const noexcept;

    // Decelerate from time t along the path at the joints' full acceleration limits.
    void stop(double t) noexcept;

    double duration() const noexcept { return profile_.duration(); }
    bool stopping() const noexcept { return profile_.stopping(); }
    Joints finalPosition() const noexcept;
    const Joints &start() const noexcept { return from_; }

private:
    Joints from_ = Joints::Zero(), to_ = Joints::Zero(), direction_ = Joints::Zero();
    double stop_decel_ = 1.0;  // sigma's deceleration at the full acceleration limits
    Trapezoid profile_;
};

}  // namespace irp::kin
