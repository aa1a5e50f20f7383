// Robot.cpp -- the robot task of the PLC + robot cell (Robot.so, the paper's Figure 13 shape:
// extern "C" initialize / start / run / stop, shared variables under PLC_ROBOT::).
//
// Every period, in run():
//   1. read the drives (AXIS_IN), the I/O status and the request block (ROBOT_MODULE_SERVICE);
//   2. supervise: a drive fault, lost communication or a following error while the drives are on
//      stops the axes (CiA 402 quick stop) and latches an error;
//   3. take a new request (nSeq != nAckSeq): validate it, answer it, plan its motion;
//   4. advance the motion: sample the trajectory at this period's time, or chain to the motion
//      that replaces a stopped one; advance power-on/off and reset;
//   5. write the drives (AXIS_OUT: controlword, mode 8, target position) and the state block
//      (ROBOT_MODULE_STATE: answer flags, measured and commanded joints, the commanded TCP pose).
// The protocol and the ErrorIDs are the contract's (docs/robot.md, "The request/answer protocol").
// run() allocates nothing, takes no lock but the shared variables' own, does no I/O.
#include <indurop/indurop.h>
#include <indurop/generated.h>

#include <indurop/kinematics/cartesian_trajectory.hpp>
#include <indurop/kinematics/joint_trajectory.hpp>
#include <indurop/kinematics/robot.hpp>

#include <dlfcn.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

