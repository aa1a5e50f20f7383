// nonReaTime.cpp -- Figure 1's nonReaTime.exe: a NON-REAL process module.  Started with the set at
// SCHED_OTHER, it gets the CPU time the real-time work leaves; it reads the shared variables
// like any global and reports once a second.
#include <indurop/generated.h>

#include <chrono>
#include <cstdio>
#include <thread>

int main() {
    for (;;) {
        std::this_thread::sleep_for(std::chrono::seconds(1));
        std::printf("nonReaTime: tick = %u, joint[0].x = %.2f, joint[1].y = %.1f\n",
                    static_cast<unsigned>(knu::Robot::tick), static_cast<double>(joint[0].x),
                    static_cast<double>(joint[1].y));
        std::fflush(stdout);
    }
}
