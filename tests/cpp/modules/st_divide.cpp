// st_divide.cpp -- a thread module written the way the ST code generator writes one
// (docs/st-runtime.md), for this ST program:
//   PROGRAM Main                                          (main.st)
//     VAR divisor : INT := 3; quotient : INT; END_VAR
//     quotient := 100 / divisor;                          (line 12, column 9: the `/`)
//     divisor := divisor - 1;
//   END_PROGRAM
// Its fourth run divides by zero: irpd disables it and the `fault` event names main.st:12:9.
#include <indurop/indurop.h>
#include <indurop/st/st.hpp>

namespace {
irp::st::INT divisor = 3;
irp::st::INT quotient = 0;
constexpr irp::st::Place kAt12_9{"main.st", 12, 9, "PROGRAM Main"};
}  // namespace

void run() {
#line 12 "main.st"
    quotient = irp::st::DIV(kAt12_9, irp::st::INT{100}, divisor);
#line 13 "main.st"
    divisor = irp::st::SUB(divisor, irp::st::INT{1});
}
