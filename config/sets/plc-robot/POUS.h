// POUS.h -- the PLC program of the plc-robot cell (the POU that main.cpp's POU_PROGRAM() scans,
// after the paper's Figure 12): power, stop, reset and a pick-and-place cycle of eight steps, on
// the PLCopen-style blocks of indurop_plcopen.
//
// The program is written against a process image, not against shared variables: Inputs are
// read before the scan, Outputs written after it, and the robot is an AxisGroupRef.  main.cpp
// binds all three to PLC_ROBOT:: (cell.glb); the tests bind them to a simulated robot.
// docs/plc.md describes the steps, the properties and the inputs and outputs.
#pragma once

#include <indurop/plcopen/plcopen.h>

#include <indurop/property.h>

#include <array>
#include <cstdint>

namespace pou {

using Joints = std::array<double, plcopen::kAxes>;  // joint angles, rad
using Pose = std::array<double, plcopen::kAxes>;    // x y z (m), roll pitch yaw (rad), base frame

// The program's parameters: module.xml properties of main.so (docs/plc.md).
struct Settings {
    Joints home{0.0, -0.5, 1.0, 0.0, 0.5, 0.0};                 // "home"
    Joints pick_above{0.5, -0.3, 1.1, 0.0, 0.8, 0.0};           // "pick_above": MoveJ target above the pick point
    Pose pick{0.45, 0.25, 0.15, 3.14159265358979, 0.0, 0.0};    // "pick": MoveL down to it
    Joints place_above{-0.5, -0.3, 1.1, 0.0, 0.8, 0.0};         // "place_above"
    Pose place{0.45, -0.25, 0.15, 3.14159265358979, 0.0, 0.0};  // "place"
    double lift = 0.10;                // "lift" (m): MoveL up goes to pick/place raised by this along base z
    double joint_speed = 0.5;          // "joint_speed": MoveJ speed, fraction of the maximum, before Override
    double linear_speed = 0.25;        // "linear_speed": MoveL speed, fraction of the maximum, before Override
    double accel = 0.5;                // "accel": acceleration of every move, fraction of the maximum
    plcopen::Time dwell{200'000'000};  // "dwell_ms": wait at the pick and place poses (the gripper)
    double override_default = 1.0;     // "override": PLC_IN.Override set at start when it is 0
    bool auto_enable = false;          // "auto_enable": PLC_IN.Enable = 1 at start

    // The properties given in module.xml over the defaults; irp::PropertyError names a bad one.
    static Settings fromProperties(const irp::Property &property);
};

// The process image: what the program reads at the start of a scan...
struct Inputs {
    bool I0 = false;  // start (rising edge), like Start
    bool I1 = false;  // stop (level), like Stop
    bool Start = false;
    bool Stop = false;
    bool Reset = false;           // rising edge: MC_Reset
    bool Enable = false;          // MC_Power
    int16_t CycleMode = 0;        // 1: repeat the cycle until Stop
    double Override = 1.0;        // scales every move's speed, clamped to [kMinOverride, 1]
    bool DrivesReachable = true;  // the drives' I/O answers (no IO_STATUS.comm_lost): MC_Power may start
};

// ...and what it writes at the end.
struct Outputs {
    bool O0 = false;  // the robot's MotionDone (the interlock lamp)
    bool Running = false;
    bool Done = false;
    bool Error = false;
    bool Powered = false;
    bool WaitingForDrives = false;  // Enable is set, MC_Power waits for the drives to answer
    int32_t Step = 0;
    int32_t ErrorID = 0;
    uint32_t Cycles = 0;
};

enum Step : int32_t {
    kIdle = 0,
    kHome = 1,        // MoveJ home
    kAbovePick = 2,   // MoveJ pick_above
    kPickDown = 3,    // MoveL pick, then dwell
    kPickUp = 4,      // MoveL pick + lift
    kAbovePlace = 5,  // MoveJ place_above
    kPlaceDown = 6,   // MoveL place, then dwell
    kPlaceUp = 7,     // MoveL place + lift
    kHomeAgain = 8,   // MoveJ home; then the cycle is done
};

inline constexpr double kMinOverride = 0.01;

// The program's own ErrorID (the robot's are 1-8, the blocks' 1001-1004; module.xml's <alarm>s):
// Enable was removed while the cycle ran, which aborts it.  The clean stop is Stop (or CycleMode
// 0 and the cycle's end), then Enable = 0 once the cycle and the robot are idle.
inline constexpr int32_t kPowerRemoved = 1010;

class PickAndPlace {
public:
    explicit PickAndPlace(const Settings &settings);

    // One PLC scan: `now` is the scan's time (monotonic), for the timers.
    void scan(const Inputs &in, Outputs &out, plcopen::AxisGroupRef &robot, plcopen::Time now);

    // The POU's variables, as a PLC's variable table shows them (public for monitoring and tests).
    plcopen::MC_Power Power;
    plcopen::MC_Stop StopRobot;
    plcopen::MC_Reset ResetRobot;
    plcopen::MC_GroupReadError GroupError;
    plcopen::MC_MoveAbsolute MoveJ_Home, MoveJ_AbovePick, MoveJ_AbovePlace, MoveJ_HomeAgain;
    plcopen::MC_MoveLinear MoveL_PickDown, MoveL_PickUp, MoveL_PlaceDown, MoveL_PlaceUp;
    plcopen::R_TRIG StartEdge, ResetDone;
    plcopen::TON PickDwell, PlaceDwell;
    int32_t step = kIdle;
    bool done = false;
    bool errorLatched = false;
    int32_t errorId = 0;
    uint32_t cycles = 0;
    bool firstScan = true;
    bool powerOn = false;  // MC_Power's Enable: Enable once the drives answered (then held until Enable falls)

private:
    template <class Move>
    bool move(Move &block, Step s, const std::array<double, plcopen::kAxes> &target, double speed,
              plcopen::AxisGroupRef &robot);
    void fault(int32_t id);

    Settings settings_;
    Pose pickUp_, placeUp_;
};

}  // namespace pou
