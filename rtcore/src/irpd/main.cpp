// main.cpp -- irpd, the indurop real-time core daemon: options, signals, then daemon::run, and
// the managed restart's exec (irpd/restart.hpp) when the run asked for one or a restart's new set
// did not start.
#include "irpd/daemon.hpp"
#include "irpd/options.hpp"
#include "osal/clock.hpp"
#include "shm/layout_json.hpp"

#include <nlohmann/json.hpp>

#include <signal.h>
#include <sys/prctl.h>

#include <iostream>

#ifndef INDUROP_VERSION
#define INDUROP_VERSION "0.0.0"
#endif

int main(int argc, char **argv) {
    irp::daemon::Session session;
    session.began_ns = irp::osal::monotonicNow();
    auto arrived = irp::daemon::takeRestartPlan();
    if (!arrived)
        std::cerr << "irpd: WARNING: " << arrived.error().message << "; starting as a fresh irpd\n";
    else
        session.arrived = std::move(*arrived);
    if (session.arrived && !session.arrived->process_name.empty())
        prctl(PR_SET_NAME, session.arrived->process_name.c_str(), 0, 0, 0);
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
    if (options->print_shm_layout) {
        std::cout << irp::shm::layoutJson().dump(2) << std::endl;
        return irp::daemon::kExitOk;
    }
    if (options->version) {
        std::cout << "irpd " << INDUROP_VERSION << "\n";
        return irp::daemon::kExitOk;
    }
    const int status = irp::daemon::run(*options, session);
    const std::vector<std::string> args(argv, argv + argc);
    if (session.restart) {
        std::cerr << "irpd: restarting onto " << irp::daemon::describeSet(session.restart->target) << std::endl;
        const irp::Error failed = irp::daemon::reexec(args, *session.restart);
        std::cerr << "irpd: error: " << failed.message << std::endl;
        return irp::daemon::kExitFailure;
    }
    // A restart's new set that did not start: the set that ran before, once (never a loop).
    if (session.arrived && !session.arrived->fallback && !session.dispatched && status != irp::daemon::kExitOk) {
        const irp::daemon::RestartPlan back = session.arrived->fallBack(session.error);
        std::cerr << "irpd: set " << irp::daemon::describeSet(back.target) << " did not start; back onto set "
                  << irp::daemon::describeSet(back.origin) << std::endl;
        const irp::Error failed = irp::daemon::reexec(args, back);
        std::cerr << "irpd: error: " << failed.message << std::endl;
        return irp::daemon::kExitFailure;
    }
    return status;
}