namespace {

using namespace irp::kin;
namespace fs = std::filesystem;

// ---- the contract's codes -------------------------------------------------------------------------

enum Op : int32_t {
    kNone = 0,
    kPowerOn = 1,
    kPowerOff = 2,
    kMoveJ = 3,
    kMoveL = 4,
    kStop = 5,
    kReset = 6,
    kMoveVelocity = 7,
};

// A velocity motion of joints without limits (continuous joints) ends after this long.
constexpr double kMaxVelocityMotionSeconds = 3600.0;

enum ErrorId : int32_t {
    kNotPowered = 1,
    kOutsideLimits = 2,
    kUnreachable = 3,
    kDriveFault = 4,
    kFollowingError = 5,
    kPowerTimeout = 6,
    kBadOpCode = 7,
    kCommLost = 8,
};

enum EState : short { kDisabled = 0, kStandstill = 1, kMoving = 2, kStopping = 3, kErrorState = 4 };

const char *opName(int32_t op) {
    switch (op) {
    case kPowerOn: return "power on";
    case kPowerOff: return "power off";
    case kMoveJ: return "MoveJ";
    case kMoveL: return "MoveL";
    case kStop: return "stop";
    case kReset: return "reset";
    case kMoveVelocity: return "MoveVelocity";
    default: return "?";
    }
}

// ---- CiA 402 --------------------------------------------------------------------------------------

namespace cia402 {
constexpr uint16_t kDisableVoltage = 0x00, kQuickStop = 0x02, kShutdown = 0x06, kSwitchOn = 0x07,
                   kEnableOperation = 0x0F, kFaultReset = 0x80;
constexpr int8_t kCyclicSynchronousPosition = 8;

enum class State { NotReady, SwitchOnDisabled, ReadyToSwitchOn, SwitchedOn, OperationEnabled, QuickStopActive, Fault };

State decode(uint16_t sw) {
    if (sw & 0x08) return State::Fault;  // fault or fault reaction active
    if ((sw & 0x4F) == 0x40) return State::SwitchOnDisabled;
    switch (sw & 0x6F) {
    case 0x21: return State::ReadyToSwitchOn;
    case 0x23: return State::SwitchedOn;
    case 0x27: return State::OperationEnabled;
    case 0x07: return State::QuickStopActive;
    default: return State::NotReady;
    }
}

// What the robot wants of its drives.
enum class Goal { Off, On, QuickStop };

// The controlword that moves a drive in `state` one transition towards `goal`.
uint16_t controlword(State state, Goal goal) {
    switch (goal) {
    case Goal::On:
        switch (state) {
        case State::SwitchOnDisabled: return kShutdown;
        case State::ReadyToSwitchOn: return kSwitchOn;
        case State::SwitchedOn:
        case State::OperationEnabled: return kEnableOperation;
        default: return kDisableVoltage;  // not ready, fault, quick stop active: to switch on disabled first
        }
    case Goal::Off:
        switch (state) {
        case State::ReadyToSwitchOn:
        case State::SwitchedOn:
        case State::OperationEnabled: return kShutdown;
        default: return kDisableVoltage;
        }
    case Goal::QuickStop:
        return state == State::OperationEnabled || state == State::QuickStopActive ? kQuickStop : kDisableVoltage;
    }
    return kDisableVoltage;
}
}  // namespace cia402

// ---- configuration (module.xml properties) ----------------------------------------------------------

struct Config {
    std::string urdf;  // resolved path
    std::string base_link = "base_link", tip_link = "tool0";
    CartesianLimits cart;  // max_cart_speed, max_cart_accel, max_cart_rot_speed, max_cart_rot_accel
    Joints joint_accel = Joints::Constant(8.0);                                         // max_joint_accel, rad/s^2
    double following_error = 0.35;                                                      // rad; 0 disables the check
    double power_timeout = 1.0;                                                         // s (power_timeout_ms)
    std::array<bool, 8> drive_devices{true, true, true, true, true, true, true, true};  // IO_STATUS indices watched
};

std::vector<double> numberList(const char *name, std::string_view text) {
    std::vector<double> out;
    size_t at = 0;
    while (at <= text.size()) {
        size_t end = text.find(',', at);
        if (end == std::string_view::npos) end = text.size();
        std::string_view item = text.substr(at, end - at);
        while (!item.empty() && item.front() == ' ') item.remove_prefix(1);
        while (!item.empty() && item.back() == ' ') item.remove_suffix(1);
        double v = 0;
        auto [ptr, ec] = std::from_chars(item.data(), item.data() + item.size(), v);
        if (item.empty() || ec != std::errc() || ptr != item.data() + item.size())
            throw irp::PropertyError(std::string("property '") + name +
                                     "': expected a number or a comma-separated list, got '" + std::string(text) + "'");
        out.push_back(v);
        at = end + 1;
    }
    return out;
}

double positive(const irp::Property &p, const char *name, double fallback) {
    double v = p.get<double>(name, fallback);
    if (!(v > 0) || !std::isfinite(v))
        throw irp::PropertyError(std::string("property '") + name + "': must be a positive number, got '" +
                                 std::string(p.find(name).value_or("")) + "'");
    return v;
}

Config readConfig(const irp::Property &p) {
    Config c;
    // A relative name is beside the set's module.xml (irp::Property::path): the .so itself is
    // loaded from irpd's module cache.
    c.urdf = fs::path(p.path("urdf", "indurop6.urdf")).lexically_normal().string();
    c.base_link = p.get("base_link", std::string_view("base_link"));
    c.tip_link = p.get("tip_link", std::string_view("tool0"));
    c.cart.speed = positive(p, "max_cart_speed", c.cart.speed);
    c.cart.accel = positive(p, "max_cart_accel", c.cart.accel);
    c.cart.rot_speed = positive(p, "max_cart_rot_speed", c.cart.rot_speed);
    c.cart.rot_accel = positive(p, "max_cart_rot_accel", c.cart.rot_accel);
    if (auto text = p.find("max_joint_accel")) {
        std::vector<double> a = numberList("max_joint_accel", *text);
        if (a.size() != 1 && a.size() != static_cast<size_t>(kAxes))
            throw irp::PropertyError("property 'max_joint_accel': one value for every joint or 6 values, got " +
                                     std::to_string(a.size()));
        for (int i = 0; i < kAxes; ++i) {
            c.joint_accel[i] = a.size() == 1 ? a[0] : a[i];
            if (!(c.joint_accel[i] > 0))
                throw irp::PropertyError("property 'max_joint_accel': every value must be positive");
        }
    }
    c.following_error = p.get<double>("following_error", c.following_error);
    if (!(c.following_error >= 0)) throw irp::PropertyError("property 'following_error': must be >= 0 (0: no check)");
    c.power_timeout = positive(p, "power_timeout_ms", c.power_timeout * 1000) / 1000;
    if (auto text = p.find("drive_devices"); text && *text != "all") {
        c.drive_devices.fill(false);
        for (double d : numberList("drive_devices", *text)) {
            if (d < 0 || d >= 8 || d != std::floor(d))
                throw irp::PropertyError("property 'drive_devices': device indices 0-7 (IO_STATUS), or 'all'");
            c.drive_devices[static_cast<size_t>(d)] = true;
        }
    }
    return c;
}

// ---- the task ---------------------------------------------------------------------------------------

using ServiceBlock = PLC_ROBOT::ROBOT_MODULE_SERVICE_t;
using StateBlock = PLC_ROBOT::ROBOT_MODULE_STATE_t;
using AxesIn = INDUROP_TYPEDEF(PLC_ROBOT::AXIS_IN)::array_type;
using AxesOut = INDUROP_TYPEDEF(PLC_ROBOT::AXIS_OUT)::array_type;

class RobotTask {
public:
    RobotTask(Robot robot, Config config)
        : robot_(std::move(robot)),
          config_(std::move(config)),
          cart_{CartesianTrajectory(robot_), CartesianTrajectory(robot_)} {}

