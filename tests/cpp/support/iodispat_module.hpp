// iodispat_module.hpp -- libiodispat.so as the I/O dispatcher's tests run it (test_iodispat,
// test_iodispat_alarms): through irpd's own loader, cycle by cycle, on the shipped demo
// ioconfig.xml or one of the test's.  Needs IODISPAT_PATH and support/iodispat.hpp's segment.
#pragma once

#include "hosts/thread_module.hpp"
#include "sdk/runtime.hpp"
#include "subprocess.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <memory>
#include <string>
#include <thread>
#include <utility>
#include <vector>

namespace testing_support {

// The shipped demo ioconfig.xml with another port and device settings.
inline std::string
demoConfig(int port, const std::string &device_settings = R"(timeout_ms="2" fail_limit="3" reconnect_ms="500")") {
    std::string text = readFile(std::string(SOURCE_ROOT) + "/config/sets/plc-robot/ioconfig.xml");
    auto replace = [&](const std::string &from, const std::string &to) {
        const auto at = text.find(from);
        EXPECT_NE(at, std::string::npos) << from;
        if (at != std::string::npos) text.replace(at, from.size(), to);
    };
    replace(R"(port="15020")", "port=\"" + std::to_string(port) + "\"");
    replace(R"(timeout_ms="4" fail_limit="3" reconnect_ms="500")", device_settings);
    return text;
}

// libiodispat.so through irpd's own loader, initialized and started; stopped at the end.  With an
// alarm source, its initialize() and start() declare and raise there, and so does every run()
// (what the reloader and the dispatcher do: docs/alarms.md).
class LoadedModule {
public:
    explicit LoadedModule(uint32_t alarm_source = irp::runtime::kNoAlarmSource) : alarm_source_(alarm_source) {}

    // "" when it runs, else the loader's or the module's message.
    std::string load(const std::string &config, std::vector<std::pair<std::string, std::string>> more = {}) {
        irp::config::ModuleSpec spec;
        spec.name = "libiodispat";
        spec.filename = "./libiodispat.so";
        spec.path = IODISPAT_PATH;
        spec.where = "test/module.xml:3";
        spec.line = 3;
        spec.period_ns = 10'000'000;
        spec.priority = 1;
        spec.properties = {{"config", config}};
        spec.properties.insert(spec.properties.end(), more.begin(), more.end());
        auto m = irp::hosts::ThreadModule::load(spec);
        if (!m) return m.error().message;
        module_ = std::move(*m);
        module_->setAlarmSource(alarm_source_);
        if (irp::Status s = module_->initialize(); !s) return s.error().message;
        if (irp::Status s = module_->start(); !s) return s.error().message;
        run_ = module_->runFunction();
        return "";
    }
    ~LoadedModule() {
        if (module_) (void)module_->stop();
    }
    // One cycle, as the dispatcher calls it; returns how long run() took.
    std::chrono::nanoseconds run() {
        irp::runtime::setAlarmSource(alarm_source_);
        const auto t0 = std::chrono::steady_clock::now();
        run_();
        const auto took = std::chrono::steady_clock::now() - t0;
        irp::runtime::setAlarmSource(irp::runtime::kNoAlarmSource);
        return took;
    }
    const irp::hosts::ThreadModule &module() const { return *module_; }
    // Its safe_outputs(), as irpd's watchdog calls it when a fault stops the set.
    irp::Status safeOutputs() { return module_->safeOutputs(); }

private:
    uint32_t alarm_source_;
    std::unique_ptr<irp::hosts::ThreadModule> module_;
    void (*run_)() = nullptr;
};

// Runs cycles 10 ms apart until done() holds (true) or max_cycles ran (false).
template <class Run, class Done>
bool cyclesUntil(Run &&run, Done done, int max_cycles = 1000) {
    for (int k = 0; k < max_cycles; ++k) {
        run();
        if (done()) return true;
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return false;
}

}  // namespace testing_support
