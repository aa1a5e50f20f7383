// test_kinematics.cpp -- the robot's kinematics and planners (rtcore/modules/kinematics) on
// config/robots/indurop6.urdf: loading and its refusals, FK against hand-worked poses, the
// Jacobian against FK, IK round trips over random reachable poses and refusals, the trapezoid,
// MoveJ / MoveL / stop limits checked by finite differences at every sample, and that planning
// and sampling allocate nothing (malloc is counted in this executable).
#include <indurop/kinematics/cartesian_trajectory.hpp>
#include <indurop/kinematics/joint_trajectory.hpp>
#include <indurop/kinematics/profile.hpp>
#include <indurop/kinematics/robot.hpp>

#include "support/allocation_counter.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

using testing_support::AllocationCounter;
using namespace irp::kin;

namespace {

const std::string kUrdf = std::string(SOURCE_ROOT) + "/config/robots/indurop6.urdf";

Robot &robot() {
    static Robot r = [] {
        auto loaded = Robot::load(kUrdf);
        if (!loaded) throw std::runtime_error(loaded.error().message);
        return std::move(loaded).value();
    }();
    return r;
}

Joints J(double a, double b, double c, double d, double e, double f) {
    Joints q;
    q << a, b, c, d, e, f;
    return q;
}

Eigen::Matrix3d Rx(double a) { return Eigen::AngleAxisd(a, Eigen::Vector3d::UnitX()).toRotationMatrix(); }
Eigen::Matrix3d Ry(double a) { return Eigen::AngleAxisd(a, Eigen::Vector3d::UnitY()).toRotationMatrix(); }
Eigen::Matrix3d Rz(double a) { return Eigen::AngleAxisd(a, Eigen::Vector3d::UnitZ()).toRotationMatrix(); }

void expectPose(const Pose &p, Eigen::Vector3d xyz, const Eigen::Matrix3d &R, const char *what) {
    EXPECT_LT((p.position - xyz).norm(), 1e-12)
        << what << ": position " << p.position.transpose() << ", expected " << xyz.transpose();
    EXPECT_LT((p.rotation() - R).cwiseAbs().maxCoeff(), 1e-12) << what << ": rotation\n"
                                                               << p.rotation() << "\nexpected\n"
                                                               << R;
}

Joints randomWithinLimits(std::mt19937 &rng) {
    const JointLimits &l = robot().limits();
    Joints q;
    for (int i = 0; i < kAxes; ++i) q[i] = std::uniform_real_distribution<double>(l.lower[i], l.upper[i])(rng);
    return q;
}

std::string slurp(const std::string &path) {
    std::ifstream in(path);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
}

// The URDF with one text replaced (a malformed variant).
std::string urdfWith(const std::string &from, const std::string &to) {
    std::string text = slurp(kUrdf);
    auto at = text.find(from);
    if (at == std::string::npos) throw std::runtime_error("fragment not in the URDF: " + from);
    return text.replace(at, from.size(), to);
}

const Joints kAmax = Joints::Constant(8.0);  // rad/s^2, the module's default max_joint_accel

// Checks a sampled joint path by finite differences: |qd| <= vmax, |qdd| <= amax (with a relative
// tolerance) at every sample; returns the largest ratios seen.
struct LimitCheck {
    double velocity_ratio = 0, acceleration_ratio = 0;
};
LimitCheck checkLimits(const std::vector<Joints> &q, double dt, const Joints &vmax, const Joints &amax, double tol,
                       const char *what) {
    LimitCheck c;
    for (size_t k = 1; k < q.size(); ++k) {
        Joints v = (q[k] - q[k - 1]) / dt;
        for (int i = 0; i < kAxes; ++i) {
            c.velocity_ratio = std::max(c.velocity_ratio, std::abs(v[i]) / vmax[i]);
            EXPECT_LE(std::abs(v[i]), vmax[i] * (1 + tol))
                << what << ": joint " << i + 1 << " velocity at sample " << k;
        }
        if (k + 1 < q.size()) {
            Joints a = (q[k + 1] - 2 * q[k] + q[k - 1]) / (dt * dt);
            for (int i = 0; i < kAxes; ++i) {
                c.acceleration_ratio = std::max(c.acceleration_ratio, std::abs(a[i]) / amax[i]);
                EXPECT_LE(std::abs(a[i]), amax[i] * (1 + tol))
                    << what << ": joint " << i + 1 << " acceleration at sample " << k;
            }
        }
    }
    return c;
}

}  // namespace

// ---- loading ------------------------------------------------------------------------------------

TEST(RobotLoad, ChainAndLimitsFromTheUrdf) {
    const JointLimits &l = robot().limits();
    EXPECT_EQ(robot().baseLink(), "base_link");
    EXPECT_EQ(robot().tipLink(), "tool0");
    for (int i = 0; i < kAxes; ++i) EXPECT_EQ(l.names[i], "joint_" + std::to_string(i + 1));
    EXPECT_DOUBLE_EQ(l.lower[0], -2.967);
    EXPECT_DOUBLE_EQ(l.upper[1], 2.356);
    EXPECT_DOUBLE_EQ(l.lower[2], -3.0);
    EXPECT_DOUBLE_EQ(l.upper[5], 6.109);
    EXPECT_DOUBLE_EQ(l.velocity[0], 2.5);
    EXPECT_DOUBLE_EQ(l.velocity[5], 4.0);
    EXPECT_DOUBLE_EQ(l.effort[1], 400);
}

