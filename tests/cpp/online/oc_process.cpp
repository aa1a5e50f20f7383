// oc_process.cpp -- a periodic process module built against v1: counts its periods in oc.proc_runs.
#include <indurop/indurop.h>
#include <indurop/generated.h>

int main() {
    if (irp::initPeriodExe() != 0) return 1;
    while (irp::waitPeriod() == 0) oc::proc_runs += 1;
    return 0;
}
