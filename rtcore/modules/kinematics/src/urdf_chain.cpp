// urdf_chain.cpp -- walks the URDF from the tip link up to the base link and builds one KDL segment
// per joint, as kdl_parser does: the segment is named after the joint's child link, its joint
// turns about the axis through the joint origin (both in the parent link's frame), its tip frame
// is the joint origin, and its inertia is the child link's, moved to the link frame.
#include "urdf_chain.hpp"

#include <urdf_model/model.h>

#include <kdl/frames.hpp>
#include <kdl/joint.hpp>
#include <kdl/rigidbodyinertia.hpp>
#include <kdl/rotationalinertia.hpp>
#include <kdl/segment.hpp>

#include <algorithm>
#include <cmath>

namespace irp::kin {
namespace {

KDL::Vector toKdl(const urdf::Vector3 &v) { return KDL::Vector(v.x, v.y, v.z); }

KDL::Frame toKdl(const urdf::Pose &p) {
    return KDL::Frame(KDL::Rotation::Quaternion(p.rotation.x, p.rotation.y, p.rotation.z, p.rotation.w),
                      toKdl(p.position));
}

// URDF gives the inertia tensor about the centre of mass in the <inertial><origin> frame; KDL
// wants it about the centre of mass in the link frame's orientation.
KDL::RigidBodyInertia inertiaOf(const urdf::Link &link) {
    if (!link.inertial) return KDL::RigidBodyInertia::Zero();
    const urdf::Inertial &i = *link.inertial;
    KDL::Frame origin = toKdl(i.origin);
    KDL::RotationalInertia about_com(i.ixx, i.iyy, i.izz, i.ixy, i.ixz, i.iyz);
    KDL::RotationalInertia in_link =
        (origin.M * KDL::RigidBodyInertia(0, KDL::Vector::Zero(), about_com)).getRotationalInertia();
    return KDL::RigidBodyInertia(i.mass, origin.p, in_link);
}

const char *typeName(int type) {
    switch (type) {
    case urdf::Joint::REVOLUTE: return "revolute";
    case urdf::Joint::CONTINUOUS: return "continuous";
    case urdf::Joint::PRISMATIC: return "prismatic";
    case urdf::Joint::FIXED: return "fixed";
    case urdf::Joint::FLOATING: return "floating";
    case urdf::Joint::PLANAR: return "planar";
    default: return "unknown";
    }
}

}  // namespace

Result<UrdfChain> chainFromUrdf(const urdf::ModelInterface &model, const std::string &base, const std::string &tip,
                                const std::string &where) {
    auto fail = [&](const std::string &what) { return Error{where + ": " + what}; };
    if (!model.getLink(base)) return fail("no link '" + base + "' (the base link)");
    urdf::LinkConstSharedPtr link = model.getLink(tip);
    if (!link) return fail("no link '" + tip + "' (the tip link)");

    // Tip to base: the joints in reverse order.
    std::vector<urdf::JointConstSharedPtr> joints;
    while (link->name != base) {
        urdf::JointConstSharedPtr joint = link->parent_joint;
        if (!joint) return fail("link '" + base + "' is not an ancestor of link '" + tip + "'");
        joints.push_back(joint);
        link = model.getLink(joint->parent_link_name);
        if (!link) return fail("joint '" + joint->name + "': no parent link '" + joint->parent_link_name + "'");
    }
    std::reverse(joints.begin(), joints.end());

    UrdfChain out;
    for (const auto &joint : joints) {
        urdf::LinkConstSharedPtr child = model.getLink(joint->child_link_name);
        KDL::Frame origin = toKdl(joint->parent_to_joint_origin_transform);
        KDL::Vector axis = toKdl(joint->axis);
        KDL::Joint kdl_joint;
        switch (joint->type) {
        case urdf::Joint::FIXED: kdl_joint = KDL::Joint(joint->name, KDL::Joint::Fixed); break;
        case urdf::Joint::REVOLUTE:
        case urdf::Joint::CONTINUOUS:
        case urdf::Joint::PRISMATIC: {
            double norm = axis.Norm();
            if (!(norm > 1e-9))
                return fail("joint '" + joint->name + "': <axis> is zero; a movable joint needs a direction");
            auto type = joint->type == urdf::Joint::PRISMATIC ? KDL::Joint::TransAxis : KDL::Joint::RotAxis;
            kdl_joint = KDL::Joint(joint->name, origin.p, origin.M * (axis / norm), type);
            break;
        }
        default:
            return fail("joint '" + joint->name + "' is " + typeName(joint->type) +
                        "; a serial arm has revolute, continuous, prismatic or fixed joints");
        }
        out.chain.addSegment(KDL::Segment(child->name, kdl_joint, origin, inertiaOf(*child)));
        if (joint->type == urdf::Joint::FIXED) continue;

        const auto &lim = joint->limits;
        if (!lim || !(lim->velocity > 0))
            return fail("joint '" + joint->name + "' has no velocity limit: <limit velocity=\"...\"> (rad/s or m/s) " +
                        "is needed to plan its motion");
        bool continuous = joint->type == urdf::Joint::CONTINUOUS;
        double inf = std::numeric_limits<double>::infinity();
        double lower = continuous ? -inf : lim->lower, upper = continuous ? inf : lim->upper;
        if (!(lower < upper))
            return fail("joint '" + joint->name + "': lower limit " + std::to_string(lower) +
                        " is not below upper limit " + std::to_string(upper));
        out.joint_names.push_back(joint->name);
        out.lower.push_back(lower);
        out.upper.push_back(upper);
        out.velocity.push_back(lim->velocity);
        out.effort.push_back(lim->effort);
    }
    return out;
}

}  // namespace irp::kin
