// test_thread_module.cpp -- the thread-module loader and lifecycle, with real .so fixtures that
// behave well and ones that fail on purpose (tests/cpp/modules/).
#include "hosts/module_set.hpp"

#include <indurop/property.h>
#include "hosts/thread_module.hpp"
#include "journal.hpp"

#include <indurop/functions.h>

#include <gtest/gtest.h>

#include <string>

using namespace irp;

namespace {

config::ModuleSpec fixture(const std::string &file, std::vector<std::pair<std::string, std::string>> props = {}) {
    config::ModuleSpec m;
    m.filename = "./" + file;
    m.path = std::string(FIXTURE_MODULES) + "/" + file;
    m.name = std::filesystem::path(file).stem().string();
    m.where = "sets/test/module.xml:7";
    m.line = 7;
    m.period_ns = 100'000;
    m.priority = 1;
    m.properties = std::move(props);
    return m;
}

std::string loadError(const std::string &file) {
    auto m = hosts::ThreadModule::load(fixture(file));
    return m.ok() ? std::string("(loaded)") : m.error().message;
}

// Loads, initializes and starts; returns the first error, or "".
std::string lifecycleError(const config::ModuleSpec &spec) {
    auto m = hosts::ThreadModule::load(spec);
    if (!m) return m.error().message;
    if (Status s = (*m)->initialize(); !s) return s.error().message;
    if (Status s = (*m)->start(); !s) return s.error().message;
    (void)(*m)->stop();
    return "";
}

}  // namespace

TEST(ThreadModuleLoad, PlainStyleModule) {
    auto m = hosts::ThreadModule::load(fixture("rec_a.so"));
    ASSERT_TRUE(m.ok()) << m.error().message;
    EXPECT_FALSE((*m)->usesDescriptor());
    EXPECT_NE((*m)->runFunction(), nullptr);
    EXPECT_EQ((*m)->name(), "rec_a");
}

TEST(ThreadModuleLoad, DescriptorModuleCarriesItsMetadata) {
    auto m = hosts::ThreadModule::load(fixture("desc_a.so"));
    ASSERT_TRUE(m.ok()) << m.error().message;
    EXPECT_TRUE((*m)->usesDescriptor());
    EXPECT_STREQ((*m)->table().name, "desc_a");
    EXPECT_STREQ((*m)->table().description, "journals its calls");
    EXPECT_EQ((*m)->table().abi_version, INDUROP_MODULE_ABI_VERSION);
}

TEST(ThreadModuleLoad, MissingFileNamesTheFileAndTheXmlLine) {
    std::string e = loadError("does_not_exist.so");
    EXPECT_NE(e.find("sets/test/module.xml:7"), std::string::npos) << e;
    EXPECT_NE(e.find("module 'does_not_exist'"), std::string::npos) << e;
    EXPECT_NE(e.find("does not exist"), std::string::npos) << e;
}

TEST(ThreadModuleLoad, PlainModuleWithoutRunIsRefused) {
    std::string e = loadError("no_run_plain.so");
    EXPECT_NE(e.find("module 'no_run_plain'"), std::string::npos) << e;
    EXPECT_NE(e.find("run()"), std::string::npos) << e;
    EXPECT_NE(e.find("undefined symbol: run"), std::string::npos) << e;  // the loader's own words
}

TEST(ThreadModuleLoad, DescriptorWithoutRunIsRefused) {
    std::string e = loadError("no_run_descriptor.so");
    EXPECT_NE(e.find("module 'no_run_descriptor'"), std::string::npos) << e;
    EXPECT_NE(e.find("sets no run"), std::string::npos) << e;
}

TEST(ThreadModuleLoad, UnresolvedSymbolIsRefusedWithTheLoadersMessage) {
    std::string e = loadError("unresolved.so");
    EXPECT_NE(e.find("module 'unresolved'"), std::string::npos) << e;
    EXPECT_NE(e.find("undefined symbol: indurop_fixture_symbol_that_does_not_exist"), std::string::npos) << e;
}

TEST(ThreadModuleLoad, NotAnElfFileIsRefused) {
    std::string e = loadError("not_elf.so");
    EXPECT_NE(e.find("module 'not_elf'"), std::string::npos) << e;
    EXPECT_NE(e.find("cannot load"), std::string::npos) << e;
}

TEST(ThreadModuleLoad, AnotherAbiVersionIsRefused) {
    std::string e = loadError("abi_mismatch.so");
    EXPECT_NE(e.find("module ABI version 99"), std::string::npos) << e;
    EXPECT_NE(e.find("rebuild"), std::string::npos) << e;
}

TEST(ThreadModuleLifecycle, InitializeThrowingRefusesWithItsMessage) {
    std::string e = lifecycleError(fixture("init_throws.so"));
    EXPECT_NE(e.find("module 'init_throws': initialize() failed: calibration table missing"), std::string::npos) << e;
}

