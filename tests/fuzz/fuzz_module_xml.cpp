// fuzz_module_xml.cpp -- libFuzzer target: arbitrary bytes as a set's module.xml, through what
// irpd does with a file it is asked to load before touching any module: parseModuleXmlText, then
// (for a valid set) the slot table, its text and its JSON.  Either an Error with a message, or a
// schedule; a sanitizer report, an exception or an empty message is a finding.
#include "config/module_xml.hpp"
#include "schedule/schedule.hpp"

#include <nlohmann/json.hpp>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string_view>

namespace {

[[noreturn]] void finding(const char *what) {
    std::fprintf(stderr, "fuzz_module_xml: %s\n", what);
    std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    const std::string_view text(reinterpret_cast<const char *>(data), size);
    auto set = irp::config::parseModuleXmlText(text, "/fuzz/set/module.xml");
    if (!set) {
        if (set.error().message.empty()) finding("a refusal without a message");
        return 0;
    }
    // A tight limit keeps each input fast; the checks are the same as irpd's.
    irp::schedule::Limits limits;
    limits.min_basic_ns = 1;
    limits.max_slots = 4096;
    auto schedule = irp::schedule::build(*set, limits);
    if (!schedule) {
        if (schedule.error().message.empty()) finding("a schedule refusal without a message");
        return 0;
    }
    if (schedule->slots.empty() || schedule->basic_ns <= 0 || schedule->macro_ns % schedule->basic_ns != 0)
        finding("a schedule that is no slot table");
    (void)irp::schedule::formatText(*schedule, *set);
    (void)irp::schedule::toJson(*schedule, *set).dump();
    return 0;
}
