// joint_trajectory.cpp -- MoveJ timing: the normalized profile sigma (0 -> 1) whose velocity and
// acceleration, scaled by each joint's travel, stay within every joint's limits.
#include <indurop/kinematics/joint_trajectory.hpp>

#include <algorithm>
#include <cmath>
#include <limits>

namespace irp::kin {

namespace {
// The largest sigma rate r with |d_i| * r <= limit_i for every joint that moves.
double commonRate(const Joints &d, const Joints &limit) noexcept {
    double r = std::numeric_limits<double>::infinity();
    for (int i = 0; i < kAxes; ++i)
        if (std::abs(d[i]) > 0) r = std::min(r, limit[i] / std::abs(d[i]));
    return r;
}
}  // namespace

void JointTrajectory::plan(const Joints &from, const Joints &to, const Joints &vmax, const Joints &amax, double speed,
                           double accel) noexcept {
    from_ = from;
    to_ = to;
    direction_ = to - from;
    double v = commonRate(direction_, vmax * speed);
    double a = commonRate(direction_, amax * accel);
    stop_decel_ = commonRate(direction_, amax);
    if (!std::isfinite(v) || !std::isfinite(a)) {  // nothing moves
        profile_.plan(0, 1, 1);
        stop_decel_ = 1;
        return;
    }
    profile_.plan(1.0, v, a);
}

void JointTrajectory::planStop(const Joints &q0, const Joints &qd0, const Joints &amax) noexcept {
    from_ = q0;
    direction_ = qd0;  // sigma in seconds: sigma' = 1 at the start
    double d = commonRate(qd0, amax);
    if (!std::isfinite(d)) {
        to_ = q0;
        profile_.plan(0, 1, 1);
        stop_decel_ = 1;
        return;
    }
    stop_decel_ = d;
    profile_.planStop(1.0, d);
    to_ = q0 + qd0 * profile_.finalPosition();
}

JointSample JointTrajectory::sample(double t) const noexcept {
    JointSample out;
    ProfileState p = profile_.at(t);
    out.done = t >= profile_.duration();
    if (out.done) {
        out.q = finalPosition();
        return out;
    }
    out.q = from_ + direction_ * p.s;
    out.qd = direction_ * p.v;
    out.qdd = direction_ * p.a;
    return out;
}

void JointTrajectory::stop(double t) noexcept { profile_.stopAt(t, stop_decel_); }

Joints JointTrajectory::finalPosition() const noexcept {
    if (!profile_.stopping() && profile_.finalPosition() == 1.0) return to_;  // exactly the target
    return from_ + direction_ * profile_.finalPosition();
}

}  // namespace irp::kin
