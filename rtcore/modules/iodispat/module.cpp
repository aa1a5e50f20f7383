// module.cpp -- libiodispat.so, the I/O dispatcher as a thread module in the plain style of the
// paper's Figure 12 (module.xml as in Figure 9):
//
//   <module>
//     <filename>./libiodispat.so</filename> <moduletype>thread</moduletype>
//     <operationtype>periodic</operationtype> <period>10000000</period> <priority>1</priority>
//     <property><value name="config">ioconfig.xml</value></property>
//   </module>
//
// initialize() reads ioconfig.xml (property `config`; a relative path is looked for in the
// property `config_dir` if given, else beside the set's module.xml) and declares its alarms (a
// device's comm lost, a drive's fault: alarms.hpp); start() resolves the shared variables and
// opens the devices; run() is one I/O cycle:
// fieldbus I/O inside the RT period by design, as in the paper, bounded by the devices' timeouts
// and the budget (docs/io.md); stop() closes the devices.  safe_outputs() is irpd's hook when a
// fault stops the set: every Modbus TCP device's safe values over a connection of its own, from
// irpd's watchdog thread, while run() may be stuck (docs/faults.md).
//
// One instance per loaded library: the dispatcher's state is this file's globals.
#include "dispatcher.hpp"
#include "safe_outputs.hpp"

#include <indurop/indurop.h>

#include <atomic>
#include <fstream>
#include <filesystem>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

std::unique_ptr<irp::iodispat::Dispatcher> g_dispatcher;
// What safe_outputs() reads: the configuration, set before the first run() and only reset by
// stop(), which irpd calls after its watchdog has ended.
std::atomic<const irp::iodispat::IoConfig *> g_config{nullptr};
bool g_started = false;

std::string findConfig(const irp::Property &property) {
    const auto value = property.find("config");
    if (!value || value->empty()) throw irp::PropertyError("property 'config' is required: the path of ioconfig.xml");
    const std::filesystem::path written{std::string(*value)};
    // config_dir if given, else the folder of the set's module.xml (irp::Property::path).
    const std::filesystem::path file = written.is_relative() && property.find("config_dir")
                                           ? std::filesystem::path(std::string(*property.find("config_dir"))) / written
                                           : std::filesystem::path(property.path("config"));
    std::error_code ec;
    if (!std::filesystem::is_regular_file(file, ec))
        throw irp::PropertyError("property 'config': " + file.string() +
                                 " does not exist (a relative name is looked "
                                 "for beside module.xml, or in the property config_dir)");
    return std::filesystem::absolute(file).lexically_normal().string();
}

}  // namespace

extern "C" void initialize(irp::Property const &property) {
    if (g_started)
        throw std::runtime_error(
            "libiodispat.so is already running in this irpd (its state is per library): stop the running set, "
            "or restart irpd, to change its configuration");
    g_dispatcher.reset();
    const std::string file = findConfig(property);
    irp::iodispat::IoConfig config = irp::iodispat::parseIoConfig(file);
    // fd= hands a device a descriptor already open in this process: the unit tests' and fuzz
    // targets' way to a CAN port without a CAN interface.  In irpd the number would name one of
    // irpd's own descriptors (its control socket, a shared-memory segment, the journal).
    for (const irp::iodispat::DeviceConfig &d : config.devices)
        if (d.fd >= 0)
            throw irp::PropertyError(d.file + ":" + std::to_string(d.line) + ": device '" + d.name + "': fd=\"" +
                                     std::to_string(d.fd) +
                                     "\" is a test hook that irpd does not accept; name the "
                                     "SocketCAN interface instead (interface=\"can0\")");
    g_dispatcher = std::make_unique<irp::iodispat::Dispatcher>(std::move(config));
    for (const irp::iodispat::AlarmText &a : irp::iodispat::alarmTexts(g_dispatcher->config()))
        irp::declareAlarm(a.id, a.severity, a.text.c_str());
    irp::printf("iodispat: %s: %zu device(s)", file.c_str(), g_dispatcher->deviceCount());
}

void start() {
    if (!g_dispatcher) throw std::runtime_error("start() without a successful initialize()");
    try {
        g_dispatcher->start();
    } catch (...) {
        g_dispatcher.reset();
        throw;
    }
    g_config.store(&g_dispatcher->config());
    g_started = true;
}

void run() {
    if (g_dispatcher) g_dispatcher->cycle();
}

extern "C" void safe_outputs() {
    const irp::iodispat::IoConfig *config = g_config.load();
    if (!config) return;
    // A short, fixed timeout: the devices are on a LAN, and this runs while the set is stopped;
    // three attempts, so that one late answer does not leave a drive enabled.
    const std::vector<std::string> failures =
        irp::iodispat::driveSafeOutputs(*config, irp::iodispat::kSafeTimeoutMs, irp::iodispat::kSafeAttempts);
    if (failures.empty()) return;
    std::string all;
    for (const std::string &f : failures) all += (all.empty() ? "" : "; ") + f;
    throw std::runtime_error(all);
}

void stop() {
    g_config.store(nullptr);
    if (g_dispatcher) {
        g_dispatcher->stop();
        irp::printf("iodispat: stopped after %llu cycles, the longest %lld us",
                    static_cast<unsigned long long>(g_dispatcher->cycles()),
                    static_cast<long long>(g_dispatcher->maxCycleNs() / 1000));
    }
    g_dispatcher.reset();
    g_started = false;
}
