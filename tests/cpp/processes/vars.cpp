// vars.cpp -- a process module built against the test .glb: in each period it reads joint[1].y by
// path and through the generated global, writes joint[2].x = 2 * y and test.cell.tick = the
// cycle by path, and shows what bad paths and sizes give.
#include <indurop/indurop.h>
#include <indurop/generated.h>

#include <cstdint>
#include <cstdio>

int main() {
    setvbuf(stdout, nullptr, _IOLBF, 0);
    channel::Handle handle;
    if (irp::initPeriodExe() != 0) return 2;
    std::printf("connect=%d %s\n", channel::connect(handle), channel::lastError(handle));
    while (irp::waitPeriod() == 0) {
        double y = 0;
        const int rc = read(handle, "joint[1].y", sizeof y, &y);
        std::printf("read joint[1].y rc=%d value=%g global=%g\n", rc, y, static_cast<double>(joint[1].y));
        const double x = 2 * y;
        const uint32_t tick = static_cast<uint32_t>(irp::cycle().count);
        std::printf("write joint[2].x rc=%d\n", write(handle, "joint[2].x", sizeof x, &x));
        std::printf("write tick rc=%d\n", write(handle, "test.cell.tick", sizeof tick, &tick));
        std::printf("bad path rc=%d: %s\n", read(handle, "joint[1].w", sizeof y, &y), channel::lastError(handle));
        std::printf("bad index rc=%d: %s\n", read(handle, "joint[4].y", sizeof y, &y), channel::lastError(handle));
        std::printf("bad size rc=%d: %s\n", read(handle, "joint[1].y", sizeof(float), &y), channel::lastError(handle));
        std::printf("done\n");
    }
    return 0;
}
