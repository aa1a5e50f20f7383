// say.hpp -- irpd's own lines on its standard error: "irpd: <line>".  From any non-RT thread
// (the main thread, the control thread, the watchdog's); never from an RT thread.
#pragma once

#include <iostream>
#include <string>

namespace irp::daemon {

inline void say(const std::string &line) { std::cerr << "irpd: " << line << std::endl; }

}  // namespace irp::daemon
