// driver.cpp -- not a figure: moves the global `joint` that Figures 7 and 8 watch, so that their
// events happen: joint[0].x turns 1 degree a period (Figure 7 fires at 180 and resets it),
// joint[1].y follows a 0..200 sawtooth (Figure 8 reacts at 180 and above).
#include <indurop/indurop.h>
#include <indurop/generated.h>

void onRun() {
    joint[0].x += 1;
    joint[1].y = joint[1].y + 0.5 < 200 ? joint[1].y + 0.5 : 0;
}
INDUROP_MODULE(name = "driver", description = "moves joint[0].x and joint[1].y", run = &::onRun)
