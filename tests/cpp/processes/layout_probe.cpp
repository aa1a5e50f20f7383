// layout_probe.cpp -- built against other_layout.glb; irpd runs the test layout, so
// irp::initPeriodExe() must end it with status 78 before it touches a variable.
#include <indurop/indurop.h>
#include <indurop/generated.h>

#include <cstdio>

int main() {
    irp::initPeriodExe();
    std::printf("initPeriodExe returned: the layout check did not stop this process\n");
    joint[4].x = 1;  // would write past the running layout's joint[4]
    return 0;
}
