// robot.cpp -- Robot: loading (urdfdom -> KDL chain -> solvers), FK, Jacobian and IK.
#include <indurop/kinematics/robot.hpp>

#include "urdf_chain.hpp"

#include <console_bridge/console.h>
#include <urdf_parser/urdf_parser.h>

#include <kdl/chainfksolverpos_recursive.hpp>
#include <kdl/chainiksolverpos_lma.hpp>
#include <kdl/chainjnttojacsolver.hpp>
#include <kdl/frames.hpp>
#include <kdl/jacobian.hpp>
#include <kdl/jntarray.hpp>

#include <Eigen/Cholesky>

#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
#include <sstream>

namespace irp::kin {

struct Robot::Impl {
    explicit Impl(UrdfChain c)
        : chain(std::move(c.chain)),
          fk(chain),
          jac(chain),
          lma(chain, lmaWeights(), 1e-8, 100, 1e-15),
          q_in(kAxes),
          q_out(kAxes),
          kdl_jacobian(kAxes) {}

    static Eigen::Matrix<double, 6, 1> lmaWeights() {
        Eigen::Matrix<double, 6, 1> w;
        w << 1, 1, 1, 0.3, 0.3, 0.3;  // ~ 1 rad of tool rotation weighs as 0.3 m
        return w;
    }

    KDL::Chain chain;  // referenced by the solvers below: Impl never moves
    KDL::ChainFkSolverPos_recursive fk;
    KDL::ChainJntToJacSolver jac;
    mutable KDL::ChainIkSolverPos_LMA lma;
    JointLimits limits;
    std::string base, tip;
    // Scratch, sized once.
    mutable KDL::JntArray q_in, q_out;
    mutable KDL::Jacobian kdl_jacobian;
};

namespace {

KDL::Frame toKdl(const Pose &p) {
    const Eigen::Quaterniond &q = p.orientation;
    return KDL::Frame(KDL::Rotation::Quaternion(q.x(), q.y(), q.z(), q.w()),
                      KDL::Vector(p.position.x(), p.position.y(), p.position.z()));
}

Pose fromKdl(const KDL::Frame &f) {
    Pose p;
    p.position = Eigen::Vector3d(f.p.x(), f.p.y(), f.p.z());
    double x, y, z, w;
    f.M.GetQuaternion(x, y, z, w);
    p.orientation = Eigen::Quaterniond(w, x, y, z);
    return p;
}

// The twist from `from` to `to` in the base frame: position difference and rotation vector.
// (KDL::diff resolves rotations only down to about 1e-6 rad: Rotation::GetRot treats smaller ones
// as none.  The quaternion of the relative rotation is exact to rounding.)
Vector6 poseError(const KDL::Frame &from, const KDL::Frame &to) {
    Eigen::Matrix3d a, b;
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) a(r, c) = from.M(r, c), b(r, c) = to.M(r, c);
    Eigen::Quaterniond d(b * a.transpose());
    if (d.w() < 0) d.coeffs() = -d.coeffs();
    double n = d.vec().norm();
    Vector6 e;
    e << to.p.x() - from.p.x(), to.p.y() - from.p.y(), to.p.z() - from.p.z(), 0, 0, 0;
    if (n > 0) e.tail<3>() = d.vec() * (2 * std::atan2(n, d.w()) / n);
    return e;
}

// Collects urdfdom's messages (console_bridge) while it parses, instead of printing them, so that
// a refusal carries urdfdom's reason.
class UrdfdomMessages : public console_bridge::OutputHandler {
public:
    UrdfdomMessages() { console_bridge::useOutputHandler(this); }
    ~UrdfdomMessages() override { console_bridge::restorePreviousOutputHandler(); }
    void log(const std::string &text, console_bridge::LogLevel level, const char *, int) override {
        if (level < console_bridge::CONSOLE_BRIDGE_LOG_ERROR) return;
        if (!text_.empty()) text_ += "; ";
        text_ += text;
    }
    const std::string &text() const { return text_; }

private:
    std::string text_;
};

}  // namespace