TEST(RobotLoad, RefusesAMissingFile) {
    auto r = Robot::load("/nonexistent/robot.urdf");
    ASSERT_FALSE(r);
    EXPECT_NE(r.error().message.find("/nonexistent/robot.urdf: cannot read the URDF"), std::string::npos)
        << r.error().message;
}

TEST(RobotLoad, RefusesMalformedXml) {
    auto r = Robot::fromString("<robot name='x'><link name='a'></robot>");
    ASSERT_FALSE(r);
    EXPECT_NE(r.error().message.find("urdfdom refused it"), std::string::npos) << r.error().message;
}

TEST(RobotLoad, RefusesAnUnknownTipLink) {
    auto r = Robot::load(kUrdf, "base_link", "flange");
    ASSERT_FALSE(r);
    EXPECT_EQ(r.error().message, kUrdf + ": no link 'flange' (the tip link)");
}

TEST(RobotLoad, RefusesABaseThatIsNotAnAncestor) {
    auto r = Robot::load(kUrdf, "link_3", "link_2");
    ASSERT_FALSE(r);
    EXPECT_EQ(r.error().message, kUrdf + ": link 'link_3' is not an ancestor of link 'link_2'");
}

TEST(RobotLoad, RefusesAChainWithoutSixJoints) {
    auto r = Robot::load(kUrdf, "base_link", "link_5");
    ASSERT_FALSE(r);
    EXPECT_NE(r.error().message.find("the chain base_link -> link_5 has 5 movable joints; the robot module drives "
                                     "exactly 6"),
              std::string::npos)
        << r.error().message;
}

TEST(RobotLoad, RefusesAJointWithoutVelocityLimit) {
    auto r = Robot::fromString(urdfWith("effort=\"60\" velocity=\"3.5\"", "effort=\"60\""));
    ASSERT_FALSE(r);
    EXPECT_NE(r.error().message.find("urdfdom refused it: joint limit: no velocity"), std::string::npos)
        << r.error().message;
}

TEST(RobotLoad, RefusesAZeroVelocityLimit) {
    auto r = Robot::fromString(urdfWith("effort=\"60\" velocity=\"3.5\"", "effort=\"60\" velocity=\"0\""));
    ASSERT_FALSE(r);
    EXPECT_NE(r.error().message.find("URDF text: joint 'joint_4' has no velocity limit"), std::string::npos)
        << r.error().message;
}

TEST(RobotLoad, RefusesAFloatingJoint) {
    auto r = Robot::fromString(
        urdfWith("<joint name=\"joint_3\" type=\"revolute\">", "<joint name=\"joint_3\" type=\"floating\">"));
    ASSERT_FALSE(r);
    EXPECT_NE(r.error().message.find("joint 'joint_3' is floating"), std::string::npos) << r.error().message;
}

TEST(RobotLoad, AContinuousJointHasNoPositionLimits) {
    auto r = Robot::fromString(
        urdfWith("<joint name=\"joint_6\" type=\"revolute\">", "<joint name=\"joint_6\" type=\"continuous\">"));
    ASSERT_TRUE(r) << r.error().message;
    EXPECT_TRUE(std::isinf(r->limits().lower[5]) && r->limits().lower[5] < 0);
    EXPECT_TRUE(std::isinf(r->limits().upper[5]) && r->limits().upper[5] > 0);
    EXPECT_EQ(r->outsideLimits(J(0, 0, 0, 0, 0, 100.0)), -1);
}

// ---- forward kinematics against poses worked out by hand ------------------------------------------
// Zero pose: shoulder at (0.1, 0, 0.4), elbow at (0.1, 0, 0.85), wrist centre at (0.55, 0, 0.885),
// flange at (0.63, 0, 0.885); tool0 = Ry(pi/2) (its z along +x).

TEST(ForwardKinematics, ZeroPose) { expectPose(robot().fk(Joints::Zero()), {0.63, 0, 0.885}, Ry(M_PI / 2), "q = 0"); }

