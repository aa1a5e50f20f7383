// tick_writer.cpp -- a thread module for test_process_release, built against the test .glb: its
// run() writes test.cell.tick = the basic period's count (property write, default 1).  Every
// pause_every-th run it first sleeps pause_us (its dispatcher blocks before it writes: a process
// after it in the slot, whose own timer has fired, could run then); every stall_every-th run it
// sleeps stall_us after writing (past the basic period: with --overrun-policy skip the dispatcher
// then skips slots).  Sleeping, not spinning, so that the CPU is free meanwhile.
#include <indurop/generated.h>
#include <indurop/indurop.h>

#include <time.h>

#include <cstdint>

namespace {
long write_tick = 1, pause_every = 0, pause_us = 0, stall_every = 0, stall_us = 0;
unsigned long runs = 0;

void sleepUs(long us) {
    timespec ts{us / 1'000'000, (us % 1'000'000) * 1000};
    nanosleep(&ts, nullptr);
}
}  // namespace

extern "C" void initialize(irp::Property const &p) {
    write_tick = p.get<long>("write", 1);
    pause_every = p.get<long>("pause_every", 0);
    pause_us = p.get<long>("pause_us", 0);
    stall_every = p.get<long>("stall_every", 0);
    stall_us = p.get<long>("stall_us", 0);
}

void run() {
    ++runs;
    if (pause_every > 0 && runs % pause_every == 0) sleepUs(pause_us);
    if (write_tick) test::cell::tick = static_cast<uint32_t>(irp::cycle().count);
    if (stall_every > 0 && runs % stall_every == 0) sleepUs(stall_us);
}
