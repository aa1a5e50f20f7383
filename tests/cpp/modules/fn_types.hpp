// fn_types.hpp -- the value types that the shared-function fixtures pass between a thread module
// (modules/served.cpp) and a process module (processes/fn_caller.cpp): both sides compile these.
#pragma once

#include <cstdint>

namespace fn_types {

struct Pair {  // padding after `a`: the packed bytes are the struct's, padding included
    int32_t a;
    double b;
};

struct Big {  // 300 bytes: more than a call from a process carries
    char bytes[300];
};

}  // namespace fn_types