TEST(ForwardKinematics, SingleJointRotations) {
    const double h = M_PI / 2;
    // Base: the whole arm turns about z.
    expectPose(robot().fk(J(h, 0, 0, 0, 0, 0)), {0, 0.63, 0.885}, Rz(h) * Ry(h), "q1 = pi/2");
    // Shoulder: (0.53, 0, 0.485) from the shoulder turns by Ry(pi/2) to (0.485, 0, -0.53).
    expectPose(robot().fk(J(0, h, 0, 0, 0, 0)), {0.585, 0, -0.13}, Ry(M_PI), "q2 = pi/2");
    // Elbow: (0.53, 0, 0.035) from the elbow turns by Ry(-pi/2) to (-0.035, 0, 0.53).
    expectPose(robot().fk(J(0, 0, -h, 0, 0, 0)), {0.065, 0, 1.38}, Eigen::Matrix3d::Identity(), "q3 = -pi/2");
    // Forearm roll: the flange stays on the x axis of the forearm.
    expectPose(robot().fk(J(0, 0, 0, h, 0, 0)), {0.63, 0, 0.885}, Rx(h) * Ry(h), "q4 = pi/2");
    // Wrist bend: the flange 0.08 m below the wrist centre, tool z pointing down.
    expectPose(robot().fk(J(0, 0, 0, 0, h, 0)), {0.55, 0, 0.805}, Ry(M_PI), "q5 = pi/2");
    // Flange roll.
    expectPose(robot().fk(J(0, 0, 0, 0, 0, h)), {0.63, 0, 0.885}, Rx(h) * Ry(h), "q6 = pi/2");
    // Roll then bend: the flange 0.08 m to the side (+y) of the wrist centre.
    expectPose(robot().fk(J(0, 0, 0, h, h, 0)), {0.55, 0.08, 0.885}, Rx(h) * Ry(h) * Ry(h), "q4 = q5 = pi/2");
}

TEST(ForwardKinematics, RpyRoundTripOfThePoseForm) {
    Pose p = robot().fk(J(0, 0, 0, 0, M_PI / 2, 0));  // tool down: Ry(pi) = roll pi, pitch 0, yaw pi
    double v[6];
    p.toXyzRpy(v);
    EXPECT_NEAR(v[0], 0.55, 1e-12);
    EXPECT_NEAR(v[2], 0.805, 1e-12);
    EXPECT_NEAR(std::abs(v[3]), M_PI, 1e-9);
    EXPECT_NEAR(v[4], 0, 1e-9);
    EXPECT_NEAR(std::abs(v[5]), M_PI, 1e-9);
    std::mt19937 rng(7);
    for (int n = 0; n < 100; ++n) {
        Pose a = robot().fk(randomWithinLimits(rng));
        a.toXyzRpy(v);
        Pose b = Pose::fromXyzRpy(v);
        EXPECT_LT(positionError(a, b), 1e-12);
        EXPECT_LT(orientationError(a, b), 1e-9);
    }
}

TEST(ForwardKinematics, JacobianMatchesFiniteDifferencesOfFk) {
    std::mt19937 rng(3);
    for (int n = 0; n < 50; ++n) {
        Joints q = randomWithinLimits(rng);
        Matrix6 Jq = robot().jacobian(q);
        Pose p0 = robot().fk(q);
        for (int i = 0; i < kAxes; ++i) {
            const double e = 1e-7;
            Joints dq = q;
            dq[i] += e;
            Pose p1 = robot().fk(dq);
            Eigen::Vector3d v = (p1.position - p0.position) / e;
            Eigen::AngleAxisd w(p1.orientation * p0.orientation.conjugate());
            Eigen::Vector3d omega = w.axis() * w.angle() / e;
            EXPECT_LT((Jq.col(i).head<3>() - v).norm(), 1e-5) << "column " << i;
            EXPECT_LT((Jq.col(i).tail<3>() - omega).norm(), 1e-5) << "column " << i;
        }
    }
}

// ---- inverse kinematics ---------------------------------------------------------------------------

TEST(InverseKinematics, RoundTripsFromANearbySeed) {
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> nudge(-0.3, 0.3);
    for (int n = 0; n < 500; ++n) {
        Joints truth = randomWithinLimits(rng);
        Joints seed = truth;
        for (int i = 0; i < kAxes; ++i) seed[i] += nudge(rng);
        Pose target = robot().fk(truth);
        Joints q;
        ASSERT_EQ(robot().ik(target, seed, q), IkStatus::Ok) << "sample " << n;
        Pose reached = robot().fk(q);
        EXPECT_LT(positionError(reached, target), 1e-6);
        EXPECT_LT(orientationError(reached, target), 1e-6);
        EXPECT_EQ(robot().outsideLimits(q), -1);
    }
}

TEST(InverseKinematics, RoundTripsFromANeutralSeed) {
    std::mt19937 rng(12);
    const Joints neutral = J(0, 0, 0, 0, M_PI / 2, 0);
    for (int n = 0; n < 500; ++n) {
        Joints truth = randomWithinLimits(rng);
        Pose target = robot().fk(truth);
        Joints q;
        ASSERT_EQ(robot().ik(target, neutral, q), IkStatus::Ok) << "sample " << n;
        Pose reached = robot().fk(q);
        EXPECT_LT(positionError(reached, target), 1e-6);
        EXPECT_LT(orientationError(reached, target), 1e-6);
        EXPECT_EQ(robot().outsideLimits(q), -1);
    }
}

TEST(InverseKinematics, KeepsTheSeedsConfiguration) {
    // From a seed next to the solution, IK returns that solution, not another arm configuration.
    Joints truth = J(0.4, 0.5, -0.3, 0.8, 1.1, -0.6);
    Joints q;
    ASSERT_EQ(robot().ik(robot().fk(truth), truth + Joints::Constant(0.05), q), IkStatus::Ok);
    EXPECT_LT((q - truth).cwiseAbs().maxCoeff(), 1e-8);
}

