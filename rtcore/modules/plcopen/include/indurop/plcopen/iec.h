// iec.h -- the IEC 61131-3 standard function blocks the PLC programs need: R_TRIG, F_TRIG (edge
// detection) and TON (on-delay timer), with the standard's semantics.
//
// As in IEC 61131-3 Structured Text, a block keeps its state between scans; a program sets its
// inputs and calls it once per scan, then reads its outputs:
//     StartEdge(CLK);  if (StartEdge.Q) ...          // or: StartEdge.CLK = x; StartEdge();
//     Dwell.IN = atPick; Dwell.PT = 200ms; Dwell(now); if (Dwell.Q) ...
// Time is passed in by the caller (the scan's time, e.g. irp::cycle().planned_ns), so a timer is
// exact with respect to the dispatcher's periods and a test can step it without sleeping.
// Like the motion blocks (motion.h), each is a plain value: inputs, outputs, then its memory.
#pragma once

#include <chrono>
#include <type_traits>

namespace plcopen {

using Time = std::chrono::nanoseconds;

// Rising edge: Q is TRUE for the one call in which CLK goes FALSE -> TRUE.  Like the standard's
// R_TRIG (M starts FALSE), a CLK already TRUE at the first call is an edge.
struct R_TRIG {
    bool CLK = false;
    bool Q = false;

    bool operator()() {
        Q = CLK && !M;
        M = CLK;
        return Q;
    }
    bool operator()(bool clk) {
        CLK = clk;
        return (*this)();
    }

    bool M = false;  // memory: CLK of the previous call
};

// Falling edge: Q is TRUE for the one call in which CLK goes TRUE -> FALSE.  M starts TRUE as in
// the standard, so a CLK FALSE at the first call is not an edge.
struct F_TRIG {
    bool CLK = false;
    bool Q = false;

    bool operator()() {
        Q = !CLK && !M;
        M = !CLK;
        return Q;
    }
    bool operator()(bool clk) {
        CLK = clk;
        return (*this)();
    }

    bool M = true;  // memory: NOT CLK of the previous call
};

// On-delay: Q goes TRUE once IN has been TRUE for PT; ET is the time IN has been TRUE, at most PT.
// IN FALSE resets Q and ET at once.  PT = 0 makes Q follow IN.
struct TON {
    bool IN = false;
    Time PT{0};
    bool Q = false;
    Time ET{0};

    bool operator()(Time now);
    bool operator()(bool in, Time pt, Time now) {
        IN = in;
        PT = pt;
        return (*this)(now);
    }

    // Memory
    bool running_ = false;
    Time start_{0};
};

static_assert(std::is_trivially_copyable_v<R_TRIG> && std::is_standard_layout_v<R_TRIG>);
static_assert(std::is_trivially_copyable_v<F_TRIG> && std::is_standard_layout_v<F_TRIG>);
static_assert(std::is_trivially_copyable_v<TON> && std::is_standard_layout_v<TON>);

}  // namespace plcopen
