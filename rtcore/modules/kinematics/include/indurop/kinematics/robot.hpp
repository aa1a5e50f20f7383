// robot.hpp -- irp::kin::Robot: a 6-axis arm loaded from a URDF (base link to tip link) as a KDL
// chain, with its joint limits, forward kinematics, Jacobian and inverse kinematics.
//
// Loading allocates (urdfdom, the KDL chain and solvers); every other call is allocation-free and
// bounded, so fk, jacobian, ikNear and ik may run inside a module's run().  A Robot keeps scratch
// state in its solvers: use one Robot per thread.
//
// Conventions: the chain's frames follow the URDF exactly (each joint frame = its <origin>, then
// the rotation about <axis>).  Poses are the tip link's frame in the base link's frame; twists and
// Jacobians are expressed in the base frame with the tip's origin as reference point.
#pragma once

#include <indurop/kinematics/pose.hpp>

#include <indurop/result.hpp>

#include <array>
#include <memory>
#include <string>
#include <utility>
#include <variant>

namespace irp::kin {

// A value or the reason it could not be made (load-time only; the message names the file, the
// link or joint, and what was expected): rtcore's Result.
using irp::Error;
using irp::Result;

// The movable joints' limits from the URDF, in chain order.
struct JointLimits {
    std::array<std::string, kAxes> names;
    Joints lower;     // rad (-inf for a continuous joint)
    Joints upper;     // rad (+inf for a continuous joint)
    Joints velocity;  // rad/s, > 0
    Joints effort;    // N m
};

enum class IkStatus {
    Ok,
    NoConvergence,  // no joint values reach the pose: out of reach, or the solver got stuck
    OutsideLimits,  // the pose is reached only with a joint outside its limits
};
const char *describe(IkStatus status) noexcept;

class Robot {
public:
    // Parses the URDF and builds the chain from `base` to `tip`; refuses a chain without exactly
    // kAxes movable joints, floating or planar joints, and movable joints without a velocity limit.
    static Result<Robot> load(const std::string &urdf_path, const std::string &base = "base_link",
                              const std::string &tip = "tool0");
    static Result<Robot> fromString(const std::string &urdf_xml, const std::string &base = "base_link",
                                    const std::string &tip = "tool0");

    Robot(Robot &&) noexcept;
    Robot &operator=(Robot &&) noexcept;
    ~Robot();

    const JointLimits &limits() const noexcept;
    const std::string &baseLink() const noexcept;
    const std::string &tipLink() const noexcept;

    // Index of the first joint outside [lower - tolerance, upper + tolerance] (or not finite), or -1.
    int outsideLimits(const Joints &q, double tolerance = 0.0) const noexcept;

    // The tip's pose for joint values q.
    Pose fk(const Joints &q) const noexcept;

    // The geometric Jacobian at q (base frame, reference point at the tip): twist = J * qdot.
    Matrix6 jacobian(const Joints &q) const noexcept;

    // Inverse kinematics near a good seed (a few Newton steps on KDL's FK and Jacobian, damped
    // least squares): for tracking a path sample by sample.  No limit check, no wrapping.
    // Converges to within kIkTolerance or returns NoConvergence after max_iterations.
    IkStatus ikNear(const Pose &target, const Joints &seed, Joints &q, int max_iterations = 8) const noexcept;

    // Inverse kinematics from any seed: Newton from the seed, then KDL's Levenberg-Marquardt solver
    // (ChainIkSolverPos_LMA) from the seed and from a few fixed seeds; each result is wrapped by
    // 2 pi into the limits nearest the seed, checked against the limits and against FK.  The
    // first solution found is returned: the seed's own configuration when it converges there.
    IkStatus ik(const Pose &target, const Joints &seed, Joints &q) const noexcept;

    // Position (m) and orientation (rad) tolerance of ik and ikNear.
    static constexpr double kIkTolerance = 1e-10;

private:
    struct Impl;
    explicit Robot(std::unique_ptr<Impl> impl);
    bool wrapIntoLimits(Joints &q, const Joints &seed) const noexcept;
    std::unique_ptr<Impl> impl_;  // stable address: KDL's solvers keep references to the chain
};

}  // namespace irp::kin