TEST(InverseKinematics, RefusesAnUnreachablePose) {
    Pose far = robot().fk(Joints::Zero());
    far.position = Eigen::Vector3d(2.5, 0.4, 0.8);  // the arm reaches about 1.1 m from the shoulder
    Joints q = Joints::Constant(99);
    EXPECT_EQ(robot().ik(far, Joints::Zero(), q), IkStatus::NoConvergence);
    EXPECT_EQ(q, Joints::Constant(99)) << "a refused IK leaves the output alone";
}

TEST(InverseKinematics, IkNearConvergesFromCloseSeedsOnly) {
    Joints truth = J(-0.7, 0.2, 0.4, -1.0, 0.9, 2.0);
    Pose target = robot().fk(truth);
    Joints q;
    EXPECT_EQ(robot().ikNear(target, truth + Joints::Constant(1e-3), q, 3), IkStatus::Ok);
    EXPECT_LT(positionError(robot().fk(q), target), Robot::kIkTolerance);
    Pose far = target;
    far.position.x() += 3;
    EXPECT_EQ(robot().ikNear(far, truth, q, 8), IkStatus::NoConvergence);
}

// ---- the trapezoid ----------------------------------------------------------------------------------

TEST(Trapezoid, ReachesCruiseSpeedWhenTheDistanceAllows) {
    Trapezoid p;
    p.plan(2.0, 1.0, 2.0);  // 0.5 s to 1 m/s over 0.25 m, 1.5 m cruise, 0.5 s down
    EXPECT_DOUBLE_EQ(p.duration(), 2.5);
    EXPECT_DOUBLE_EQ(p.at(0.5).v, 1.0);
    EXPECT_DOUBLE_EQ(p.at(0.5).s, 0.25);
    EXPECT_DOUBLE_EQ(p.at(1.25).s, 1.0);
    EXPECT_DOUBLE_EQ(p.at(2.25).v, 0.5);
    EXPECT_DOUBLE_EQ(p.at(2.5).s, 2.0);
    EXPECT_DOUBLE_EQ(p.at(3.0).v, 0.0);
}

TEST(Trapezoid, IsTriangularOnShortDistances) {
    Trapezoid p;
    p.plan(0.5, 10.0, 2.0);  // peak at 0.5 s, 1 m/s
    EXPECT_DOUBLE_EQ(p.duration(), 1.0);
    EXPECT_DOUBLE_EQ(p.peakVelocity(), 1.0);
    EXPECT_DOUBLE_EQ(p.at(0.5).s, 0.25);
    EXPECT_DOUBLE_EQ(p.at(1.0).s, 0.5);
}

TEST(Trapezoid, StopDeceleratesToRestAtTheGivenRate) {
    Trapezoid p;
    p.plan(2.0, 1.0, 2.0);
    p.stopAt(1.0, 4.0);  // cruising at 1 m/s at s = 0.75: 0.25 s and 0.125 m to rest
    EXPECT_TRUE(p.stopping());
    EXPECT_DOUBLE_EQ(p.duration(), 1.25);
    EXPECT_DOUBLE_EQ(p.finalPosition(), 0.875);
    EXPECT_DOUBLE_EQ(p.at(1.125).v, 0.5);
    EXPECT_DOUBLE_EQ(p.at(1.125).a, -4.0);
    EXPECT_DOUBLE_EQ(p.at(9).s, 0.875);
    p.stopAt(1.1, 100.0);  // a second stop keeps the first
    EXPECT_DOUBLE_EQ(p.duration(), 1.25);
}

TEST(Trapezoid, AStopNeverDeceleratesSlowerThanPlanned) {
    Trapezoid p;
    p.plan(2.0, 1.0, 2.0);
    p.stopAt(2.25, 0.1);  // already decelerating at 2 m/s^2: a slower stop would overshoot the end
    EXPECT_DOUBLE_EQ(p.finalPosition(), 2.0);
    EXPECT_DOUBLE_EQ(p.duration(), 2.5);
}

// ---- MoveJ ------------------------------------------------------------------------------------------

TEST(MoveJ, SynchronizedWithinLimitsAtEverySample) {
    const Joints from = J(0, 0, 0, 0, M_PI / 2, 0), to = J(1.2, 0.6, -0.9, 2.0, -0.4, 3.0);
    const Joints vmax = robot().limits().velocity;
    for (double dt : {0.001, 0.01}) {
        JointTrajectory tr;
        tr.plan(from, to, vmax, kAmax, 1.0, 1.0);
        std::vector<Joints> q;
        for (int k = 0;; ++k) {
            JointSample s = tr.sample(k * dt);
            q.push_back(s.q);
            // On the straight line in joint space: all joints at the same fraction of their travel.
            Joints fraction = (s.q - from).cwiseQuotient(to - from);
            EXPECT_LT(fraction.maxCoeff() - fraction.minCoeff(), 1e-12) << "t = " << k * dt;
            if (s.done) break;
            ASSERT_LT(k, 100000);
        }
        EXPECT_EQ(q.back(), to);
        LimitCheck c = checkLimits(q, dt, vmax, kAmax, 1e-9, "MoveJ");
        // Time-optimal for the joint with the most travel: it reaches its velocity limit (joint 6:
        // 3 rad at 4 rad/s and 8 rad/s^2 has a cruise phase).
        EXPECT_GT(c.velocity_ratio, 0.99);
        EXPECT_GT(c.acceleration_ratio, 0.9);
    }
}

