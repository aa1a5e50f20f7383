// test_shm_layout.cpp -- irpd's description of its shared-memory segments (rtcore/src/shm/): the
// completeness check catches an undescribed member, the description agrees with the structs and
// constants irpd compiles, and the agent's copy (agent/indurop_agent/irpd/shm_layout.json) is current.
#include "shm/layout_json.hpp"
#include "stats/stats_block.hpp"

#include <indurop/control.h>
#include <indurop/segment.h>
#include <indurop/shared.h>
#include <indurop/trace.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cstddef>
#include <fstream>
#include <sstream>

namespace {

using json = nlohmann::ordered_json;
using irp::shm::Field;

// A struct with a member in the middle, another at the end, and tail padding of its alignment.
struct alignas(16) Sample {
    uint64_t a;
    uint32_t b;
    uint32_t c;
    uint16_t d;
};

constexpr Field kComplete[] = {
    IRP_SHM_FIELD(Sample, a, ""),
    IRP_SHM_FIELD(Sample, b, ""),
    IRP_SHM_FIELD(Sample, c, ""),
    IRP_SHM_FIELD(Sample, d, ""),
};
constexpr Field kWithoutB[] = {IRP_SHM_FIELD(Sample, a, ""), IRP_SHM_FIELD(Sample, c, ""),
                               IRP_SHM_FIELD(Sample, d, "")};
constexpr Field kWithoutD[] = {IRP_SHM_FIELD(Sample, a, ""), IRP_SHM_FIELD(Sample, b, ""),
                               IRP_SHM_FIELD(Sample, c, "")};
constexpr Field kOutOfOrder[] = {IRP_SHM_FIELD(Sample, a, ""), IRP_SHM_FIELD(Sample, c, ""),
                                 IRP_SHM_FIELD(Sample, b, ""), IRP_SHM_FIELD(Sample, d, "")};

std::size_t gap(std::span<const Field> fields) {
    return irp::shm::firstUndescribed(fields, sizeof(Sample), alignof(Sample));
}

TEST(ShmDescribe, ATableCoveringEveryByteButTheTailPaddingIsComplete) {
    EXPECT_EQ(gap(kComplete), sizeof(Sample));
    EXPECT_TRUE(irp::shm::describesEveryByte<Sample>(kComplete));
}

TEST(ShmDescribe, AMissingMemberIsFoundWhereItStarts) {
    EXPECT_EQ(gap(kWithoutB), offsetof(Sample, b));
    EXPECT_EQ(gap(kWithoutD), offsetof(Sample, d));  // the last member: more than the padding is left
    EXPECT_EQ(gap(kOutOfOrder), offsetof(Sample, b));
    EXPECT_FALSE(irp::shm::describesEveryByte<Sample>(kWithoutD));
}

TEST(ShmDescribe, AFieldTakesItsTypeSizeAndCountFromTheCompiler) {
    constexpr Field f = IRP_SHM_FIELD(indurop_trace_channel, path, "x");
    EXPECT_EQ(f.type, "char");
    EXPECT_EQ(f.count, std::size_t{INDUROP_TRACE_PATH_CHARS});
    EXPECT_EQ(f.size, sizeof(indurop_trace_channel::path));
    constexpr Field state = IRP_SHM_FIELD(irp::stats::TimingRecord, state, "x");  // std::atomic<uint32_t>
    EXPECT_EQ(state.type, "u32");
    EXPECT_EQ(state.count, 0u);
    constexpr Field kind = IRP_SHM_FIELD(irp::stats::TimingRecord, kind, "x");  // enum class : uint32_t
    EXPECT_EQ(kind.type, "u32");
}

const json &layout() {
    static const json j = irp::shm::layoutJson();
    return j;
}

std::size_t offsetIn(const char *segment, const char *st, const char *field) {
    return layout()["segments"][segment]["structs"][st]["fields"][field]["offset"].get<std::size_t>();
}

TEST(ShmLayout, DescribesEachSegmentWithTheConstantsIrpdIsBuiltWith) {
    const json &s = layout()["segments"];
    EXPECT_EQ(s["variables"]["magic"].get<uint64_t>(), INDUROP_SEGMENT_MAGIC);
    EXPECT_EQ(s["variables"]["version"], INDUROP_SEGMENT_VERSION);
    EXPECT_EQ(s["variables"]["magic_text"], "IRPVARS1");
    EXPECT_EQ(s["trace"]["magic"].get<uint64_t>(), INDUROP_TRACE_MAGIC);
    EXPECT_EQ(s["trace"]["constants"]["no_seq"]["value"].get<uint64_t>(), INDUROP_TRACE_NO_SEQ);
    EXPECT_EQ(s["trace"]["enums"]["indurop_trace_type"]["values"]["double"]["value"], INDUROP_TRACE_FLOAT64);
    EXPECT_EQ(s["control"]["magic"].get<uint64_t>(), INDUROP_CONTROL_MAGIC);
    EXPECT_EQ(s["control"]["version"], INDUROP_CONTROL_VERSION);
    EXPECT_EQ(s["stats"]["magic"].get<uint64_t>(), irp::stats::kMagic);
    EXPECT_EQ(s["stats"]["constants"]["bucket_count"]["value"], irp::stats::kBuckets);
}

TEST(ShmLayout, GivesTheOffsetsAndSizesOfTheStructs) {
    EXPECT_EQ(offsetIn("variables", "indurop_segment_header", "layout_seq"),
              offsetof(indurop_segment_header, layout_seq));
    EXPECT_EQ(offsetIn("variables", "indurop_var_lock", "seq"), offsetof(indurop_var_lock, seq));
    EXPECT_EQ(offsetIn("trace", "indurop_trace_header", "head"), offsetof(indurop_trace_header, head));
    EXPECT_EQ(offsetIn("trace", "indurop_trace_channel", "type"), offsetof(indurop_trace_channel, type));
    EXPECT_EQ(offsetIn("control", "indurop_process_slot", "call"), offsetof(indurop_process_slot, call));
    EXPECT_EQ(offsetIn("control", "indurop_call_area", "result"), offsetof(indurop_call_area, result));
    EXPECT_EQ(layout()["segments"]["stats"]["structs"]["timing_record"]["size"], sizeof(irp::stats::TimingRecord));
    EXPECT_EQ(layout()["segments"]["control"]["structs"]["indurop_function_entry"]["size"],
              sizeof(indurop_function_entry));
}

// Every segment's header opens with magic, version and header_size (docs/shared-memory.md), and
// every struct's fields follow one another without gaps: what readers rely on.
TEST(ShmLayout, EverySegmentFollowsTheOneConvention) {
    for (const auto &[name, segment] : layout()["segments"].items()) {
        SCOPED_TRACE(name);
        const json &header = segment["structs"][segment["header"].get<std::string>()]["fields"];
        EXPECT_EQ(header["magic"]["offset"], 0);
        EXPECT_EQ(header["magic"]["type"], "u64");
        EXPECT_EQ(header["version"]["offset"], 8);
        EXPECT_EQ(header["version"]["type"], "u32");
        EXPECT_EQ(header["header_size"]["offset"], 12);
        EXPECT_EQ(header["header_size"]["type"], "u32");
        for (const auto &[st, desc] : segment["structs"].items()) {
            std::size_t at = 0;
            for (const auto &[field, f] : desc["fields"].items()) {
                EXPECT_EQ(f["offset"].get<std::size_t>(), at) << st << "." << field;
                at += f["size"].get<std::size_t>();
            }
            EXPECT_LT(desc["size"].get<std::size_t>() - at, desc["align"].get<std::size_t>()) << st;
        }
    }
}

// The staleness test of the agent's copy: irpd's description changed (a field added, moved,
// retyped or described otherwise) and the copy was not rewritten.
TEST(ShmLayout, TheAgentsCopyIsIrpdsDescription) {
    const std::string path = std::string(SOURCE_ROOT) + "/agent/indurop_agent/irpd/shm_layout.json";
    std::ifstream in(path);
    ASSERT_TRUE(in) << path << " is missing: run `ninja -C build shm-layout`";
    std::stringstream text;
    text << in.rdbuf();
    EXPECT_TRUE(text.str() == irp::shm::layoutJson().dump(2) + "\n")
        << path << " is stale: run `ninja -C build shm-layout` (and raise the segment's version if an old reader "
        << "would misread the new layout)";
}

}  // namespace
