// main.cpp -- irpd, the indurop real-time core daemon: options, signals, then daemon::run.
#include "irpd/daemon.hpp"
#include "irpd/options.hpp"
#include "stats/layout_json.hpp"

#include <nlohmann/json.hpp>

#include <signal.h>

#include <iostream>

#ifndef INDUROP_VERSION
#define INDUROP_VERSION "0.0.0"
#endif

int main(int argc, char **argv) {
    // SIGINT/SIGTERM are taken with sigtimedwait by the main thread; blocked here, before any
    // thread exists, so that the RT threads never get them.
    sigset_t stop_signals;
    sigemptyset(&stop_signals);
    sigaddset(&stop_signals, SIGINT);
    sigaddset(&stop_signals, SIGTERM);
    pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr);
    signal(SIGPIPE, SIG_IGN);  // a control client or a pipe that goes away is an error value, not a death

    auto options = irp::daemon::parseOptions(argc, argv);
    if (!options) {
        std::cerr << "irpd: " << options.error().message << "\n\n" << irp::daemon::usage();
        return irp::daemon::kExitRefused;
    }
    if (options->help) {
        std::cout << irp::daemon::usage();
        return irp::daemon::kExitOk;
    }
    if (options->print_stats_layout) {
        std::cout << irp::stats::layoutJson().dump(2) << std::endl;
        return irp::daemon::kExitOk;
    }
    if (options->version) {
        std::cout << "irpd " << INDUROP_VERSION << "\n";
        return irp::daemon::kExitOk;
    }
    return irp::daemon::run(*options);
}
