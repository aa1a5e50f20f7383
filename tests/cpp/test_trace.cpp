// test_trace.cpp -- the trace rings: a real variables segment (a layout with every scalar type), the
// sampler writing rows, and a reader that maps the trace segment read-only and follows only the
// protocol of <indurop/trace.h> (as the agent does): rows in order with their seq, rows lost to
// overwriting counted exactly, a configuration switch mid-stream, a writer stuck inside a
// variable's seqlock, the `trace` command, and a reader racing the sampler that never accepts a
// torn row.
#include "trace/trace_rings.hpp"
#include "variables/layout.hpp"
#include "variables/variable_segment.hpp"

#include <indurop/shared.h>
#include <indurop/trace.h>

#include <gtest/gtest.h>

#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <optional>
#include <thread>

using namespace irp;
using nlohmann::json;
using trace::TraceRings;

namespace {

std::string uniqueInstance() {
    static std::atomic<int> n{0};
    return "trace-test-" + std::to_string(getpid()) + "-" + std::to_string(n++);
}

// ---- a layout with every scalar type, a struct, an array and 70 doubles ------------------------
struct Var {
    std::string path, type;
    uint64_t offset, size;
};

json makeLayout() {
    const std::vector<Var> scalars = {
        {"t.i8", "int8_t", 0, 1},    {"t.u8", "uint8_t", 1, 1},    {"t.i16", "int16_t", 2, 2},
        {"t.u16", "uint16_t", 4, 2}, {"t.i32", "int32_t", 8, 4},   {"t.u32", "uint32_t", 12, 4},
        {"t.i64", "int64_t", 16, 8}, {"t.u64", "uint64_t", 24, 8}, {"t.f32", "float", 32, 4},
        {"t.f64", "double", 40, 8},  {"t.b", "bool", 48, 1}};
    json variables = json::array(), leaves = json::array();
    uint32_t lock = 0;
    for (const Var &v : scalars) {
        variables.push_back(
            {{"path", v.path}, {"type", v.type}, {"offset", v.offset}, {"size", v.size}, {"lock", lock}});
        leaves.push_back({{"path", v.path}, {"type", v.type}, {"offset", v.offset}, {"size", v.size}, {"lock", lock}});
        ++lock;
    }
    variables.push_back({{"path", "t.s"}, {"type", "t.s_t"}, {"offset", 64}, {"size", 16}, {"lock", lock}});
    leaves.push_back({{"path", "t.s.x"}, {"type", "double"}, {"offset", 64}, {"size", 8}, {"lock", lock}});
    leaves.push_back({{"path", "t.s.y"}, {"type", "double"}, {"offset", 72}, {"size", 8}, {"lock", lock}});
    ++lock;
    variables.push_back({{"path", "t.arr"}, {"type", "double"}, {"offset", 128}, {"size", 24}, {"lock", lock}});
    for (int i = 0; i < 3; ++i)
        leaves.push_back({{"path", "t.arr[" + std::to_string(i) + "]"},
                          {"type", "double"},
                          {"offset", 128 + 8 * i},
                          {"size", 8},
                          {"lock", lock}});
    ++lock;
    variables.push_back({{"path", "t.many"}, {"type", "double"}, {"offset", 192}, {"size", 70 * 8}, {"lock", lock}});
    for (int i = 0; i < 70; ++i)
        leaves.push_back({{"path", "t.many[" + std::to_string(i) + "]"},
                          {"type", "double"},
                          {"offset", 192 + 8 * i},
                          {"size", 8},
                          {"lock", lock}});
    ++lock;
    const std::string long_name = "t." + std::string(240, 'l');
    variables.push_back({{"path", long_name}, {"type", "double"}, {"offset", 768}, {"size", 8}, {"lock", lock}});
    leaves.push_back({{"path", long_name}, {"type", "double"}, {"offset", 768}, {"size", 8}, {"lock", lock}});
    ++lock;
    json scalar_types = json::object();
    for (const Var &v : scalars)
        scalar_types[v.type] = {{"size", v.size},
                                {"align", v.size},
                                {"kind", v.type == "float" || v.type == "double" ? "float"
                                         : v.type == "bool"                      ? "bool"
                                         : v.type[0] == 'u'                      ? "unsigned"
                                                                                 : "signed"}};
    return {{"format", "indurop-layout"}, {"version", 1},           {"hash", std::string(64, 'c')},
            {"data_size", 832},           {"lock_count", lock},     {"scalars", scalar_types},
            {"types", json::object()},    {"variables", variables}, {"leaves", leaves}};
}

uint32_t lockOf(const json &layout, const std::string &leaf_path) {
    for (const auto &leaf : layout["leaves"])
        if (leaf["path"] == leaf_path) return leaf["lock"];
    ADD_FAILURE() << "no leaf " << leaf_path;
    return 0;
}
uint64_t offsetOf(const json &layout, const std::string &leaf_path) {
    for (const auto &leaf : layout["leaves"])
        if (leaf["path"] == leaf_path) return leaf["offset"];
    ADD_FAILURE() << "no leaf " << leaf_path;
    return 0;
}

// Writes a value as a module would: a top-level scalar with one atomic store, anything in an
// aggregate under its variable's lock (seqlock odd meanwhile).
template <class T>
void put(const json &layout, const std::string &path, T v) {
    const uint64_t offset = offsetOf(layout, path);
    const uint32_t lock = lockOf(layout, path);
    shared::ScalarRef<T>(offset, lock,
                         /*in_aggregate=*/path.find_first_of("[") != std::string::npos || path.rfind("t.s.", 0) == 0)
        .store(v);
}

// ---- a reader that knows only <indurop/trace.h> -------------------------------------------------
struct ConfigView {
    uint64_t generation = 0, first_seq = INDUROP_TRACE_NO_SEQ;
    std::vector<std::string> paths;
};
struct Row {
    uint64_t seq = 0;
    int64_t t_ns = 0;
    uint64_t generation = 0;
    std::vector<double> values;
};
struct ReadResult {
    std::vector<Row> rows;
    uint64_t lost = 0;  // rows after `since` overwritten (or of a configuration gone) before they were copied
    uint64_t next = 0;  // the seq to pass next time
};

class Reader {
public:
    explicit Reader(const std::string &name) {
        auto shm = osal::SharedMemory::open(name, false);
        EXPECT_TRUE(shm.ok()) << shm.error().message;
        shm_ = std::move(*shm);
        h_ = static_cast<const indurop_trace_header *>(shm_.data());
    }
    const indurop_trace_header *header() const { return h_; }
    uint64_t head() const { return __atomic_load_n(&h_->head, __ATOMIC_ACQUIRE); }