TEST(ThreadModuleLifecycle, InitializeReturningFalseRefuses) {
    std::string e = lifecycleError(fixture("init_false.so"));
    EXPECT_NE(e.find("initialize() reported failure"), std::string::npos) << e;
}

TEST(ThreadModuleLifecycle, BadPropertyValueNamesTheProperty) {
    std::string e = lifecycleError(fixture("bad_property.so", {{"gain", "fast"}}));
    EXPECT_NE(e.find("property 'gain': expected an integer, got 'fast'"), std::string::npos) << e;
    EXPECT_EQ(lifecycleError(fixture("bad_property.so", {{"gain", "12"}})), "");
}

TEST(ThreadModuleLifecycle, StartThrowingRefusesWithItsMessage) {
    std::string e = lifecycleError(fixture("start_throws.so"));
    EXPECT_NE(e.find("module 'start_throws': start() failed: drive not ready"), std::string::npos) << e;
}

TEST(ThreadModuleLifecycle, PropertiesReachInitializeAndCallsComeInOrder) {
    journal::clear();
    for (const char *file : {"rec_b.so", "desc_b.so"}) {
        auto m = hosts::ThreadModule::load(fixture(file, {{"busy_ns", "0"}}));
        ASSERT_TRUE(m.ok()) << m.error().message;
        ASSERT_TRUE((*m)->initialize().ok());
        ASSERT_TRUE((*m)->start().ok());
        (*m)->runFunction()();
        (*m)->runFunction()();
        ASSERT_TRUE((*m)->stop().ok());
        ASSERT_TRUE((*m)->stop().ok());  // a second stop() does not call the module again
    }
    std::vector<std::string> calls;
    for (const auto &e : journal::entries()) calls.push_back(e.who + ":" + e.what);
    EXPECT_EQ(calls, (std::vector<std::string>{"rec_b:initialize", "rec_b:start", "rec_b:run", "rec_b:run",
                                               "rec_b:stop", "desc_b:initialize", "desc_b:start", "desc_b:run",
                                               "desc_b:run", "desc_b:stop"}));
}

TEST(ThreadModuleLifecycle, StopIsNotCalledWithoutStart) {
    journal::clear();
    auto m = hosts::ThreadModule::load(fixture("rec_c.so"));
    ASSERT_TRUE(m.ok());
    ASSERT_TRUE((*m)->initialize().ok());
    ASSERT_TRUE((*m)->stop().ok());
    ASSERT_EQ(journal::entries().size(), 1u);
    EXPECT_EQ(journal::entries()[0].what, "initialize");
}

TEST(ModuleSet, AFailedStartStopsTheModulesAlreadyStartedInReverse) {
    journal::clear();
    config::SetSpec set;
    set.modules = {fixture("rec_a.so"), fixture("rec_b.so"), fixture("start_throws.so"), fixture("rec_c.so")};
    for (int i = 0; i < 4; ++i) set.modules[static_cast<std::size_t>(i)].index = i;
    auto loaded = hosts::ModuleSet::load(set);
    ASSERT_TRUE(loaded.ok()) << loaded.error().message;
    ASSERT_TRUE((*loaded)->initializeAll().ok());
    Status s = (*loaded)->startAll();
    ASSERT_FALSE(s.ok());
    EXPECT_NE(s.error().message.find("drive not ready"), std::string::npos);
    std::vector<std::string> calls;
    for (const auto &e : journal::entries())
        if (e.what != "initialize") calls.push_back(e.who + ":" + e.what);
    EXPECT_EQ(calls, (std::vector<std::string>{"rec_a:start", "rec_b:start", "rec_b:stop", "rec_a:stop"}));
    EXPECT_TRUE((*loaded)->stopAll().empty());                // nothing is stopped twice
    EXPECT_EQ(journal::entries().size(), 3u + calls.size());  // 3 initialize (start_throws has none)
}

TEST(ModuleSet, OneBadModuleRefusesTheWholeSet) {
    config::SetSpec set;
    set.modules = {fixture("rec_a.so"), fixture("unresolved.so")};
    set.modules[1].index = 1;
    auto loaded = hosts::ModuleSet::load(set);
    ASSERT_FALSE(loaded.ok());
    EXPECT_NE(loaded.error().message.find("module 'unresolved'"), std::string::npos);
}

TEST(ModuleSet, ProcessModulesAreLeftToTheSupervisor) {
    config::SetSpec set;
    set.modules = {fixture("rec_a.so"), fixture("whatever.exe")};
    set.modules[1].index = 1;
    set.modules[1].type = config::ModuleType::Process;
    auto loaded = hosts::ModuleSet::load(set);
    ASSERT_TRUE(loaded.ok()) << loaded.error().message;
    EXPECT_NE((*loaded)->module(0), nullptr);
    EXPECT_EQ((*loaded)->module(1), nullptr);  // not loaded, not refused (its file is not even looked at)
}