TEST(MoveJ, AllJointsArriveTogether) {
    const Joints from = Joints::Zero(), to = J(0.1, -0.2, 0.3, -2.5, 0.5, 0.05);
    JointTrajectory tr;
    tr.plan(from, to, robot().limits().velocity, kAmax, 1.0, 1.0);
    JointSample before = tr.sample(tr.duration() - 0.01);
    for (int i = 0; i < kAxes; ++i)
        EXPECT_GT(std::abs(to[i] - before.q[i]), 0) << "joint " << i + 1 << " arrived early";
    EXPECT_FALSE(before.done);
    EXPECT_TRUE(tr.sample(tr.duration()).done);
}

TEST(MoveJ, SpeedAndAccelerationFractionsScaleTheLimits) {
    const Joints from = Joints::Zero(), to = J(2.0, 1.0, -1.0, 3.0, 1.5, -4.0);
    const Joints vmax = robot().limits().velocity;
    JointTrajectory tr;
    tr.plan(from, to, vmax, kAmax, 0.25, 0.5);
    std::vector<Joints> q;
    const double dt = 0.01;
    for (int k = 0;; ++k) {
        JointSample s = tr.sample(k * dt);
        q.push_back(s.q);
        if (s.done) break;
    }
    LimitCheck c = checkLimits(q, dt, vmax * 0.25, kAmax * 0.5, 1e-9, "MoveJ 25%/50%");
    EXPECT_GT(c.velocity_ratio, 0.99);
    // Joint 6 sets the pace: 4 rad at 0.25 * 4 rad/s and 0.5 * 8 rad/s^2, i.e. sigma at 0.25 /s
    // and 1 /s^2: 1 / 0.25 + 0.25 / 1 = 4.25 s.
    EXPECT_DOUBLE_EQ(tr.duration(), 4.25);
}

TEST(MoveJ, ZeroTravelIsDoneAtOnce) {
    JointTrajectory tr;
    tr.plan(J(0.1, 0.2, 0.3, 0.4, 0.5, 0.6), J(0.1, 0.2, 0.3, 0.4, 0.5, 0.6), robot().limits().velocity, kAmax, 1, 1);
    EXPECT_EQ(tr.duration(), 0);
    EXPECT_TRUE(tr.sample(0).done);
}

TEST(MoveJ, StopDeceleratesWithinTheLimitsOnThePath) {
    const Joints from = Joints::Zero(), to = J(2.0, 1.0, -1.0, 3.0, 1.5, -4.0);
    const Joints vmax = robot().limits().velocity;
    for (double t_stop : {0.1, 0.6, 1.0}) {  // accelerating, cruising, cruising later
        JointTrajectory tr;
        tr.plan(from, to, vmax, kAmax, 1.0, 0.5);
        const double dt = 0.001;
        std::vector<Joints> q;
        bool stopped = false;
        for (int k = 0;; ++k) {
            double t = k * dt;
            if (!stopped && t >= t_stop) tr.stop(t), stopped = true;
            JointSample s = tr.sample(t);
            q.push_back(s.q);
            if (s.done) break;
        }
        checkLimits(q, dt, vmax, kAmax, 1e-9, "stop");
        Joints end = tr.finalPosition();
        EXPECT_EQ(q.back(), end);
        Joints fraction = (end - from).cwiseQuotient(to - from);
        EXPECT_LT(fraction.maxCoeff() - fraction.minCoeff(), 1e-12) << "stops on the path";
        EXPECT_LT(fraction[0], 1.0) << "stops before the target";
        // At the full deceleration: the slowest joint to stop sets it, so the stop takes
        // exactly max_i |qd_i| / amax_i.
        JointTrajectory ref;
        ref.plan(from, to, vmax, kAmax, 1.0, 0.5);
        Joints qd = ref.sample(t_stop).qd;
        double expected = qd.cwiseAbs().cwiseQuotient(kAmax).maxCoeff();
        EXPECT_NEAR(tr.duration() - t_stop, expected, 2e-3) << "t_stop " << t_stop;
    }
}

TEST(MoveJ, PlanStopBringsAMovingArmToRest) {
    const Joints q0 = J(0.2, 0.3, -0.4, 0.5, 0.6, 0.7), qd0 = J(2.0, -1.0, 0.5, 3.0, 0.0, -3.5);
    JointTrajectory tr;
    tr.planStop(q0, qd0, kAmax);
    EXPECT_NEAR(tr.duration(), 3.5 / 8.0, 1e-12);  // joint 6 has the most to shed
    EXPECT_EQ(tr.sample(0).qd, qd0);
    std::vector<Joints> q;
    const double dt = 0.001;
    q.push_back(q0 - qd0 * dt);  // the motion before: already at qd0
    for (int k = 0;; ++k) {
        JointSample s = tr.sample(k * dt);
        q.push_back(s.q);
        if (s.done) break;
    }
    checkLimits(q, dt, Joints::Constant(4.0), kAmax, 1e-6, "planStop");
    EXPECT_TRUE(tr.sample(tr.duration()).qd.isZero());
}

