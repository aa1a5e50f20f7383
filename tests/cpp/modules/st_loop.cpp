// st_loop.cpp -- a thread module written the way the ST code generator writes one
// (docs/st-runtime.md), for this ST program:
//   PROGRAM Main                                          (main.st)
//     VAR n : DINT; spins : DINT; END_VAR
//     n := n + 1;
//     WHILE n > 5 DO                                      (line 30, column 5)
//       spins := spins + 1;                               (never ends from its 6th run on)
//     END_WHILE;
//   END_PROGRAM
// irpd's overrun watchdog asks the run to end; the loop guard then throws a RuntimeFault naming
// line 30, and irpd disables the module.
#include <indurop/indurop.h>
#include <indurop/st/st.hpp>

namespace {
irp::st::DINT n = 0;
irp::st::DINT spins = 0;
constexpr irp::st::Place kLoop30_5{"main.st", 30, 5, "PROGRAM Main"};
}  // namespace

void run() {
#line 29 "main.st"
    n = irp::st::ADD(n, 1);
#line 30 "main.st"
    while (irp::st::GT(n, 5)) {
#line 31 "main.st"
        spins = irp::st::ADD(spins, 1);
        irp::st::loopCheck(kLoop30_5);
    }
}