    // Both configurations, consistently: neither rewritten (generation 0, or changed) meanwhile.
    std::optional<std::array<ConfigView, 2>> configs() const {
        const auto *c = reinterpret_cast<const indurop_trace_config *>(base() + h_->configs_offset);
        for (int attempt = 0; attempt < 1000; ++attempt) {
            std::array<uint64_t, 2> g{}, f{};
            for (int i = 0; i < 2; ++i) {
                g[i] = __atomic_load_n(&c[i].generation, __ATOMIC_ACQUIRE);
                f[i] = __atomic_load_n(&c[i].first_seq, __ATOMIC_ACQUIRE);
            }
            if (!g[0] || !g[1]) continue;
            std::array<ConfigView, 2> out;
            for (int i = 0; i < 2; ++i) {
                out[i].generation = g[i];
                out[i].first_seq = f[i];
                const uint32_t n = std::min<uint32_t>(c[i].channel_count, INDUROP_TRACE_CHANNELS);
                for (uint32_t k = 0; k < n; ++k)
                    out[i].paths.emplace_back(c[i].channels[k].path,
                                              strnlen(c[i].channels[k].path, INDUROP_TRACE_PATH_CHARS));
            }
            std::atomic_thread_fence(std::memory_order_acquire);
            bool same = true;
            for (int i = 0; i < 2; ++i)
                same = same && __atomic_load_n(&c[i].generation, __ATOMIC_RELAXED) == g[i] &&
                       __atomic_load_n(&c[i].first_seq, __ATOMIC_RELAXED) == f[i];
            if (same) return out;
        }
        return std::nullopt;
    }

