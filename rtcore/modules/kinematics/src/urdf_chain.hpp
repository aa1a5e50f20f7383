// urdf_chain.hpp -- URDF (urdfdom) -> KDL::Chain from a base link to a tip link, with the movable
// joints' limits.  Debian has no kdl_parser; this is the small part of it that a serial arm needs.
#pragma once

#include <indurop/kinematics/robot.hpp>

#include <kdl/chain.hpp>

#include <limits>
#include <string>
#include <vector>

namespace urdf {
class ModelInterface;
}

namespace irp::kin {

struct UrdfChain {
    KDL::Chain chain;
    std::vector<std::string> joint_names;  // the movable joints, base to tip
    std::vector<double> lower, upper, velocity, effort;
};

// `where` names the source in messages (a file path, or "URDF text").
Result<UrdfChain> chainFromUrdf(const urdf::ModelInterface &model, const std::string &base, const std::string &tip,
                                const std::string &where);

}  // namespace irp::kin