// ---- MoveL ------------------------------------------------------------------------------------------

namespace {

struct MoveLRun {
    std::vector<Joints> q;
    std::vector<Pose> pose;
    bool all_ok = true;
};

MoveLRun sampleAll(CartesianTrajectory &tr, double dt, double stop_at = -1) {
    MoveLRun r;
    bool stopped = false;
    for (int k = 0;; ++k) {
        double t = k * dt;
        if (stop_at >= 0 && !stopped && t >= stop_at) tr.stop(t), stopped = true;
        CartesianSample s = tr.sample(t);
        r.all_ok = r.all_ok && s.ok;
        r.q.push_back(s.q);
        r.pose.push_back(robot().fk(s.q));
        if (s.done) break;
        if (k > 100000) break;
    }
    return r;
}

// A pose on the segment a -> b, checked: its distance to the line and its orientation against
// slerp at the same fraction of the way.
void expectOnLine(const Pose &p, const Pose &a, const Pose &b, const char *what) {
    Eigen::Vector3d d = b.position - a.position;
    double s = d.squaredNorm() > 0 ? (p.position - a.position).dot(d) / d.squaredNorm() : 0;
    EXPECT_GE(s, -1e-9) << what;
    EXPECT_LE(s, 1 + 1e-9) << what;
    EXPECT_LT((a.position + s * d - p.position).norm(), 1e-6) << what << ": off the line";
    if (d.squaredNorm() > 0) {
        Eigen::Quaterniond expected = a.orientation.slerp(s, b.orientation);
        EXPECT_LT(orientationError(p, Pose{p.position, expected}), 1e-6) << what << ": not slerp";
    }
}

const Joints kHome = J(0, 0, 0, 0, M_PI / 2, 0);

}  // namespace

TEST(MoveL, StraightLineWithinEveryLimit) {
    static CartesianTrajectory tr(robot());
    const Joints from = J(0.2, 0.3, 0.2, 0.1, 1.0, 0.2);
    Pose start = robot().fk(from), target = start;
    target.position += Eigen::Vector3d(0.05, 0.3, -0.2);
    target.orientation = Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, 1, 0).normalized()) * start.orientation;
    CartesianLimits cart;  // 0.5 m/s, 2 m/s^2, 1.5 rad/s, 6 rad/s^2
    PlanReport rep = tr.plan(from, target, robot().limits().velocity, kAmax, cart, 0.8, 0.5);
    ASSERT_TRUE(rep) << rep.text;
    const double dt = 0.002;
    MoveLRun run = sampleAll(tr, dt);
    EXPECT_TRUE(run.all_ok);
    for (const Pose &p : run.pose) expectOnLine(p, start, target, "MoveL");
    EXPECT_LT(positionError(run.pose.back(), target), 1e-9);
    EXPECT_LT(orientationError(run.pose.back(), target), 1e-9);
    checkLimits(run.q, dt, robot().limits().velocity, kAmax, 0.01, "MoveL");
    // The tip's speed and acceleration stay within the requested fractions of the maxima.
    double peak = 0;
    for (size_t k = 1; k < run.pose.size(); ++k) {
        double v = positionError(run.pose[k], run.pose[k - 1]) / dt;
        peak = std::max(peak, v);
        EXPECT_LE(v, 0.8 * cart.speed * 1.001);
        EXPECT_LE(orientationError(run.pose[k], run.pose[k - 1]) / dt, 0.8 * cart.rot_speed * 1.001);
    }
    if (rep.speed_scale == 1) {
        EXPECT_GT(peak, 0.8 * cart.speed * 0.99) << "reaches the requested speed";
    }
}

TEST(MoveL, RetimedWhereAJointWouldBeTooFast) {
    static CartesianTrajectory tr(robot());
    CartesianLimits cart;
    cart.speed = 3.0;  // far beyond what the joints can follow on this line
    Pose start = robot().fk(kHome), target = start;
    target.position += Eigen::Vector3d(0, 0.4, -0.3);
    PlanReport rep = tr.plan(kHome, target, robot().limits().velocity, kAmax, cart, 1.0, 1.0);
    ASSERT_TRUE(rep) << rep.text;
    EXPECT_LT(rep.speed_scale, 1.0);
    EXPECT_GE(rep.joint, 0);
    EXPECT_NE(std::string(rep.text).find("MoveL slowed to"), std::string::npos) << rep.text;
    const double dt = 0.001;
    MoveLRun run = sampleAll(tr, dt);
    EXPECT_TRUE(run.all_ok);
    for (const Pose &p : run.pose) expectOnLine(p, start, target, "re-timed MoveL");
    LimitCheck c = checkLimits(run.q, dt, robot().limits().velocity, kAmax, 0.01, "re-timed MoveL");
    EXPECT_GT(std::max(c.velocity_ratio, c.acceleration_ratio), 0.5) << "a joint limit sets the pace";
}