    ReadResult readSince(uint64_t since) const {
        ReadResult r;
        r.next = since;
        const uint64_t cap = h_->capacity;
        const uint64_t h1 = head();  // before the configurations: they then cover every row up to h1
        if (h1 <= since) return r;
        auto cfgs = configs();
        if (!cfgs) {
            ADD_FAILURE() << "the configurations never held still";
            return r;
        }
        const uint64_t oldest = h1 + 2 > cap ? h1 + 2 - cap : 1;
        const uint64_t from = std::max(since + 1, oldest);
        const auto *seqs = reinterpret_cast<const uint64_t *>(base() + h_->seq_offset);
        const auto *times = reinterpret_cast<const int64_t *>(base() + h_->time_offset);
        const auto *values = reinterpret_cast<const double *>(base() + h_->values_offset);
        std::vector<Row> rows;
        for (uint64_t s = from; s <= h1; ++s) {
            const uint64_t i = s & (cap - 1);
            Row row;
            row.seq = s;
            const uint64_t stored = __atomic_load_n(&seqs[i], __ATOMIC_RELAXED);  // s, unless overwritten
            row.t_ns = __atomic_load_n(&times[i], __ATOMIC_RELAXED);
            const ConfigView *in_force = nullptr;
            for (const ConfigView &c : *cfgs)
                if (c.first_seq != INDUROP_TRACE_NO_SEQ && c.first_seq <= s &&
                    (!in_force || c.first_seq > in_force->first_seq ||
                     (c.first_seq == in_force->first_seq && c.generation > in_force->generation)))
                    in_force = &c;  // the latest put in force at or before s
            if (in_force && stored == s) {
                row.generation = in_force->generation;
                for (std::size_t k = 0; k < in_force->paths.size(); ++k)
                    row.values.push_back(std::bit_cast<double>(
                        __atomic_load_n(reinterpret_cast<const uint64_t *>(&values[k * cap + i]), __ATOMIC_RELAXED)));
            }
            rows.push_back(std::move(row));
        }
        std::atomic_thread_fence(std::memory_order_acquire);
        const uint64_t h2 = __atomic_load_n(&h_->head, __ATOMIC_RELAXED);
        const uint64_t valid_from = h2 + 2 > cap ? h2 + 2 - cap : 1;
        r.lost = from - (since + 1);
        for (Row &row : rows) {
            // Overwritten while copying, or sampled with a configuration no longer in shared memory.
            if (row.seq < valid_from || row.generation == 0) {
                ++r.lost;
                continue;
            }
            r.rows.push_back(std::move(row));
        }
        r.next = h1;
        return r;
    }

private:
    const char *base() const { return static_cast<const char *>(shm_.data()); }
    osal::SharedMemory shm_;
    const indurop_trace_header *h_ = nullptr;
};

// ---- fixture: a variables segment on the test layout, adopted as irpd adopts it -----------------
class Trace : public ::testing::Test {
protected:
    void SetUp() override {
        layout_ = makeLayout();
        dir_ = std::filesystem::temp_directory_path() / uniqueInstance();
        std::filesystem::create_directories(dir_);
        std::ofstream(dir_ / "layout.json") << layout_.dump(1);
        auto layout = variables::readLayout(dir_ / "layout.json");
        ASSERT_TRUE(layout.ok()) << layout.error().message;
        auto vars = variables::VariableSegment::create(uniqueInstance(), *layout);
        ASSERT_TRUE(vars.ok()) << vars.error().message;
        vars_.emplace(std::move(*vars));
    }
    void TearDown() override {
        vars_.reset();
        std::filesystem::remove_all(dir_);
    }
    TraceRings rings(uint64_t capacity = 64) {
        auto r = TraceRings::create(uniqueInstance(), capacity);
        EXPECT_TRUE(r.ok()) << r.error().message;
        r->setBasicPeriod(1000);
        return std::move(*r);
    }

    json layout_;
    std::filesystem::path dir_;
    std::optional<variables::VariableSegment> vars_;
};

}  // namespace

TEST_F(Trace, TheSegmentIsCreatedWithItsPinnedLayout) {
    auto created = TraceRings::create(uniqueInstance());
    ASSERT_TRUE(created.ok()) << created.error().message;
    TraceRings &r = *created;
    EXPECT_EQ(r.capacity(), trace::kDefaultCapacity);
    struct stat st {};
    ASSERT_EQ(stat(("/dev/shm" + r.name()).c_str(), &st), 0);
    EXPECT_EQ(st.st_mode & 0777, 0660u);
    Reader reader(r.name());
    const indurop_trace_header *h = reader.header();
    EXPECT_EQ(h->magic, INDUROP_TRACE_MAGIC);
    EXPECT_EQ(std::string(reinterpret_cast<const char *>(&h->magic), 8), "IRPTRAC1");
    EXPECT_EQ(h->version, INDUROP_TRACE_VERSION);
    EXPECT_EQ(h->channel_max, 64u);
    EXPECT_EQ(h->owner_pid, getpid());
    EXPECT_EQ(h->head, 0u);
    for (uint64_t off : {h->configs_offset, h->seq_offset, h->time_offset, h->values_offset}) EXPECT_EQ(off % 64, 0u);
    EXPECT_EQ(h->time_offset - h->seq_offset, h->capacity * 8);
    EXPECT_EQ(h->total_size, h->values_offset + 64 * h->capacity * 8);
    EXPECT_EQ(h->total_size, static_cast<uint64_t>(st.st_size));
    // Before any configuration: buffer 0 (no channels) in force from the first row.
    auto cfgs = reader.configs();
    ASSERT_TRUE(cfgs);
    EXPECT_EQ((*cfgs)[0].first_seq, 1u);
    EXPECT_TRUE((*cfgs)[0].paths.empty());
}

