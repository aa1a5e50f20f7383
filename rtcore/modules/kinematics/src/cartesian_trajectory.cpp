// cartesian_trajectory.cpp -- MoveL: the IK grid along the line, the re-timing against the
// joints' velocity and acceleration limits, and sampling by Hermite seed + Newton.
#include <indurop/kinematics/cartesian_trajectory.hpp>

#include <Eigen/LU>
#include <Eigen/SVD>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

namespace irp::kin {

namespace {
constexpr double kGridStep = 0.01;       // m between grid points, at most
constexpr double kGridAngle = 0.02;      // rad between grid points, at most
constexpr double kMaxGridJump = 0.15;    // rad: a grid solution this far from its prediction changed configuration
constexpr double kSingularRatio = 1e-5;  // smallest / largest singular value of J below this: singular
constexpr double kInf = std::numeric_limits<double>::infinity();
}  // namespace

const char *describe(PlanError error) noexcept {
    switch (error) {
    case PlanError::None: return "ok";
    case PlanError::OutsideLimits: return "the line leaves the joint limits";
    case PlanError::Unreachable: return "the line leaves the reachable space";
    case PlanError::Singular: return "the line crosses a singularity";
    case PlanError::TooSlow: return "the line passes too close to a singularity";
    }
    return "?";
}

Pose CartesianTrajectory::poseAt(double s) const noexcept {
    Pose p;
    p.position = start_.position + s * delta_p_;
    p.orientation = start_.orientation * Eigen::Quaterniond(Eigen::AngleAxisd(s * angle_, axis_local_));
    return p;
}

Joints CartesianTrajectory::seedAt(double s) const noexcept {
    if (grid_ == 0) return q_[0];
    double x = std::clamp(s, 0.0, 1.0) * grid_;
    int k = std::min(static_cast<int>(x), grid_ - 1);
    double u = x - k, h = 1.0 / grid_;
    double u2 = u * u, u3 = u2 * u;
    return (2 * u3 - 3 * u2 + 1) * q_[k] + (u3 - 2 * u2 + u) * h * dq_[k] + (-2 * u3 + 3 * u2) * q_[k + 1] +
           (u3 - u2) * h * dq_[k + 1];
}

Joints CartesianTrajectory::seedRateAt(double s) const noexcept {
    if (grid_ == 0) return Joints::Zero();
    double x = std::clamp(s, 0.0, 1.0) * grid_;
    int k = std::min(static_cast<int>(x), grid_ - 1);
    double u = x - k, h = 1.0 / grid_;
    double u2 = u * u;
    return ((6 * u2 - 6 * u) * q_[k] + (-6 * u2 + 6 * u) * q_[k + 1]) / h + (3 * u2 - 4 * u + 1) * dq_[k] +
           (3 * u2 - 2 * u) * dq_[k + 1];
}

PlanReport CartesianTrajectory::plan(const Joints &from, const Pose &target, const Joints &vmax, const Joints &amax,
                                     const CartesianLimits &cart, double speed, double accel) noexcept {
    PlanReport report;
    const Robot &robot = *robot_;
    auto refuse = [&](PlanError error, int joint, double s, const char *detail) {
        report.error = error;
        report.joint = joint;
        report.s = s;
        if (joint >= 0)
            std::snprintf(report.text, sizeof report.text, "MoveL refused: %s at %.0f%% of the line (joint %d%s%s)",
                          describe(error), 100 * s, joint + 1, *detail ? ": " : "", detail);
        else
            std::snprintf(report.text, sizeof report.text, "MoveL refused: %s at %.0f%% of the line%s%s",
                          describe(error), 100 * s, *detail ? ": " : "", detail);
        grid_ = 0;
        q_[0] = q_end_ = from;
        profile_.plan(0, 1, 1);
        return report;
    };

    start_ = robot.fk(from);
    target_ = target;
    target_.orientation.normalize();
    grid_ = 0;
    q_[0] = q_end_ = from;
    speed_scale_ = 1;
    delta_p_ = target_.position - start_.position;
    Eigen::AngleAxisd rel(start_.orientation.conjugate() * target_.orientation);
    angle_ = rel.angle();
    axis_local_ = angle_ > 1e-12 ? rel.axis() : Eigen::Vector3d::UnitZ();
    if (angle_ > M_PI) {  // the short way round
        angle_ = 2 * M_PI - angle_;
        axis_local_ = -axis_local_;
    }
    const double length = delta_p_.norm();
    xi_.head<3>() = delta_p_;
    xi_.tail<3>() = start_.orientation * (axis_local_ * angle_);
    speed = std::clamp(speed, 1e-6, 1.0);
    accel = std::clamp(accel, 1e-6, 1.0);

    if (int j = robot.outsideLimits(from, 1e-9); j >= 0) return refuse(PlanError::OutsideLimits, j, 0, "at the start");
    if (length < 1e-9 && angle_ < 1e-9) {  // already there
        profile_.plan(0, 1, 1);
        std::snprintf(report.text, sizeof report.text, "MoveL: already at the target");
        return report;
    }

    // The Cartesian bounds on s: translation and rotation, requested and full (for stops).
    double sd_cart = kInf, sdd_cart = kInf, sdd_cart_full = kInf;
    if (length > 0) {
        sd_cart = std::min(sd_cart, speed * cart.speed / length);
        sdd_cart = std::min(sdd_cart, accel * cart.accel / length);
        sdd_cart_full = std::min(sdd_cart_full, cart.accel / length);
    }
    if (angle_ > 0) {
        sd_cart = std::min(sd_cart, speed * cart.rot_speed / angle_);
        sdd_cart = std::min(sdd_cart, accel * cart.rot_accel / angle_);
        sdd_cart_full = std::min(sdd_cart_full, cart.rot_accel / angle_);
    }

    // 1. The grid: IK continued along the line, dq/ds = J^+ xi.
    int n = static_cast<int>(std::ceil(std::max(length / kGridStep, angle_ / kGridAngle)));
    n = std::clamp(n, 8, kMaxGrid);
    const double h = 1.0 / n;
    for (int k = 0; k <= n; ++k) {
        double s = k * h;
        if (k > 0) {
            // Second-order prediction from the last two points: one Newton step usually suffices.
            Joints predicted = q_[k - 1] + dq_[k - 1] * h;
            if (k > 1) predicted += 0.5 * h * (dq_[k - 1] - dq_[k - 2]);
            Joints q;
            if (robot.ikNear(poseAt(s), predicted, q, 20) != IkStatus::Ok)
                return refuse(PlanError::Unreachable, -1, s, "no joint values reach this point");
            Eigen::Index j;
            if ((q - predicted).cwiseAbs().maxCoeff(&j) > kMaxGridJump)
                return refuse(PlanError::Singular, static_cast<int>(j), s, "the arm would change configuration");
            q_[k] = q;
        }
        if (int j = robot.outsideLimits(q_[k]); j >= 0) return refuse(PlanError::OutsideLimits, j, s, "");
        // dq/ds = J^-1 xi (LU); at a singular J the pseudo-inverse (SVD), which is exact when the
        // line's direction is still one the tip can move in.
        Matrix6 J = robot.jacobian(q_[k]);
        Joints dq = J.partialPivLu().solve(xi_);
        if (!((J * dq - xi_).norm() <= 1e-9 * xi_.norm())) {
            Eigen::JacobiSVD<Matrix6> svd(J, Eigen::ComputeFullU | Eigen::ComputeFullV);
            const auto &sv = svd.singularValues();
            Vector6 inv = Vector6::Zero();
            for (int i = 0; i < 6; ++i)
                if (sv[i] > kSingularRatio * sv[0]) inv[i] = 1.0 / sv[i];
            dq = svd.matrixV() * inv.asDiagonal() * svd.matrixU().transpose() * xi_;
            if (!((J * dq - xi_).norm() <= 1e-6 * xi_.norm()))
                return refuse(PlanError::Singular, -1, s, "the tip cannot move along the line there");
        }
        dq_[k] = dq;
    }
    grid_ = n;
    q_end_ = q_[n];

    // 2. Re-timing.  Velocity: |dq_i/ds| * sd <= margin * vmax_i on every grid point.
    double sd_joint = kInf;
    int slow_joint = -1;
    for (int k = 0; k <= n; ++k)
        for (int i = 0; i < kAxes; ++i) {
            double r = kVelocityMargin * vmax[i] / std::abs(dq_[k][i]);
            if (r < sd_joint) sd_joint = r, slow_joint = i;
        }
    double sd = std::min(sd_cart, sd_joint);
    // Acceleration: |dq_i/ds| * sdd + |d2q_i/ds2| * sd^2 <= margin * amax_i.  The curvature term
    // may use at most half of the budget; beyond that the path speed is lowered.
    auto ddq = [&](int k) -> Joints {
        if (k == 0) return (dq_[1] - dq_[0]) / h;
        if (k == n) return (dq_[n] - dq_[n - 1]) / h;
        return (dq_[k + 1] - dq_[k - 1]) / (2 * h);
    };
    for (int k = 0; k <= n; ++k) {
        Joints c = ddq(k).cwiseAbs();
        for (int i = 0; i < kAxes; ++i) {
            double budget = 0.5 * kAccelerationMargin * amax[i];
            if (c[i] * sd * sd > budget) {
                sd = std::sqrt(budget / c[i]);
                slow_joint = i;
            }
        }
    }
    double sdd_joint = kInf;
    for (int k = 0; k <= n; ++k) {
        Joints c = ddq(k).cwiseAbs();
        for (int i = 0; i < kAxes; ++i)
            sdd_joint = std::min(sdd_joint, (kAccelerationMargin * amax[i] - c[i] * sd * sd) / std::abs(dq_[k][i]));
    }
    speed_scale_ = sd / sd_cart;
    if (speed_scale_ < kMinSpeedScale) {
        char detail[96];
        std::snprintf(detail, sizeof detail, "it would move at %.1f%% of the requested speed", 100 * speed_scale_);
        return refuse(PlanError::TooSlow, slow_joint, 0, detail);
    }
    const double sdd = std::min(sdd_cart, sdd_joint);
    stop_decel_ = std::min(sdd_cart_full, sdd_joint);
    profile_.plan(1.0, sd, sdd);
    if (speed_scale_ < 1)
        std::snprintf(report.text, sizeof report.text,
                      "MoveL slowed to %.0f%% of the requested speed by joint %d's limits (%.2f s)", 100 * speed_scale_,
                      slow_joint + 1, profile_.duration());
    else
        std::snprintf(report.text, sizeof report.text, "MoveL planned: %.3f m, %.3f rad in %.2f s", length, angle_,
                      profile_.duration());
    report.speed_scale = speed_scale_;
    report.joint = speed_scale_ < 1 ? slow_joint : -1;
    return report;
}

CartesianSample CartesianTrajectory::sample(double t) const noexcept {
    CartesianSample out;
    if (t >= profile_.duration()) {
        out.q = q_end_;
        out.s = profile_.finalPosition();
        out.done = true;
        return out;
    }
    ProfileState p = profile_.at(t);
    out.s = p.s;
    out.sd = p.v;
    Joints seed = seedAt(p.s);
    if (robot_->ikNear(poseAt(p.s), seed, out.q, 4) != IkStatus::Ok) {
        out.ok = false;
        out.q = seed;
    }
    if (p.v != 0) {
        Joints dq = robot_->jacobian(out.q).partialPivLu().solve(xi_);
        out.qd = (dq.allFinite() ? dq : seedRateAt(p.s)) * p.v;  // at a singular J: the grid's slope
    }
    return out;
}

void CartesianTrajectory::stop(double t) noexcept {
    if (profile_.stopping() || grid_ == 0) return;
    profile_.stopAt(t, stop_decel_);
    double s = profile_.finalPosition();
    Joints seed = seedAt(s);
    if (robot_->ikNear(poseAt(s), seed, q_end_, 6) != IkStatus::Ok) q_end_ = seed;
}

}  // namespace irp::kin