TEST(MoveL, PureReorientation) {
    static CartesianTrajectory tr(robot());
    Pose start = robot().fk(kHome), target = start;
    target.orientation = Eigen::AngleAxisd(0.8, Eigen::Vector3d::UnitZ()) * start.orientation;
    CartesianLimits cart;
    PlanReport rep = tr.plan(kHome, target, robot().limits().velocity, kAmax, cart, 1.0, 1.0);
    ASSERT_TRUE(rep) << rep.text;
    MoveLRun run = sampleAll(tr, 0.002);
    for (const Pose &p : run.pose) EXPECT_LT(positionError(p, start), 1e-6) << "the tip stays put";
    EXPECT_LT(orientationError(run.pose.back(), target), 1e-9);
    EXPECT_GE(tr.duration(), 0.8 / cart.rot_speed);
    checkLimits(run.q, 0.002, robot().limits().velocity, kAmax, 0.01, "reorientation");
}

TEST(MoveL, RefusedBeyondReach) {
    static CartesianTrajectory tr(robot());
    Pose target = robot().fk(kHome);
    target.position.x() += 1.5;
    PlanReport rep = tr.plan(kHome, target, robot().limits().velocity, kAmax, CartesianLimits{}, 1, 1);
    EXPECT_EQ(rep.error, PlanError::Unreachable);
    EXPECT_GT(rep.s, 0.05);
    EXPECT_LT(rep.s, 0.6);
    EXPECT_NE(std::string(rep.text).find("MoveL refused: the line leaves the reachable space"), std::string::npos)
        << rep.text;
    EXPECT_EQ(tr.duration(), 0);
    EXPECT_EQ(tr.finalPosition(), kHome) << "a refused plan stays where it is";
}

TEST(MoveL, RefusedOutsideTheJointLimits) {
    // Turning the tip about the base axis past joint 1's limit (2.967 rad) on an arc's chord.
    static CartesianTrajectory tr(robot());
    const Joints from = J(2.8, 0.3, 0.2, 0, 1.2, 0);
    Pose start = robot().fk(from), target;
    Eigen::AngleAxisd turn(0.3, Eigen::Vector3d::UnitZ());
    target.position = turn * start.position;
    target.orientation = turn * start.orientation;
    PlanReport rep = tr.plan(from, target, robot().limits().velocity, kAmax, CartesianLimits{}, 1, 1);
    EXPECT_EQ(rep.error, PlanError::OutsideLimits);
    EXPECT_EQ(rep.joint, 0);
    EXPECT_NE(std::string(rep.text).find("the line leaves the joint limits"), std::string::npos) << rep.text;
}

TEST(MoveL, RefusedThroughTheWristSingularity) {
    // Wrist straight (q5 = 0): joints 4 and 6 are aligned and the tip cannot move sideways
    // with a fixed orientation.
    static CartesianTrajectory tr(robot());
    const Joints from = J(0, 0.3, 0.3, 0, 0, 0);
    Pose target = robot().fk(from);
    target.position.y() += 0.1;
    PlanReport rep = tr.plan(from, target, robot().limits().velocity, kAmax, CartesianLimits{}, 1, 1);
    EXPECT_EQ(rep.error, PlanError::Singular);
    EXPECT_NE(std::string(rep.text).find("singularity"), std::string::npos) << rep.text;
    // Almost straight: the wrist would have to flip on the way.
    rep = tr.plan(J(0, 0.3, 0.3, 0, 0.002, 0), target, robot().limits().velocity, kAmax, CartesianLimits{}, 1, 1);
    EXPECT_TRUE(rep.error == PlanError::Singular || rep.error == PlanError::TooSlow) << rep.text;
}

TEST(MoveL, StartsFromTheSingularZeroPoseInItsPlane) {
    // q = 0 has the wrist straight (singular), yet a line in the arm's plane with a fixed
    // orientation is possible: the pseudo-inverse finds the joints' rates there.
    static CartesianTrajectory tr(robot());
    Pose start = robot().fk(Joints::Zero()), target = start;
    target.position += Eigen::Vector3d(-0.15, 0, -0.2);
    PlanReport rep = tr.plan(Joints::Zero(), target, robot().limits().velocity, kAmax, CartesianLimits{}, 0.5, 0.5);
    ASSERT_TRUE(rep) << rep.text;
    MoveLRun run = sampleAll(tr, 0.002);
    EXPECT_TRUE(run.all_ok);
    for (const Pose &p : run.pose) expectOnLine(p, start, target, "from q = 0");
    EXPECT_LT(positionError(run.pose.back(), target), 1e-9);
    EXPECT_TRUE(tr.sample(0).qd.allFinite());
    EXPECT_TRUE(tr.sample(0.01).qd.allFinite());
    checkLimits(run.q, 0.002, robot().limits().velocity, kAmax, 0.01, "from q = 0");
}

