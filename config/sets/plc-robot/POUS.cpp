// POUS.cpp -- the pick-and-place POU of the plc-robot cell (POUS.h): its rungs, scanned once per
// period by main.cpp's POU_PROGRAM(), and its properties.
#include "POUS.h"

#include <charconv>
#include <cmath>
#include <string>

namespace pou {

using namespace plcopen;

// ---- properties ------------------------------------------------------------------------------

namespace {

[[noreturn]] void bad(std::string_view name, std::string_view text, const char *expected) {
    throw irp::PropertyError("property '" + std::string(name) + "': expected " + expected + ", got '" +
                             std::string(text) + "'");
}

// Six numbers separated by spaces and/or commas: "0 -0.5 1.0 0 0.5 0".
std::array<double, kAxes> vector6(const irp::Property &p, std::string_view name, std::array<double, kAxes> fallback,
                                  const char *expected) {
    const auto text = p.find(name);
    if (!text) return fallback;
    std::array<double, kAxes> v{};
    std::size_t n = 0;
    const char *c = text->data(), *end = c + text->size();
    for (;;) {
        while (c != end && (*c == ' ' || *c == '\t' || *c == ',' || *c == '\n' || *c == '\r')) ++c;
        if (c == end) break;
        double x = 0;
        auto [next, ec] = std::from_chars(c, end, x);
        if (ec != std::errc() || n == kAxes || !std::isfinite(x)) bad(name, *text, expected);
        v[n++] = x;
        c = next;
        if (c != end && *c != ' ' && *c != '\t' && *c != ',' && *c != '\n' && *c != '\r') bad(name, *text, expected);
    }
    if (n != kAxes) bad(name, *text, expected);
    return v;
}

double fraction(const irp::Property &p, std::string_view name, double fallback) {
    const double v = p.get<double>(name, fallback);
    if (!(v > 0.0 && v <= 1.0)) bad(name, p.get(name), "a fraction in (0, 1]");
    return v;
}

}  // namespace

Settings Settings::fromProperties(const irp::Property &p) {
    static constexpr const char *kJoints = "6 joint angles in rad, separated by spaces";
    static constexpr const char *kPose = "a pose 'x y z roll pitch yaw' (m, rad), 6 numbers separated by spaces";
    Settings s;
    s.home = vector6(p, "home", s.home, kJoints);
    s.pick_above = vector6(p, "pick_above", s.pick_above, kJoints);
    s.pick = vector6(p, "pick", s.pick, kPose);
    s.place_above = vector6(p, "place_above", s.place_above, kJoints);
    s.place = vector6(p, "place", s.place, kPose);
    s.lift = p.get<double>("lift", s.lift);
    if (!(s.lift >= 0.0 && s.lift <= 2.0)) bad("lift", p.get("lift"), "a height in m, 0 to 2");
    s.joint_speed = fraction(p, "joint_speed", s.joint_speed);
    s.linear_speed = fraction(p, "linear_speed", s.linear_speed);
    s.accel = fraction(p, "accel", s.accel);
    const int64_t dwell_ms = p.get<int64_t>("dwell_ms", s.dwell.count() / 1'000'000);
    if (dwell_ms < 0 || dwell_ms > 60'000) bad("dwell_ms", p.get("dwell_ms"), "milliseconds, 0 to 60000");
    s.dwell = std::chrono::milliseconds(dwell_ms);
    s.override_default = fraction(p, "override", s.override_default);
    s.auto_enable = p.get<bool>("auto_enable", s.auto_enable);
    return s;
}

// ---- the program -----------------------------------------------------------------------------

PickAndPlace::PickAndPlace(const Settings &settings) : settings_(settings) {
    pickUp_ = settings.pick;
    pickUp_[2] += settings.lift;
    placeUp_ = settings.place;
    placeUp_[2] += settings.lift;
}

void PickAndPlace::fault(int32_t id) {
    if (!errorLatched) {  // the first failing block's ErrorID is the one shown
        errorLatched = true;
        errorId = id;
    }
    step = kIdle;
}

// One step's move: Execute while the sequence is at step `s`; true once the move is Done.  An
// Error ends the cycle with a fault, CommandAborted (a stop, power off) ends it quietly.
template <class Move>
bool PickAndPlace::move(Move &block, Step s, const std::array<double, kAxes> &target, double speed,
                        AxisGroupRef &robot) {
    block.Execute = step == s;
    block.Position = target;
    block.Velocity = speed;
    block.Acceleration = settings_.accel;
    block(robot);
    if (step != s) return false;
    if (block.Error) {
        fault(block.ErrorID);
        return false;
    }
    if (block.CommandAborted) {
        step = kIdle;
        return false;
    }
    return block.Done;
}

void PickAndPlace::scan(const Inputs &in, Outputs &out, AxisGroupRef &robot, Time now) {
    const bool stop = in.I1 || in.Stop;
    double ov = in.Override;
    if (!(ov >= kMinOverride)) ov = kMinOverride;  // also NaN
    if (ov > 1.0) ov = 1.0;
    const double vJ = settings_.joint_speed * ov;
    const double vL = settings_.linear_speed * ov;

    // (* Rung 1: the robot is powered while Enable.  An Enable while the drives do not answer
    //    (after a start or a restart, until the fieldbus is up) waits for them rather than asking
    //    the robot, which would refuse with ErrorID 8; once asked, the request stands, so a comm
    //    loss afterwards is the robot's fault 8 as before. *)
    if (!in.Enable)
        powerOn = false;
    else if (in.DrivesReachable)
        powerOn = true;
    Power.Enable = powerOn;
    Power(robot);
    if (Power.Error) fault(Power.ErrorID);

    // (* Rung 1b: power removed while the cycle runs aborts it, with the program's own fault; no
    //    move of the cycle is requested after the power-off (the robot would refuse it, ErrorID 1) *)
    if (!in.Enable && step != kIdle) fault(kPowerRemoved);

    // (* Rung 2: the robot's own error, shown when no block reported one *)
    GroupError.Enable = true;
    GroupError(robot);

    // (* Rung 3: Stop (a level) ends the cycle and brings the powered robot to standstill *)
    if (stop) step = kIdle;
    StopRobot.Execute = stop && Power.Status && Power.Enable;  // a power-off stops the robot itself
    StopRobot(robot);
    if (StopRobot.Error) fault(StopRobot.ErrorID);

    // (* Rung 4: Reset clears the robot's error, then the program's *)
    ResetRobot.Execute = in.Reset;
    ResetRobot(robot);
    if (ResetRobot.Error) fault(ResetRobot.ErrorID);
    if (ResetDone(ResetRobot.Done)) {
        errorLatched = false;
        errorId = 0;
    }

    // (* Rung 5: a rising edge of Start begins a cycle when powered, not stopped and without error.
    //    A Start already held in the first scan (a reload while the button is held) is no edge. *)
    StartEdge(in.I0 || in.Start);
    if (StartEdge.Q && !firstScan && step == kIdle && Power.Status && !stop && !errorLatched &&
        GroupError.GroupErrorID == 0) {
        step = kHome;
        done = false;
    }

    // (* Steps 1..8: the pick-and-place cycle; each rung moves on when its move is Done *)
    if (move(MoveJ_Home, kHome, settings_.home, vJ, robot)) step = kAbovePick;
    if (move(MoveJ_AbovePick, kAbovePick, settings_.pick_above, vJ, robot)) step = kPickDown;

    PickDwell(move(MoveL_PickDown, kPickDown, settings_.pick, vL, robot), settings_.dwell, now);
    if (PickDwell.Q) step = kPickUp;
    if (move(MoveL_PickUp, kPickUp, pickUp_, vL, robot)) step = kAbovePlace;

    if (move(MoveJ_AbovePlace, kAbovePlace, settings_.place_above, vJ, robot)) step = kPlaceDown;
    PlaceDwell(move(MoveL_PlaceDown, kPlaceDown, settings_.place, vL, robot), settings_.dwell, now);
    if (PlaceDwell.Q) step = kPlaceUp;
    if (move(MoveL_PlaceUp, kPlaceUp, placeUp_, vL, robot)) step = kHomeAgain;

    if (move(MoveJ_HomeAgain, kHomeAgain, settings_.home, vJ, robot)) {
        ++cycles;
        done = true;
        step = in.CycleMode == 1 && !stop ? kHome : kIdle;  // CycleMode 1: again until Stop
    }

    // (* Outputs *)
    out.O0 = *robot.MotionDone != 0;
    out.Running = step != kIdle;
    out.Done = done;
    out.Powered = Power.Status;
    out.WaitingForDrives = in.Enable && !powerOn;
    out.Step = step;
    out.Cycles = cycles;
    out.Error = errorLatched || GroupError.GroupErrorID != 0;
    out.ErrorID = errorLatched ? errorId : GroupError.GroupErrorID;
    firstScan = false;
}

}  // namespace pou
