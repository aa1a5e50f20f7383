// cntr4.cpp -- Figure 1's cntr4.exe: a periodic PROCESS module (500 us, priority 4, last in slot 0).
// Released by the dispatcher in its slot and awaited; it moves joint[1].y along a 0..200 degree
// sawtooth that visionEvt (Figure 8) watches, and copies knu.Robot.tick into joints[2].z.
#include <indurop/indurop.h>
#include <indurop/generated.h>

#include <cstdio>

int main() {
    if (irp::initPeriodExe() != 0) return 1;  // not started by irpd
    double y = 0;
    unsigned long periods = 0;
    while (irp::waitPeriod() == 0) {
        y = y + 0.1 < 200 ? y + 0.1 : 0;
        joint[1].y = y;
        knu::Robot::joints[2].z = static_cast<double>(knu::Robot::tick);  // written by cntr2 earlier in the slot
        ++periods;
    }
    std::printf("cntr4: stop after %lu periods\n", periods);
    return 0;
}