    void start();
    void run();

private:
    // One planned motion: a MoveJ (or a joint-space stop, or a velocity motion) or a MoveL,
    // started at t0 (task time).
    struct Motion {
        enum Kind { Joint, Cartesian } kind = Joint;
        bool velocity = false;  // a MoveVelocity: a joint motion that ends at a joint limit
        int limit_joint = -1;   // the joint whose limit ends it, or -1
        double t0 = 0;
        JointTrajectory joint;
        CartesianTrajectory *cart = nullptr;
        double duration() const { return kind == Joint ? joint.duration() : cart->duration(); }
        bool stopping() const { return kind == Joint ? joint.stopping() : cart->stopping(); }
        Joints finalPosition() const { return kind == Joint ? joint.finalPosition() : cart->finalPosition(); }
        void stop(double t) { kind == Joint ? joint.stop(t) : cart->stop(t); }
    };

    void readInputs();
    void supervise();
    void takeRequest(const ServiceBlock &svc);
    void acceptMotion(const ServiceBlock &svc);
    bool planVelocity(const ServiceBlock &svc, const Joints &from, Motion &m);
    void advanceMotion();
    void advanceRequest();
    void writeOutputs();

    void refuse(int32_t id, const char *why);
    void raise(int32_t id, const char *why);  // a fault while running: the drives quick-stop
    void stopMotion();                        // decelerate the running motion, drop a queued one
    bool moving() const { return active_ >= 0; }
    bool powered() const { return goal_ == cia402::Goal::On && all_enabled_; }
    bool allOff() const;

    Robot robot_;
    Config config_;
    std::array<CartesianTrajectory, 2> cart_;
    std::array<Motion, 2> motions_{};
    int active_ = -1, next_ = -1;  // indices into motions_, or -1

    // Time and inputs of this period.
    double now_ = 0;  // s since start()
    int64_t last_planned_ns_ = 0;
    AxesIn in_{};
    std::array<cia402::State, kAxes> drive_{};
    bool all_enabled_ = false, was_enabled_ = false, any_fault_ = false, comm_lost_ = false;
    Joints q_act_ = Joints::Zero();

    // Commands.
    cia402::Goal goal_ = cia402::Goal::Off;
    Joints q_cmd_ = Joints::Zero(), qd_cmd_ = Joints::Zero(), q_sent_ = Joints::Zero();
    bool power_off_after_stop_ = false;
    int fault_reset_ticks_ = 0;

