// axis_group.cpp -- writing one request of the PLC -> robot protocol (axis_group.h).
#include <indurop/plcopen/axis_group.h>

namespace plcopen {

uint32_t AxisGroupRef::request(OpCode op, double speed, double accel, const double *target) {
    *eOpCode = static_cast<int32_t>(op);
    *t_speed = speed;
    *t_accel = accel;
    if (target)
        for (int i = 0; i < kAxes; ++i) dTarget[i] = target[i];
    const uint32_t seq = *nSeq + 1;
    *nSeq = seq;  // last: the robot takes the request when it sees nSeq change
    return seq;
}

}  // namespace plcopen