TEST(MoveL, JointRatesAgreeWithTheSampledPath) {
    static CartesianTrajectory tr(robot());
    const Joints from = J(0.2, 0.3, 0.2, 0.1, 1.0, 0.2);
    Pose target = robot().fk(from);
    target.position += Eigen::Vector3d(0.1, -0.2, 0.1);
    ASSERT_TRUE(tr.plan(from, target, robot().limits().velocity, kAmax, CartesianLimits{}, 1, 1));
    for (double t = 0.05; t < tr.duration() - 0.05; t += 0.05) {
        const double e = 1e-5;
        Joints fd = (tr.sample(t + e).q - tr.sample(t - e).q) / (2 * e);
        EXPECT_LT((tr.sample(t).qd - fd).cwiseAbs().maxCoeff(), 1e-5) << "t = " << t;
    }
}

TEST(MoveL, AlreadyAtTheTargetIsDoneAtOnce) {
    static CartesianTrajectory tr(robot());
    PlanReport rep = tr.plan(kHome, robot().fk(kHome), robot().limits().velocity, kAmax, CartesianLimits{}, 1, 1);
    ASSERT_TRUE(rep);
    EXPECT_TRUE(tr.sample(0).done);
    EXPECT_EQ(tr.sample(0).q, kHome);
}

TEST(MoveL, StopStaysOnTheLineWithinTheLimits) {
    static CartesianTrajectory tr(robot());
    Pose start = robot().fk(kHome), target = start;
    target.position += Eigen::Vector3d(-0.1, 0.35, -0.25);
    for (double t_stop : {0.15, 0.5}) {
        PlanReport rep = tr.plan(kHome, target, robot().limits().velocity, kAmax, CartesianLimits{}, 1.0, 0.5);
        ASSERT_TRUE(rep) << rep.text;
        double planned = tr.duration();
        const double dt = 0.001;
        MoveLRun run = sampleAll(tr, dt, t_stop);
        EXPECT_TRUE(run.all_ok);
        EXPECT_LT(tr.duration(), planned);
        for (const Pose &p : run.pose) expectOnLine(p, start, target, "stopping MoveL");
        checkLimits(run.q, dt, robot().limits().velocity, kAmax, 0.01, "stopping MoveL");
        EXPECT_GT(positionError(run.pose.back(), target), 0.01) << "stopped short of the target";
        EXPECT_EQ(run.q.back(), tr.finalPosition());
        // The tip decelerates within the full Cartesian limit (2 m/s^2): the stop takes at least v / a.
        for (size_t k = 1; k + 1 < run.pose.size(); ++k) {
            Eigen::Vector3d a =
                (run.pose[k + 1].position - 2 * run.pose[k].position + run.pose[k - 1].position) / (dt * dt);
            EXPECT_LE(a.norm(), CartesianLimits{}.accel * 1.01) << "sample " << k;
        }
        CartesianSample at_stop = tr.sample(t_stop);
        double v = at_stop.sd * (target.position - start.position).norm();
        EXPECT_GE(tr.duration() - t_stop, v / CartesianLimits{}.accel - 1e-9);
    }
}

// ---- real-time safety ---------------------------------------------------------------------------------

TEST(RealTime, PlanningSamplingAndStoppingAllocateNothing) {
    static CartesianTrajectory cart(robot());
    static JointTrajectory joint;
    Robot &r = robot();
    Pose target = r.fk(kHome);
    target.position += Eigen::Vector3d(0, 0.3, -0.2);
    Joints q;
    r.fk(kHome);  // first calls outside the counter (lazy statics of the libraries, if any)
    AllocationCounter counter;
    Pose p = r.fk(J(0.1, 0.2, 0.3, 0.4, 0.5, 0.6));
    Matrix6 jac = r.jacobian(kHome);
    IkStatus st = r.ikNear(p, J(0.1, 0.2, 0.3, 0.4, 0.5, 0.6) + Joints::Constant(0.01), q);
    IkStatus st2 = r.ik(p, kHome, q);
    joint.plan(kHome, J(1, 1, -1, 1, 1, 1), r.limits().velocity, kAmax, 1, 1);
    JointSample js = joint.sample(0.3);
    joint.stop(0.4);
    PlanReport rep = cart.plan(kHome, target, r.limits().velocity, kAmax, CartesianLimits{}, 1, 1);
    CartesianSample cs = cart.sample(0.2);
    cart.stop(0.3);
    CartesianSample cs2 = cart.sample(0.35);
    double v[6];
    p.toXyzRpy(v);
    Pose back = Pose::fromXyzRpy(v);
    EXPECT_EQ(counter.count(), 0);
    // (and the calls did their work)
    EXPECT_EQ(st, IkStatus::Ok);
    EXPECT_EQ(st2, IkStatus::Ok);
    EXPECT_TRUE(rep) << rep.text;
    EXPECT_TRUE(cs.ok && cs2.ok);
    EXPECT_FALSE(js.done);
    EXPECT_NE(jac(0, 0), 99);
    EXPECT_LT(positionError(back, p), 1e-12);
}

TEST(RealTime, TheCounterSeesAllocations) {
    static void *volatile sink;
    AllocationCounter counter;
    sink = std::malloc(64);
    long seen = counter.count();
    std::free(sink);
    EXPECT_EQ(seen, 1);
}
