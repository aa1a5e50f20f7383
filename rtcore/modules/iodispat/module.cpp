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
// property `config_dir`, then beside the module.xml irpd was started with, then in irpd's working
// directory); start() resolves the shared variables and opens the devices; run() is one I/O cycle:
// fieldbus I/O inside the RT period by design, as in the paper, bounded by the devices' timeouts
// and the budget (docs/io.md); stop() closes the devices.
//
// One instance per loaded library: the dispatcher's state is this file's globals.
#include "dispatcher.hpp"

#include <indurop/indurop.h>

#include <fstream>
#include <filesystem>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

std::unique_ptr<irp::iodispat::Dispatcher> g_dispatcher;
bool g_started = false;

// The --config argument of the running irpd (its module.xml), if there is one.
std::filesystem::path irpdSetFolder() {
    std::ifstream in("/proc/self/cmdline", std::ios::binary);
    std::vector<std::string> args;
    for (std::string a; std::getline(in, a, '\0');) args.push_back(a);
    for (std::size_t i = 0; i < args.size(); ++i) {
        if (args[i] == "--config" && i + 1 < args.size()) return std::filesystem::path(args[i + 1]).parent_path();
        if (args[i].rfind("--config=", 0) == 0) return std::filesystem::path(args[i].substr(9)).parent_path();
    }
    return {};
}

std::string findConfig(const irp::Property &property) {
    const auto value = property.find("config");
    if (!value || value->empty()) throw irp::PropertyError("property 'config' is required: the path of ioconfig.xml");
    const std::string written(*value);
    const std::filesystem::path p(written);
    if (p.is_absolute()) return written;
    std::vector<std::filesystem::path> tried;
    if (auto dir = property.find("config_dir")) tried.push_back(std::filesystem::path(std::string(*dir)) / p);
    if (auto set = irpdSetFolder(); !set.empty()) tried.push_back(set / p);
    tried.push_back(std::filesystem::current_path() / p);
    for (const auto &candidate : tried) {
        std::error_code ec;
        if (std::filesystem::is_regular_file(candidate, ec)) return std::filesystem::absolute(candidate).lexically_normal().string();
    }
    std::string list;
    for (const auto &candidate : tried) list += (list.empty() ? "" : ", ") + candidate.string();
    throw irp::PropertyError("property 'config': '" + written + "' not found (looked at " + list +
                             "); give an absolute path or the property config_dir");
}

} // namespace

extern "C" void initialize(irp::Property const &property) {
    if (g_started)
        throw std::runtime_error("libiodispat.so is already running in this irpd (its state is per library): stop the running set, "
                                 "or restart irpd, to change its configuration");
    g_dispatcher.reset();
    const std::string file = findConfig(property);
    g_dispatcher = std::make_unique<irp::iodispat::Dispatcher>(irp::iodispat::parseIoConfig(file));
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
    g_started = true;
}

void run() {
    if (g_dispatcher) g_dispatcher->cycle();
}

void stop() {
    if (g_dispatcher) {
        g_dispatcher->stop();
        irp::printf("iodispat: stopped after %llu cycles, the longest %lld us", static_cast<unsigned long long>(g_dispatcher->cycles()),
                    static_cast<long long>(g_dispatcher->maxCycleNs() / 1000));
    }
    g_dispatcher.reset();
    g_started = false;
}