    // The request being answered.
    uint32_t ack_ = 0;
    int32_t op_ = kNone;
    bool done_ = false, resetting_ = false;
    double deadline_ = 0;
    bool error_ = false;
    int32_t error_id_ = 0;
};

void RobotTask::start() {
    StateBlock st = PLC_ROBOT::ROBOT_MODULE_STATE;
    ack_ = st.nAckSeq;  // a request taken by a previous instance (hot reload) is not taken again
    readInputs();
    goal_ = all_enabled_ ? cia402::Goal::On : cia402::Goal::Off;
    q_cmd_ = q_sent_ = q_act_;
    was_enabled_ = all_enabled_;
    done_ = true;
}

void RobotTask::readInputs() {
    in_ = PLC_ROBOT::AXIS_IN;
    all_enabled_ = true;
    any_fault_ = false;
    for (int i = 0; i < kAxes; ++i) {
        drive_[i] = cia402::decode(in_[i].statusword);
        all_enabled_ = all_enabled_ && drive_[i] == cia402::State::OperationEnabled;
        any_fault_ = any_fault_ || drive_[i] == cia402::State::Fault;
        q_act_[i] = in_[i].position;
    }
    PLC_ROBOT::IO_STATUS_t io = PLC_ROBOT::IO_STATUS;
    comm_lost_ = false;
    for (int d = 0; d < 8; ++d) comm_lost_ = comm_lost_ || (config_.drive_devices[d] && io.comm_lost[d] != 0);
}

bool RobotTask::allOff() const {
    for (cia402::State s : drive_)
        if (s == cia402::State::OperationEnabled || s == cia402::State::QuickStopActive) return false;
    return true;
}

void RobotTask::run() {
    const irp::Cycle &cycle = irp::cycle();
    double dt = 0;
    if (cycle.planned_ns == 0)
        dt = 0.01;  // called outside irpd's dispatcher: assume 10 ms
    else if (last_planned_ns_ != 0)
        dt = static_cast<double>(cycle.planned_ns - last_planned_ns_) * 1e-9;
    last_planned_ns_ = cycle.planned_ns;
    now_ += std::max(dt, 0.0);

    readInputs();
    supervise();
    ServiceBlock svc = PLC_ROBOT::ROBOT_MODULE_SERVICE;
    if (svc.nSeq != ack_) takeRequest(svc);
    advanceMotion();
    advanceRequest();
    writeOutputs();
    was_enabled_ = all_enabled_;
}

void RobotTask::supervise() {
    if (goal_ != cia402::Goal::On) return;
    if (comm_lost_) return raise(kCommLost, "communication with a drive lost");
    if (any_fault_) {
        for (int i = 0; i < kAxes; ++i)
            if (drive_[i] == cia402::State::Fault) {
                irp::printf("Robot: drive %d fault (statusword 0x%04x, error 0x%04x)", i + 1, in_[i].statusword,
                            in_[i].error);
                break;
            }
        return raise(kDriveFault, "drive fault");
    }
    if (was_enabled_ && !all_enabled_) {
        for (int i = 0; i < kAxes; ++i)
            if (drive_[i] != cia402::State::OperationEnabled) {
                irp::printf("Robot: drive %d left operation enabled (statusword 0x%04x)", i + 1, in_[i].statusword);
                break;
            }
        return raise(kDriveFault, "a drive left operation enabled");
    }
    if (config_.following_error > 0 && all_enabled_ && was_enabled_) {
        for (int i = 0; i < kAxes; ++i)
            if (std::abs(q_sent_[i] - q_act_[i]) > config_.following_error) {
                irp::printf("Robot: joint %d following error %.3f rad (commanded %.4f, actual %.4f)", i + 1,
                            q_sent_[i] - q_act_[i], q_sent_[i], q_act_[i]);
                return raise(kFollowingError, "following error");
            }
    }
}

void RobotTask::refuse(int32_t id, const char *why) {
    error_ = true;
    error_id_ = id;
    done_ = false;
    resetting_ = false;
    irp::printf("Robot: request %u (%s) refused, ErrorID %d: %s", ack_, opName(op_), id, why);
    stopMotion();  // a moving robot stops when its request is superseded by a refused one
}

void RobotTask::raise(int32_t id, const char *why) {
    if (error_ && error_id_ == id) return;
    error_ = true;
    error_id_ = id;
    done_ = false;
    resetting_ = false;
    irp::printf("Robot: error %d (%s) during request %u (%s): the drives quick-stop", id, why, ack_, opName(op_));
    goal_ = cia402::Goal::QuickStop;
    active_ = next_ = -1;
    power_off_after_stop_ = false;
    q_cmd_ = q_act_;
    qd_cmd_.setZero();
}

void RobotTask::stopMotion() {
    next_ = -1;
    if (active_ >= 0) {
        Motion &m = motions_[active_];
        m.stop(now_ - m.t0);
    }
}

void RobotTask::takeRequest(const ServiceBlock &svc) {
    ack_ = svc.nSeq;
    op_ = svc.eOpCode;
    done_ = false;
    resetting_ = false;

    if (op_ == kReset) {
        error_ = false;
        error_id_ = 0;
        if (goal_ == cia402::Goal::QuickStop) goal_ = cia402::Goal::Off;
        resetting_ = true;
        fault_reset_ticks_ = 0;
        deadline_ = now_ + config_.power_timeout;
        return;
    }
    if (error_) {  // only a reset leaves the error state; power off is still obeyed
        if (op_ == kPowerOff) {
            if (moving())
                stopMotion(), power_off_after_stop_ = true;
            else
                goal_ = cia402::Goal::Off;
        }
        irp::printf("Robot: request %u (%s) refused: in error %d, reset first", ack_, opName(op_), error_id_);
        return;
    }
    switch (op_) {
    case kPowerOn:
        if (comm_lost_) return refuse(kCommLost, "communication with a drive lost");
        if (any_fault_) return refuse(kDriveFault, "a drive is in fault: reset first");
        power_off_after_stop_ = false;  // a power off waiting for a stop is superseded
        if (goal_ != cia402::Goal::On) {
            goal_ = cia402::Goal::On;
            if (!moving()) q_cmd_ = q_act_;
        }
        deadline_ = now_ + config_.power_timeout;
        return;
    case kPowerOff:
        if (moving()) {
            stopMotion();
            power_off_after_stop_ = true;
        } else {
            goal_ = cia402::Goal::Off;
        }
        deadline_ = now_ + config_.power_timeout;
        return;
    case kStop:
        stopMotion();
        if (!moving()) done_ = true;
        return;
    case kMoveJ:
    case kMoveL:
    case kMoveVelocity: return acceptMotion(svc);
    default: return refuse(kBadOpCode, "unknown eOpCode");
    }
}

void RobotTask::acceptMotion(const ServiceBlock &svc) {
    if (!powered() || power_off_after_stop_) return refuse(kNotPowered, "the drives are not in operation enabled");
    const double speed = op_ == kMoveVelocity ? 1.0 : svc.t_speed, accel = svc.t_accel;  // 7: dTarget has the speeds
    if (!(speed > 0) || !(accel > 0) || !std::isfinite(speed) || !std::isfinite(accel))
        return refuse(kOutsideLimits, "t_speed and t_accel must be in (0, 1]");
    for (double v : svc.dTarget)
        if (!std::isfinite(v)) return refuse(kOutsideLimits, "dTarget is not a number");

    // Where the new motion starts: here, or where the running one stops.
    Joints from = q_cmd_;
    double t0 = now_;
    int slot = 0;
    if (moving()) {
        Motion &running = motions_[active_];
        if (!running.stopping()) running.stop(now_ - running.t0);
        from = running.finalPosition();
        t0 = running.t0 + running.duration();
        slot = 1 - active_;
    }
    Motion &m = motions_[slot];
    m.t0 = t0;
    m.velocity = false;
    if (op_ == kMoveVelocity) {
        if (!planVelocity(svc, from, m)) return;
    } else if (op_ == kMoveJ) {
        Joints to;
        for (int i = 0; i < kAxes; ++i) to[i] = svc.dTarget[i];
        if (int j = robot_.outsideLimits(to); j >= 0) {
            char why[96];
            std::snprintf(why, sizeof why, "joint %d target %.4f rad outside [%.3f, %.3f]", j + 1, to[j],
                          robot_.limits().lower[j], robot_.limits().upper[j]);
            return refuse(kOutsideLimits, why);
        }
        m.kind = Motion::Joint;
        m.joint.plan(from, to, robot_.limits().velocity, config_.joint_accel, std::min(speed, 1.0),
                     std::min(accel, 1.0));
    } else {
        Pose target = Pose::fromXyzRpy(svc.dTarget);
        m.kind = Motion::Cartesian;
        m.cart = &cart_[slot];
        PlanReport report = m.cart->plan(from, target, robot_.limits().velocity, config_.joint_accel, config_.cart,
                                         std::min(speed, 1.0), std::min(accel, 1.0));
        if (!report)
            return refuse(report.error == PlanError::OutsideLimits ? kOutsideLimits : kUnreachable, report.text);
        if (report.speed_scale < 1) irp::printf("Robot: request %u: %s", ack_, report.text);
    }
    if (moving())
        next_ = slot;
    else
        active_ = slot;
}

// A velocity motion (op-code 7): every joint at dTarget[i] x its velocity limit, on the straight
// line in joint space from `from`, is a MoveJ to the point of that line where the first joint
// reaches its limit, at the speed fraction that makes its cruise exactly those velocities; the
// trapezoid brakes in time to stop there.  False when refused.
bool RobotTask::planVelocity(const ServiceBlock &svc, const Joints &from, Motion &m) {
    const JointLimits &l = robot_.limits();
    Joints w = Joints::Zero();  // rad/s
    double fastest = 0;         // the largest |fraction|
    for (int i = 0; i < kAxes; ++i) {
        const double f = svc.dTarget[i];
        if (!(std::abs(f) <= 1.0)) {
            refuse(kOutsideLimits, "MoveVelocity: every dTarget must be a fraction in [-1, 1]");
            return false;
        }
        w[i] = f * l.velocity[i];
        fastest = std::max(fastest, std::abs(f));
    }
    if (fastest == 0) {
        refuse(kOutsideLimits, "MoveVelocity: every dTarget is 0");
        return false;
    }
    double horizon = kMaxVelocityMotionSeconds;  // s until the first joint reaches its limit
    m.limit_joint = -1;
    for (int i = 0; i < kAxes; ++i) {
        if (w[i] == 0) continue;
        const double to_limit = ((w[i] > 0 ? l.upper[i] : l.lower[i]) - from[i]) / w[i];
        if (to_limit < horizon) horizon = to_limit, m.limit_joint = i;
    }
    if (!(horizon > 1e-9)) {
        char why[80];
        std::snprintf(why, sizeof why, "MoveVelocity: joint %d is at its limit in that direction", m.limit_joint + 1);
        refuse(kOutsideLimits, why);
        return false;
    }
    m.kind = Motion::Joint;
    m.velocity = true;
    m.joint.plan(from, from + w * horizon, l.velocity, config_.joint_accel, fastest, std::min(svc.t_accel, 1.0));
    return true;
}

void RobotTask::advanceMotion() {
    while (active_ >= 0) {
        Motion &m = motions_[active_];
        double t = now_ - m.t0;
        bool done;
        if (m.kind == Motion::Joint) {
            JointSample s = m.joint.sample(t);
            q_cmd_ = s.q;
            qd_cmd_ = s.qd;
            done = s.done;
            // A velocity request is "done" (MotionDone) while it holds its velocity: the cruise.
            if (m.velocity && op_ == kMoveVelocity && !error_) done_ = !done && s.qdd.isZero(0) && !s.qd.isZero(0);
        } else {
            CartesianSample s = m.cart->sample(t);
            if (!s.ok) {
                // The line could not be followed (should not happen after planning): leave it and
                // stop in joint space from the last command.
                Joints q0 = q_cmd_, qd0 = qd_cmd_;
                m.kind = Motion::Joint;
                m.t0 = now_;
                m.joint.planStop(q0, qd0, config_.joint_accel);
                next_ = -1;
                if (!error_) {
                    error_ = true;
                    error_id_ = kUnreachable;
                    done_ = false;
                    irp::printf("Robot: request %u (MoveL): IK failed on the line at s = %.3f: stopping", ack_, s.s);
                }
                continue;
            }
            q_cmd_ = s.q;
            qd_cmd_ = s.qd;
            done = s.done;
        }
        if (!done) return;
        double end = m.t0 + m.duration();
        if (next_ >= 0) {  // the motion that replaced this one starts where it stopped
            active_ = next_;
            next_ = -1;
            motions_[active_].t0 = end;
            continue;
        }
        active_ = -1;
        qd_cmd_.setZero();
        if (power_off_after_stop_) {
            power_off_after_stop_ = false;
            goal_ = cia402::Goal::Off;
            deadline_ = now_ + config_.power_timeout;
        } else if (!error_ && m.velocity && op_ == kMoveVelocity) {
            if (m.limit_joint >= 0) {  // as a PLCopen axis at its software limit: an error to reset
                error_ = true;
                error_id_ = kOutsideLimits;
                done_ = false;
                irp::printf("Robot: request %u (MoveVelocity): joint %d reached its limit and stopped there", ack_,
                            m.limit_joint + 1);
            } else {
                done_ = true;
            }
        } else if (!error_ && (op_ == kMoveJ || op_ == kMoveL || op_ == kStop)) {
            done_ = true;
        }
        return;
    }
}

void RobotTask::advanceRequest() {
    if ((goal_ != cia402::Goal::On || !all_enabled_) && !moving()) {
        // A drive that is not enabled gets its measured position as target, so that enabling it
        // never jumps; an enabled one keeps its last target until it is switched off.
        for (int i = 0; i < kAxes; ++i)
            if (drive_[i] != cia402::State::OperationEnabled) q_cmd_[i] = q_act_[i];
        qd_cmd_.setZero();
    }
    if (resetting_) {
        bool faulted = false;
        for (cia402::State s : drive_) faulted = faulted || s == cia402::State::Fault;
        if (!faulted && !moving()) {
            resetting_ = false;
            done_ = true;
        } else if (faulted && now_ > deadline_) {
            resetting_ = false;
            error_ = true;
            error_id_ = kDriveFault;
            irp::printf("Robot: reset: a drive stays in fault after %.0f ms", config_.power_timeout * 1000);
        }
        ++fault_reset_ticks_;
        return;
    }
    if (done_ || error_) return;
    if (op_ == kPowerOn) {
        if (powered())
            done_ = true;
        else if (now_ > deadline_)
            raise(kPowerTimeout, "the drives did not reach operation enabled in time");
    } else if (op_ == kPowerOff && goal_ == cia402::Goal::Off) {
        if (allOff())
            done_ = true;
        else if (now_ > deadline_)
            raise(kPowerTimeout, "the drives did not switch off in time");
    }
}

void RobotTask::writeOutputs() {
    AxesOut out{};
    for (int i = 0; i < kAxes; ++i) {
        uint16_t cw = cia402::controlword(drive_[i], goal_);
        if (resetting_ && drive_[i] == cia402::State::Fault)  // rising edges of bit 7, every 4 periods
            cw = (fault_reset_ticks_ % 4) < 2 ? cia402::kDisableVoltage : cia402::kFaultReset;
        out[i].controlword = cw;
        out[i].mode = cia402::kCyclicSynchronousPosition;
        out[i].position = q_cmd_[i];
    }
    PLC_ROBOT::AXIS_OUT = out;
    q_sent_ = q_cmd_;

    StateBlock st{};
    st.nAXESGROUP = kAxes;
    st.MotionDone = done_ && !error_ ? 1 : 0;
    // A velocity motion is Busy while it runs, also once MotionDone says it holds its velocity.
    st.Busy = !error_ && op_ != kNone && (!done_ || (op_ == kMoveVelocity && moving())) ? 1 : 0;
    st.Powered = powered() && !comm_lost_ ? 1 : 0;
    st.Error = error_ ? 1 : 0;
    st.ErrorID = error_ ? error_id_ : 0;
    st.nAckSeq = ack_;
    bool stopping = moving() && motions_[active_].stopping() && next_ < 0;
    if (error_)
        st.eState = kErrorState;
    else if (moving())
        st.eState = stopping && (op_ == kStop || op_ == kPowerOff || op_ == kReset) ? kStopping : kMoving;
    else
        st.eState = powered() ? kStandstill : kDisabled;
    double world[6];
    robot_.fk(q_cmd_).toXyzRpy(world);
    for (int i = 0; i < kAxes; ++i) {
        st.dCurJoint[i] = q_act_[i];
        st.dCmdJoint[i] = q_cmd_[i];
        st.dWorldPos[i] = world[i];
        st.dJointSpeed[i] = qd_cmd_[i];
    }
    PLC_ROBOT::ROBOT_MODULE_STATE = st;
}

std::unique_ptr<RobotTask> task;

}  // namespace

extern "C" void initialize(irp::Property const &property) {
    Config config = readConfig(property);
    auto robot = Robot::load(config.urdf, config.base_link, config.tip_link);
    if (!robot) throw std::runtime_error("property 'urdf': " + robot.error().message);
    const JointLimits &l = robot->limits();
    std::cout << "[Robot] " << config.urdf << ": " << config.base_link << " -> " << config.tip_link << ", joints";
    for (int i = 0; i < kAxes; ++i) std::cout << ' ' << l.names[i] << " [" << l.lower[i] << ", " << l.upper[i] << "]";
    std::cout << std::endl;
    task = std::make_unique<RobotTask>(std::move(robot).value(), std::move(config));
}

void start() {
    if (!task) throw std::runtime_error("start() before initialize()");
    task->start();
}

void run() { task->run(); }

void stop() {
    // The outputs stay as the last run() left them: on a hot reload the next instance already runs.
    task.reset();
}