TEST(ModuleSet, ASporadicThreadModuleNeedsCondition) {
    config::SetSpec set;
    set.modules = {fixture("rec_a.so")};
    set.modules[0].operation = config::OperationType::Sporadic;
    set.modules[0].deadline_ns = 100'000;
    auto loaded = hosts::ModuleSet::load(set);
    ASSERT_FALSE(loaded.ok());
    EXPECT_NE(loaded.error().message.find(
                  "sets/test/module.xml:7: module 'rec_a': a sporadic thread module needs condition()"),
              std::string::npos)
        << loaded.error().message;
    set.modules = {fixture("event_handler.so")};
    set.modules[0].operation = config::OperationType::Sporadic;
    EXPECT_TRUE(hosts::ModuleSet::load(set).ok());
}

TEST(ModuleSet, ANonRealThreadModuleIsRefusedWithTheFix) {
    config::SetSpec set;
    set.modules = {fixture("rec_a.so")};
    set.modules[0].operation = config::OperationType::NonReal;
    auto loaded = hosts::ModuleSet::load(set);
    ASSERT_FALSE(loaded.ok());
    EXPECT_NE(loaded.error().message.find("set <moduletype>process</moduletype>"), std::string::npos);
}

namespace {
config::SetSpec setOf(std::initializer_list<const char *> files) {
    config::SetSpec set;
    int i = 0;
    for (const char *f : files) {
        set.modules.push_back(fixture(f));
        set.modules.back().index = i++;
    }
    return set;
}
}  // namespace

TEST(SharedFunctions, AThreadModuleCallsAnotherModulesFunctionDirectly) {
    journal::clear();
    auto loaded = hosts::ModuleSet::load(setOf({"fn_import.so", "fn_export.so"}));  // the user first in the file
    ASSERT_TRUE(loaded.ok()) << loaded.error().message;
    ASSERT_TRUE((*loaded)->initializeAll().ok());
    Status started = (*loaded)->startAll();
    ASSERT_TRUE(started.ok()) << started.error().message;
    (*loaded)->module(0)->runFunction()();
    ASSERT_EQ(journal::entries().size(), 1u);
    EXPECT_EQ(journal::entries()[0].what, "10");  // scale(4.0) = 10
    (*loaded)->stopAll();
}

TEST(SharedFunctions, AnotherSignatureRefusesTheSetNamingBoth) {
    auto loaded = hosts::ModuleSet::load(setOf({"fn_export.so", "fn_wrong_sig.so"}));
    ASSERT_TRUE(loaded.ok());
    ASSERT_TRUE((*loaded)->initializeAll().ok());
    Status started = (*loaded)->startAll();
    ASSERT_FALSE(started.ok());
    EXPECT_NE(started.error().message.find("module 'fn_wrong_sig': start() failed: shared function 'math.scale' of "
                                           "module 'fn_export' is double (double), not int (int)"),
              std::string::npos)
        << started.error().message;
}

TEST(SharedFunctions, AnUnknownNameRefusesTheSet) {
    auto loaded = hosts::ModuleSet::load(setOf({"fn_missing.so"}));
    ASSERT_TRUE(loaded.ok());
    ASSERT_TRUE((*loaded)->initializeAll().ok());
    Status started = (*loaded)->startAll();
    ASSERT_FALSE(started.ok());
    EXPECT_NE(started.error().message.find("no module exports a shared function 'nobody.exports.this'"),
              std::string::npos);
}

TEST(SharedFunctions, ExportsGoWithTheirModule) {
    {
        auto loaded = hosts::ModuleSet::load(setOf({"fn_export.so"}));
        ASSERT_TRUE(loaded.ok());
        ASSERT_TRUE((*loaded)->initializeAll().ok());
        EXPECT_NO_THROW(irp::findFunction<double(double)>("math.scale"));
        // A new instance of the same module (a hot reload's replacement) exports the name again and
        // is the one found until it goes; another module exporting that name is refused.
        {
            auto again = hosts::ModuleSet::load(setOf({"fn_export.so"}));
            ASSERT_TRUE(again.ok());
            EXPECT_TRUE((*again)->initializeAll().ok());
        }
        EXPECT_NO_THROW(irp::findFunction<double(double)>("math.scale"));  // the replacement gone: the first's
    }
    EXPECT_THROW(irp::findFunction<double(double)>("math.scale"), irp::FunctionError);  // unloaded: gone
}

TEST(Property, PathResolvesRelativeNamesAgainstTheSetFolder) {
    std::vector<indurop_property_entry> entries = {
        {"config", "ioconfig.xml"}, {"abs", "/etc/x.xml"}, {"indurop.set_dir", "/srv/sets/cell"}};
    indurop_property_list list{entries.data(), entries.size()};
    irp::Property p(&list);
    EXPECT_EQ(p.path("config"), "/srv/sets/cell/ioconfig.xml");
    EXPECT_EQ(p.path("abs"), "/etc/x.xml");
    EXPECT_EQ(p.path("missing", "robot.urdf"), "/srv/sets/cell/robot.urdf");
    EXPECT_EQ(p.path("missing"), "");
}