TEST_F(Trace, CapacitiesThatAreNotPowersOfTwoAreRefused) {
    for (uint64_t bad : {uint64_t{0}, uint64_t{1}, uint64_t{3}, uint64_t{10000}, trace::kMaxCapacity * 2}) {
        auto r = TraceRings::create(uniqueInstance(), bad);
        ASSERT_FALSE(r.ok()) << bad;
        EXPECT_NE(r.error().message.find("power of two"), std::string::npos) << r.error().message;
    }
}

// A child process that creates `instance`'s trace rings, then pauses -- or, with exec_sleep, runs
// sleep (the same pid, another program).  Its pid once the rings exist, -1 if they could not be made.
pid_t childOwningRings(const std::string &instance, bool exec_sleep) {
    int ready[2];
    if (pipe(ready) != 0) return -1;
    pid_t child = fork();
    if (child == 0) {
        auto r = TraceRings::create(instance, 16);
        char c = r.ok() ? 'y' : 'n';
        (void)!write(ready[1], &c, 1);
        if (exec_sleep) execlp("sleep", "sleep", "30", static_cast<char *>(nullptr));
        pause();
        _exit(0);
    }
    char c = 0;
    const bool made = child > 0 && read(ready[0], &c, 1) == 1 && c == 'y';
    close(ready[0]);
    close(ready[1]);
    return made ? child : -1;
}

TEST_F(Trace, AnInstanceOfALiveIrpdIsRefusedAndADeadOnesReplaced) {
    const std::string instance = uniqueInstance();
    const pid_t child = childOwningRings(instance, false);
    ASSERT_GT(child, 0);
    auto refused = TraceRings::create(instance, 16);
    ASSERT_FALSE(refused.ok());
    EXPECT_NE(refused.error().message.find("in use by irpd pid " + std::to_string(child)), std::string::npos)
        << refused.error().message;
    kill(child, SIGKILL);  // by pid; it leaves its segment behind
    waitpid(child, nullptr, 0);
    auto replaced = TraceRings::create(instance, 16);
    ASSERT_TRUE(replaced.ok()) << replaced.error().message;
    EXPECT_EQ(replaced->header()->owner_pid, getpid());
}