const char *describe(IkStatus status) noexcept {
    switch (status) {
    case IkStatus::Ok: return "ok";
    case IkStatus::NoConvergence: return "no joint values reach the pose (out of reach)";
    case IkStatus::OutsideLimits: return "the pose is reached only outside the joint limits";
    }
    return "?";
}

Robot::Robot(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Robot::Robot(Robot &&) noexcept = default;
Robot &Robot::operator=(Robot &&) noexcept = default;
Robot::~Robot() = default;

Result<Robot> Robot::load(const std::string &urdf_path, const std::string &base, const std::string &tip) {
    std::ifstream in(urdf_path);
    if (!in) return Error{urdf_path + ": cannot read the URDF (" + std::string(std::strerror(errno)) + ")"};
    std::stringstream text;
    text << in.rdbuf();
    auto robot = fromString(text.str(), base, tip);
    if (!robot) {
        std::string message = robot.error().message;
        if (message.rfind("URDF text", 0) == 0) message = urdf_path + message.substr(9);
        return Error{message};
    }
    return robot;
}

Result<Robot> Robot::fromString(const std::string &xml, const std::string &base, const std::string &tip) {
    const std::string where = "URDF text";
    urdf::ModelInterfaceSharedPtr model;
    std::string messages;
    {
        UrdfdomMessages capture;
        model = urdf::parseURDF(xml);
        messages = capture.text();
    }
    if (!model) return Error{where + ": urdfdom refused it: " + (messages.empty() ? "no reason given" : messages)};
    auto chain = chainFromUrdf(*model, base, tip, where);
    if (!chain) return chain.error();
    UrdfChain &c = chain.value();
    if (c.joint_names.size() != static_cast<size_t>(kAxes))
        return Error{where + ": the chain " + base + " -> " + tip + " has " + std::to_string(c.joint_names.size()) +
                     " movable joints; the robot module drives exactly " + std::to_string(kAxes)};
    JointLimits limits;
    for (int i = 0; i < kAxes; ++i) {
        limits.names[i] = c.joint_names[i];
        limits.lower[i] = c.lower[i];
        limits.upper[i] = c.upper[i];
        limits.velocity[i] = c.velocity[i];
        limits.effort[i] = c.effort[i];
    }
    auto impl = std::make_unique<Impl>(std::move(c));
    impl->limits = limits;
    impl->base = base;
    impl->tip = tip;
    return Robot(std::move(impl));
}

const JointLimits &Robot::limits() const noexcept { return impl_->limits; }
const std::string &Robot::baseLink() const noexcept { return impl_->base; }
const std::string &Robot::tipLink() const noexcept { return impl_->tip; }

int Robot::outsideLimits(const Joints &q, double tolerance) const noexcept {
    const JointLimits &l = impl_->limits;
    for (int i = 0; i < kAxes; ++i)
        if (!std::isfinite(q[i]) || q[i] < l.lower[i] - tolerance || q[i] > l.upper[i] + tolerance) return i;
    return -1;
}

Pose Robot::fk(const Joints &q) const noexcept {
    impl_->q_in.data = q;
    KDL::Frame f;
    impl_->fk.JntToCart(impl_->q_in, f);
    return fromKdl(f);
}

Matrix6 Robot::jacobian(const Joints &q) const noexcept {
    impl_->q_in.data = q;
    impl_->jac.JntToJac(impl_->q_in, impl_->kdl_jacobian);
    return impl_->kdl_jacobian.data;
}

IkStatus Robot::ikNear(const Pose &target, const Joints &seed, Joints &q, int max_iterations) const noexcept {
    const KDL::Frame goal = toKdl(target);
    Impl &m = *impl_;
    Joints x = seed;
    for (int it = 0; it <= max_iterations; ++it) {
        m.q_in.data = x;
        KDL::Frame f;
        m.fk.JntToCart(m.q_in, f);
        Vector6 err = poseError(f, goal);  // base frame: what is still to go
        if (err.head<3>().norm() < kIkTolerance && err.tail<3>().norm() < kIkTolerance) {
            q = x;
            return IkStatus::Ok;
        }
        if (it == max_iterations || !err.allFinite()) break;
        m.jac.JntToJac(m.q_in, m.kdl_jacobian);
        Matrix6 J = m.kdl_jacobian.data;
        // Damped least squares: dq = J^T (J J^T + l^2 I)^-1 err; l is small enough not to slow
        // the quadratic convergence away from singularities and keeps the step finite at them.
        Matrix6 A = J * J.transpose();
        A.diagonal().array() += 1e-10;
        Joints dq = J.transpose() * A.ldlt().solve(err);
        double largest = dq.cwiseAbs().maxCoeff();
        if (largest > 0.5) dq *= 0.5 / largest;  // far from the solution: bounded steps
        x += dq;
    }
    return IkStatus::NoConvergence;
}

bool Robot::wrapIntoLimits(Joints &q, const Joints &seed) const noexcept {
    const JointLimits &l = impl_->limits;
    for (int i = 0; i < kAxes; ++i) {
        if (!std::isfinite(q[i])) return false;
        if (!std::isfinite(l.lower[i]) && !std::isfinite(l.upper[i])) continue;  // continuous
        // Of q + 2 pi k within the limits, the one nearest the seed.
        double best = q[i], best_distance = INFINITY;
        double k0 = std::round((seed[i] - q[i]) / (2 * M_PI));
        for (int dk = -2; dk <= 2; ++dk) {
            double c = q[i] + 2 * M_PI * (k0 + dk);
            if (c < l.lower[i] || c > l.upper[i]) continue;
            if (std::abs(c - seed[i]) < best_distance) best = c, best_distance = std::abs(c - seed[i]);
        }
        if (best_distance == INFINITY) return false;
        q[i] = best;
    }
    return true;
}

IkStatus Robot::ik(const Pose &target, const Joints &seed, Joints &q) const noexcept {
    Impl &m = *impl_;
    const KDL::Frame goal = toKdl(target);
    bool reached_outside = false;

    // Accepts a candidate: wrapped into the limits, polished by Newton, checked against FK.
    auto accept = [&](Joints candidate) -> bool {
        Joints polished;
        if (ikNear(target, candidate, polished, 6) != IkStatus::Ok) return false;
        if (!wrapIntoLimits(polished, seed)) {
            reached_outside = true;
            return false;
        }
        Pose check = fk(polished);
        if (positionError(check, target) > 1e-9 || orientationError(check, target) > 1e-9) return false;
        q = polished;
        return true;
    };

    Joints near;
    if (ikNear(target, seed, near, 12) == IkStatus::Ok && accept(near)) return IkStatus::Ok;

    // LMA from the given seed, then from arm configurations spread over the workspace: the base
    // turned towards the target, away from it or as in the seed, shoulder and elbow in eight combinations, the
    // wrist bent either way.  A result outside the limits is tried again with its wrist flipped.
    auto tryLma = [&](const Joints &s) -> bool {
        m.q_in.data = s;
        int rc = m.lma.CartToJnt(m.q_in, goal, m.q_out);
        if (rc < 0 && rc != KDL::ChainIkSolverPos_LMA::E_INCREMENT_JOINTS_TOO_SMALL) return false;
        Joints found = m.q_out.data;
        if (accept(found)) return true;
        Joints flipped = found;
        flipped[3] += M_PI, flipped[4] = -flipped[4], flipped[5] += M_PI;
        return accept(flipped);
    };
    if (tryLma(seed)) return IkStatus::Ok;
    static constexpr double kArm[8][2] = {{0.3, -0.3}, {0.8, 0.4}, {-0.4, -1.8}, {1.5, 0.6},
                                          {2.2, 0.6},  {2.1, 1.0}, {-1.3, 0.2},  {1.7, -2.1}};
    const double toward = std::atan2(target.position.y(), target.position.x());
    for (double base : {toward, toward > 0 ? toward - M_PI : toward + M_PI, seed[0]})
        for (const auto &arm : kArm)
            for (double wrist : {1.0, -1.0}) {
                Joints s;
                s << base, arm[0], arm[1], 0, wrist, 0;
                if (tryLma(s)) return IkStatus::Ok;
            }
    return reached_outside ? IkStatus::OutsideLimits : IkStatus::NoConvergence;
}

}  // namespace irp::kin
