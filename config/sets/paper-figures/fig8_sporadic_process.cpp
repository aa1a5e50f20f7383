//sporadic-process1
// fig8_sporadic_process.cpp -- the paper's Figure 8 (also Figure 1's visionEvt.exe, config/sets/paper-fig1),
// with only its slips fixed (condition's parameter type, the loop condition, read_ret's declaration,
// processEvent declared before use) and the elided channel connection filled in.
#include <indurop/indurop.h>
#include <fstream>
#include <cstdio>

int condition(double event){
if(event <0 || event >= 180)
    return 1; // occur event
else
    return 0;
}
void processEvent(double event);
int main(int argc, char* argv[]){
    double y_pos;
    int read_ret;
    channel::Handle handle; // connection channel for event handler
    irp::initPeriodExe(); // enrollment of signal to event handler

    // connect channel to process for shared variables ;
    channel::connect(handle);
    while(true){
        irp::waitPeriod(); // wait signal from event handler
        read_ret = read(handle, "joint[1].y", sizeof(y_pos), &y_pos);
        // read value from shared variable named "joint[1].y" in Fig. 3
        if (condition(y_pos))
            processEvent(y_pos) ;
    }
    return 0;
}
void processEvent(double event)
{
    // process event
    static unsigned long events = 0;
    if (++events % 1000 == 1) std::printf("Figure 8: event %lu, joint[1].y = %.1f\n", events, event), std::fflush(stdout);
}