// After a crash, the dead irpd's pid can go to another program: its segment is stale all the same.
TEST_F(Trace, AnInstanceWhoseOwnerPidNowRunsAnotherProgramIsReplaced) {
    const std::string instance = uniqueInstance();
    const pid_t child = childOwningRings(instance, true);
    ASSERT_GT(child, 0);
    auto comm = [&] {
        std::string name;
        std::getline(std::ifstream("/proc/" + std::to_string(child) + "/comm"), name);
        return name;
    };
    for (int i = 0; i < 500 && comm() != "sleep"; ++i) usleep(10'000);
    ASSERT_EQ(comm(), "sleep");
    auto replaced = TraceRings::create(instance, 16);
    ASSERT_TRUE(replaced.ok()) << replaced.error().message;
    EXPECT_EQ(replaced->header()->owner_pid, getpid());
    kill(child, SIGKILL);
    waitpid(child, nullptr, 0);
}

TEST_F(Trace, ConfigureNamesEveryChannelWithItsType) {
    TraceRings r = rings();
    auto answer = r.configure({"t.u32", "t.f64", "t.s.y", "t.arr[2]", "t.b"}, *vars_);
    ASSERT_TRUE(answer.ok()) << answer.error().message;
    const auto &a = *answer;
    EXPECT_EQ(a["shm"], r.name());
    EXPECT_EQ(a["capacity"], 64);
    EXPECT_EQ(a["basic_period_ns"], 1000);
    EXPECT_EQ(a["applied"], false);  // no sampler ran yet
    ASSERT_EQ(a["channels"].size(), 5u);
    EXPECT_EQ(a["channels"][0], (json{{"index", 0}, {"path", "t.u32"}, {"type", "uint32_t"}}));
    EXPECT_EQ(a["channels"][2]["path"], "t.s.y");
    EXPECT_EQ(a["channels"][4]["type"], "bool");
    EXPECT_EQ(r.describe()["channels"], a["channels"]);
    r.sample(1000);
    EXPECT_EQ(r.describe()["applied"], true);
    EXPECT_EQ(r.describe()["from_seq"], 1);
}

TEST_F(Trace, UnknownNonScalarTooManyRepeatedAndTooLongPathsAreRefusedByName) {
    TraceRings r = rings();
    auto expectError = [&](const std::vector<std::string> &paths, const std::string &words) {
        auto answer = r.configure(paths, *vars_);
        ASSERT_FALSE(answer.ok()) << words;
        EXPECT_NE(answer.error().message.find(words), std::string::npos) << answer.error().message;
    };
    expectError({"t.u32", "t.nothing"}, "no variable 't.nothing'");
    expectError({"t.s"}, "'t.s' is not a scalar");
    expectError({"t.arr"}, "'t.arr' is not a scalar");
    expectError({"t.many"}, "'t.many' is not a scalar");
    expectError({"t.f64", "t.f64"}, "'t.f64' is listed twice");
    expectError({"t." + std::string(240, 'l')}, "longer than 231 characters");
    std::vector<std::string> many;
    for (int i = 0; i < 65; ++i) many.push_back("t.many[" + std::to_string(i) + "]");
    expectError(many, "65 channels asked for; at most 64 can be traced (the first one over is 't.many[64]')");
    many.pop_back();
    EXPECT_TRUE(r.configure(many, *vars_).ok());  // exactly 64 is fine
    // A refusal leaves the configuration asked for before untouched.
    EXPECT_EQ(r.describe()["channels"].size(), 64u);
}

TEST_F(Trace, RowsAreReadBackInOrderWithTheirSeqAndDueTime) {
    TraceRings r = rings(256);
    ASSERT_TRUE(r.configure({"t.i32", "t.f64"}, *vars_).ok());
    Reader reader(r.name());
    const int64_t t0 = 5'000'000'000;
    for (int n = 1; n <= 100; ++n) {
        put<int32_t>(layout_, "t.i32", n * 3);
        put<double>(layout_, "t.f64", n / 4.0);
        r.sample(t0 + n * 1000);
    }
    EXPECT_EQ(reader.head(), 100u);
    ReadResult all = reader.readSince(0);
    EXPECT_EQ(all.lost, 0u);
    EXPECT_EQ(all.next, 100u);
    ASSERT_EQ(all.rows.size(), 100u);
    for (std::size_t k = 0; k < all.rows.size(); ++k) {
        const Row &row = all.rows[k];
        const auto n = static_cast<int64_t>(k + 1);
        EXPECT_EQ(row.seq, static_cast<uint64_t>(n));
        EXPECT_EQ(row.t_ns, t0 + n * 1000);
        ASSERT_EQ(row.values.size(), 2u);
        EXPECT_EQ(row.values[0], n * 3.0);
        EXPECT_EQ(row.values[1], n / 4.0);
    }
    ReadResult tail = reader.readSince(90);
    ASSERT_EQ(tail.rows.size(), 10u);
    EXPECT_EQ(tail.rows.front().seq, 91u);
    EXPECT_EQ(reader.readSince(100).rows.size(), 0u);
}

TEST_F(Trace, EveryScalarTypeIsSampledAsItsExactValue) {
    TraceRings r = rings();
    ASSERT_TRUE(
        r.configure({"t.i8", "t.u8", "t.i16", "t.u16", "t.i32", "t.u32", "t.i64", "t.u64", "t.f32", "t.f64", "t.b"},
                    *vars_)
            .ok());
    put<int8_t>(layout_, "t.i8", -5);
    put<uint8_t>(layout_, "t.u8", 250);
    put<int16_t>(layout_, "t.i16", -30000);
    put<uint16_t>(layout_, "t.u16", 60000);
    put<int32_t>(layout_, "t.i32", -2'000'000'000);
    put<uint32_t>(layout_, "t.u32", 4'000'000'000u);
    put<int64_t>(layout_, "t.i64", -(int64_t{1} << 40));
    put<uint64_t>(layout_, "t.u64", uint64_t{1} << 50);
    put<float>(layout_, "t.f32", 1.5f);
    put<double>(layout_, "t.f64", -2.25);
    put<bool>(layout_, "t.b", true);
    r.sample(1);
    ReadResult got = Reader(r.name()).readSince(0);
    ASSERT_EQ(got.rows.size(), 1u);
    EXPECT_EQ(got.rows[0].values, (std::vector<double>{-5, 250, -30000, 60000, -2e9, 4e9, -1099511627776.0,
                                                       1125899906842624.0, 1.5, -2.25, 1}));
}

TEST_F(Trace, RowsOverwrittenBeforeTheyWereReadAreCountedAsLost) {
    TraceRings r = rings(64);
    ASSERT_TRUE(r.configure({"t.u64"}, *vars_).ok());
    Reader reader(r.name());
    for (uint64_t n = 1; n <= 200; ++n) {
        put<uint64_t>(layout_, "t.u64", n * 7);
        r.sample(static_cast<int64_t>(n));
    }
    // 63 rows are readable (row 201 may be in the writing): 138..200; 1..137 were overwritten.
    ReadResult got = reader.readSince(0);
    EXPECT_EQ(got.lost, 137u);
    ASSERT_EQ(got.rows.size(), 63u);
    EXPECT_EQ(got.rows.front().seq, 138u);
    EXPECT_EQ(got.rows.back().seq, 200u);
    for (const Row &row : got.rows) EXPECT_EQ(row.values.at(0), static_cast<double>(row.seq * 7));
    ReadResult recent = reader.readSince(150);
    EXPECT_EQ(recent.lost, 0u);
    EXPECT_EQ(recent.rows.size(), 50u);
}

TEST_F(Trace, AConfigurationSwitchMidStreamSaysWhichChannelMeantWhatFromWhichSeq) {
    TraceRings r = rings(256);
    auto a = r.configure({"t.i32"}, *vars_);
    ASSERT_TRUE(a.ok());
    Reader reader(r.name());
    for (int n = 1; n <= 10; ++n) {
        put<int32_t>(layout_, "t.i32", n);
        put<double>(layout_, "t.f64", n + 0.5);
        r.sample(n);
    }
    const uint64_t generation_a = reader.header()->config_generation;
    EXPECT_EQ(generation_a, (*a)["generation"].get<uint64_t>());
    // Asked for between periods 10 and 11: in force from row 11 on.  One asked for and replaced
    // before the sampler saw it is never in force.
    ASSERT_TRUE(r.configure({"t.u8"}, *vars_).ok());
    auto b = r.configure({"t.f64", "t.i32"}, *vars_);
    ASSERT_TRUE(b.ok());
    EXPECT_EQ((*b)["applied"], false);
    for (int n = 11; n <= 20; ++n) {
        put<int32_t>(layout_, "t.i32", n);
        put<double>(layout_, "t.f64", n + 0.5);
        r.sample(n);
    }
    const indurop_trace_header *h = reader.header();
    EXPECT_EQ(h->config_seq, 11u);
    EXPECT_EQ(h->config_generation, (*b)["generation"].get<uint64_t>());
    EXPECT_GT(h->config_generation, generation_a);
    EXPECT_EQ(r.describe()["from_seq"], 11);

    ReadResult got = reader.readSince(0);
    EXPECT_EQ(got.lost, 0u);
    ASSERT_EQ(got.rows.size(), 20u);
    for (const Row &row : got.rows) {
        const auto n = static_cast<double>(row.seq);
        if (row.seq <= 10) {
            EXPECT_EQ(row.generation, generation_a);
            EXPECT_EQ(row.values, (std::vector<double>{n}));
        } else {
            EXPECT_EQ(row.generation, h->config_generation);
            EXPECT_EQ(row.values, (std::vector<double>{n + 0.5, n}));
        }
    }
    auto cfgs = reader.configs();
    ASSERT_TRUE(cfgs);
    EXPECT_EQ((*cfgs)[h->active_config].paths, (std::vector<std::string>{"t.f64", "t.i32"}));

    // A third configuration rewrites the buffer of the first: rows 1..10 can no longer be told
    // apart, and a reader counts them as lost instead of misreading them.
    ASSERT_TRUE(r.configure({"t.b"}, *vars_).ok());
    r.sample(21);
    ReadResult later = reader.readSince(0);
    EXPECT_EQ(later.lost, 10u);
    ASSERT_EQ(later.rows.size(), 11u);
    EXPECT_EQ(later.rows.front().seq, 11u);
    EXPECT_EQ(later.rows.back().values.size(), 1u);
}

TEST_F(Trace, AWriterInsideTheSeqlockMakesTheSamplerTakeThePreviousValue) {
    TraceRings r = rings();
    ASSERT_TRUE(r.configure({"t.s.x", "t.u16"}, *vars_).ok());
    const uint32_t lock = lockOf(layout_, "t.s.x");
    std::atomic_ref<uint32_t> seq(indurop_shared_locks[lock].seq);
    auto *x = reinterpret_cast<double *>(indurop_shared_data + offsetOf(layout_, "t.s.x"));

    // A writer stalled inside from the start: no value was ever read, so NaN.
    seq.store(seq.load() + 1);
    r.sample(1);
    seq.store(seq.load() + 1);
    put<double>(layout_, "t.s.x", 7.0);
    put<uint16_t>(layout_, "t.u16", 3);
    r.sample(2);
    // Stalled again, half way through a write of 8.0.
    seq.store(seq.load() + 1);
    std::atomic_ref<double>(*x).store(8.0);
    r.sample(3);
    EXPECT_EQ(r.header()->torn_skips, 2u);
    EXPECT_EQ(r.describe()["torn_skips"], 2);
    seq.store(seq.load() + 1);  // the writer leaves
    r.sample(4);

    ReadResult got = Reader(r.name()).readSince(0);
    ASSERT_EQ(got.rows.size(), 4u);
    EXPECT_TRUE(std::isnan(got.rows[0].values[0]));
    EXPECT_EQ(got.rows[1].values, (std::vector<double>{7.0, 3}));
    EXPECT_EQ(got.rows[2].values, (std::vector<double>{7.0, 3}));  // the previous value; the other channel unaffected
    EXPECT_EQ(got.rows[3].values, (std::vector<double>{8.0, 3}));
    EXPECT_EQ(r.header()->torn_skips, 2u);
}

TEST_F(Trace, AReaderRacingTheSamplerNeverAcceptsATornRow) {
    // 64 channels, a small ring that the sampler laps many times while a reader thread copies:
    // every row's values are tied to its seq, so a row mixing two periods would show.
    TraceRings r = rings(128);
    std::vector<std::string> paths;
    for (int i = 0; i < 64; ++i) paths.push_back("t.many[" + std::to_string(i) + "]");
    ASSERT_TRUE(r.configure(paths, *vars_).ok());
    const uint32_t lock = lockOf(layout_, "t.many[0]");
    auto *many = reinterpret_cast<double *>(indurop_shared_data + offsetOf(layout_, "t.many[0]"));
    constexpr uint64_t kRows = 300'000;
    const int64_t t0 = 1'000'000;
    std::atomic<bool> done{false};
    uint64_t verified = 0, lost = 0, bad = 0, next = 0;

    std::thread reader_thread([&] {
        Reader reader(r.name());
        auto check = [&](const ReadResult &got) {
            lost += got.lost;
            uint64_t expect = next + 1 + got.lost;
            for (const Row &row : got.rows) {
                bool ok = row.seq == expect && row.t_ns == t0 + static_cast<int64_t>(row.seq) * 100 &&
                          row.values.size() == 64;
                for (std::size_t k = 0; ok && k < row.values.size(); ++k)
                    ok = row.values[k] == static_cast<double>(row.seq * 64 + k);
                if (!ok) ++bad;
                ++verified;
                ++expect;
            }
            next = got.next;
        };
        while (!done.load()) check(reader.readSince(next));
        check(reader.readSince(next));
    });
    for (uint64_t s = 1; s <= kRows; ++s) {
        shared::detail::writeExclusive(lock, [&] {
            for (uint64_t k = 0; k < 64; ++k)
                std::atomic_ref<double>(many[k]).store(static_cast<double>(s * 64 + k), std::memory_order_relaxed);
        });
        r.sample(t0 + static_cast<int64_t>(s) * 100);
    }
    done.store(true);
    reader_thread.join();
    EXPECT_EQ(bad, 0u) << "rows read intact " << verified << ", lost " << lost;
    EXPECT_GT(verified, 0u);
    EXPECT_EQ(verified + lost, kRows);  // every row either read intact or reported lost
    EXPECT_EQ(next, kRows);
    EXPECT_EQ(r.header()->torn_skips, 0u);
}

TEST_F(Trace, TheTraceCommandDescribesConfiguresAndRefuses) {
    TraceRings r = rings();
    auto described = trace::handleTraceCommand(r, &*vars_, json{{"cmd", "trace"}});
    ASSERT_TRUE(described.ok());
    EXPECT_EQ((*described)["channels"], json::array());
    EXPECT_EQ((*described)["shm"], r.name());

    // With a sampler running, the answer comes once the channels are in force.
    std::atomic<bool> stop{false};
    std::thread sampler([&] {
        for (int64_t n = 1; !stop.load(); ++n) {
            r.sample(n);
            std::this_thread::sleep_for(std::chrono::microseconds(100));
        }
    });
    auto configured = trace::handleTraceCommand(r, &*vars_, json{{"cmd", "trace"}, {"channels", {"t.i16", "t.s.x"}}});
    ASSERT_TRUE(configured.ok()) << configured.error().message;
    EXPECT_EQ((*configured)["applied"], true);
    EXPECT_TRUE((*configured)["from_seq"].is_number());
    EXPECT_EQ((*configured)["channels"][1], (json{{"index", 1}, {"path", "t.s.x"}, {"type", "double"}}));
    auto cleared = trace::handleTraceCommand(r, &*vars_, json{{"channels", json::array()}});
    ASSERT_TRUE(cleared.ok());
    EXPECT_EQ((*cleared)["channels"], json::array());
    stop.store(true);
    sampler.join();

    auto error = [&](const json &request, const variables::VariableSegment *vars, const std::string &words) {
        auto answer = trace::handleTraceCommand(r, vars, request);
        ASSERT_FALSE(answer.ok()) << request.dump();
        EXPECT_NE(answer.error().message.find(words), std::string::npos) << answer.error().message;
    };
    error(json{{"channels", "t.i16"}}, &*vars_, "\"channels\" must be a list");
    error(json{{"channels", {"t.i16", 3}}}, &*vars_, "\"channels\"[1] is 3, not a variable path");
    error(json{{"channels", {"t.zz"}}}, &*vars_, "no variable 't.zz'");
    error(json{{"channels", {"t.i16"}}}, nullptr, "no shared variables");
    EXPECT_TRUE(trace::handleTraceCommand(r, nullptr, json{{"channels", json::array()}}).ok());
}

TEST_F(Trace, TwoOwnersAreTracedAsTheUnionAndEachWithdrawsOnlyItsOwn) {
    TraceRings r = rings();
    auto paths = [](const json &answer) {
        std::vector<std::string> out;
        for (const auto &c : answer["channels"]) out.push_back(c["path"].get<std::string>());
        return out;
    };
    auto agent = r.configureFor("agent", {"t.i16", "t.s.x"}, &*vars_);
    ASSERT_TRUE(agent.ok()) << agent.error().message;
    auto dds = r.configureFor("dds", {"t.s.x", "t.f64"}, &*vars_);
    ASSERT_TRUE(dds.ok()) << dds.error().message;
    EXPECT_EQ(paths(*dds), (std::vector<std::string>{"t.i16", "t.s.x", "t.f64"}));  // shared once, in place
    EXPECT_EQ((*dds)["owners"]["dds"], (json{"t.s.x", "t.f64"}));
    EXPECT_EQ((*dds)["owners"]["agent"], (json{"t.i16", "t.s.x"}));

    // The agent asks anew: the bridge's channels stay, the agent's order does not move them.
    auto again = r.configureFor("agent", {"t.u32", "t.i16"}, &*vars_);
    ASSERT_TRUE(again.ok()) << again.error().message;
    EXPECT_EQ(paths(*again), (std::vector<std::string>{"t.i16", "t.s.x", "t.f64", "t.u32"}));

    // A refusal (a path of its own unknown, or the union over 64) changes nobody's request.
    auto bad = r.configureFor("dds", {"t.f64", "t.nothing"}, &*vars_);
    ASSERT_FALSE(bad.ok());
    EXPECT_NE(bad.error().message.find("no variable 't.nothing'"), std::string::npos) << bad.error().message;
    std::vector<std::string> many;
    for (int i = 0; i < 63; ++i) many.push_back("t.many[" + std::to_string(i) + "]");
    auto over = r.configureFor("dds", many, &*vars_);
    ASSERT_FALSE(over.ok());
    EXPECT_NE(over.error().message.find("'dds' asks for 63 channels; with every owner's (agent: 2, dds: 63) 65"),
              std::string::npos)
        << over.error().message;
    EXPECT_EQ(paths(r.describe()), (std::vector<std::string>{"t.i16", "t.s.x", "t.f64", "t.u32"}));
    auto twice = r.configureFor("dds", {"t.f64", "t.f64"}, &*vars_);
    ASSERT_FALSE(twice.ok());
    EXPECT_NE(twice.error().message.find("'t.f64' is listed twice"), std::string::npos);

    // The bridge withdraws: only the agent's channels stay.
    auto gone = r.configureFor("dds", {}, &*vars_);
    ASSERT_TRUE(gone.ok());
    EXPECT_EQ(paths(*gone), (std::vector<std::string>{"t.i16", "t.u32"}));
    EXPECT_FALSE((*gone)["owners"].contains("dds"));

    // Through the command: "owner" names who asks, and without it the request is the agent's.
    auto byCommand = trace::handleTraceCommand(r, &*vars_, json{{"channels", {"t.b"}}, {"owner", "dds"}});
    ASSERT_TRUE(byCommand.ok());
    EXPECT_EQ((*byCommand)["owners"]["dds"], (json{"t.b"}));
    auto legacy = trace::handleTraceCommand(r, &*vars_, json{{"channels", json::array()}});
    ASSERT_TRUE(legacy.ok());
    EXPECT_EQ(paths(*legacy), (std::vector<std::string>{"t.b"}));
}
