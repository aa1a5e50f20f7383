// layout_json.cpp -- the segments' descriptions (describe.hpp) written out as JSON.
#include "shm/layout_json.hpp"

#include <nlohmann/json.hpp>

#include <string>

namespace irp::shm {
namespace {

using json = nlohmann::ordered_json;

std::string str(std::string_view s) { return std::string(s); }

// The magic's eight bytes as text ("IRPVARS1"): how the segments' headers spell them.
std::string magicText(uint64_t magic) {
    std::string text;
    for (int i = 0; i < 8; ++i) text += static_cast<char>((magic >> (8 * i)) & 0xff);
    return text;
}

json constants(std::span<const Constant> list) {
    json out = json::object();
    for (const Constant &c : list) out[str(c.name)] = {{"value", c.value}, {"meaning", str(c.meaning)}};
    return out;
}

json structJson(const Struct &s) {
    json fields = json::object();
    for (const Field &f : s.fields) {
        json entry = {{"offset", f.offset}, {"size", f.size}, {"type", str(f.type)}};
        if (f.count) entry["count"] = f.count;
        entry["meaning"] = str(f.meaning);
        fields[str(f.name)] = std::move(entry);
    }
    return {{"size", s.size}, {"align", s.align}, {"meaning", str(s.meaning)}, {"fields", std::move(fields)}};
}

}  // namespace

json segmentJson(const Segment &segment) {
    json structs = json::object();
    for (const Struct &s : segment.structs) structs[str(s.name)] = structJson(s);
    json enums = json::object();
    for (const Enum &e : segment.enums)
        enums[str(e.name)] = {{"meaning", str(e.meaning)}, {"values", constants(e.values)}};
    return {{"shm", str(segment.shm)},       {"meaning", str(segment.meaning)},
            {"magic", segment.magic},        {"magic_text", magicText(segment.magic)},
            {"version", segment.version},    {"header", str(segment.header)},
            {"structs", std::move(structs)}, {"constants", constants(segment.constants)},
            {"enums", std::move(enums)}};
}

json layoutJson() {
    json segments = json::object();
    for (const Segment *s :
         {&variablesSegment(), &statsSegment(), &traceSegment(), &controlSegment(), &alarmsSegment()})
        segments[str(s->name)] = segmentJson(*s);
    return {{"format", kDescriptionFormat},
            {"byte_order", "little"},
            {"written_by", "irpd --print-shm-layout; regenerate the copies with `ninja -C build shm-layout`"},
            {"segments", std::move(segments)}};
}

}  // namespace irp::shm
