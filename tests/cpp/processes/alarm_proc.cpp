// alarm_proc.cpp -- a periodic process module that raises an alarm through libindurop's mapping
// of the alarm segment (INDUROP_ALARMS, INDUROP_ALARM_SOURCE; docs/alarms.md), for
// test_alarms_irpd.  Arguments: ID TRIGGER -- every period irp::alarm(ID, TRIGGER exists, "from a
// process", 42).  It also tells, at start, what irp::declareAlarm answers in a process.
#include <indurop/indurop.h>
#include <indurop/property.h>

#include <unistd.h>

#include <cstdio>
#include <cstdlib>

int main(int argc, char *argv[]) {
    setvbuf(stdout, nullptr, _IOLBF, 0);
    if (argc < 3) return 2;
    const auto id = static_cast<uint32_t>(std::atol(argv[1]));
    const char *trigger = argv[2];
    try {
        irp::declareAlarm(id, irp::Severity::High, "declared by the process");
        std::printf("declareAlarm: accepted\n");
    } catch (const irp::PropertyError &e) {
        std::printf("declareAlarm: %s\n", e.what());
    }
    if (irp::initPeriodExe() != 0) return 1;
    while (irp::waitPeriod() == 0) irp::alarm(id, access(trigger, F_OK) == 0, "from a process", 42);
    return 0;
}
