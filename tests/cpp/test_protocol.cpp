// test_protocol.cpp -- the control protocol's description (protocol/control.json, through the
// generated protocol/command_table.hpp and limits.hpp) as irpd applies it: every command decodes
// with the arguments the table says, every argument is refused outside its type and range (one
// case per edge), and module.xml and the scheduler hold the same limits at their edges.
#include "config/module_xml.hpp"
#include "irpd/commands.hpp"
#include "protocol/arguments.hpp"
#include "protocol/command_table.hpp"
#include "schedule/schedule.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <set>
#include <string>

namespace {

using json = nlohmann::json;
using irp::daemon::decodeCommand;
namespace protocol = irp::protocol;

// A value the table accepts for `arg`: the smallest allowed.
json validValue(const protocol::Arg &arg) {
    switch (arg.type) {
    case protocol::ArgType::String: return std::string(static_cast<std::size_t>(arg.has_min ? arg.min : 0), 'm');
    case protocol::ArgType::Integer: return arg.has_min ? arg.min : 0;
    case protocol::ArgType::Boolean: return true;
    case protocol::ArgType::Scalar: return 1.5;
    case protocol::ArgType::StringList: return json::array({validValue(arg.members[0])});
    case protocol::ArgType::ObjectList: {
        json entry = json::object();
        bool one = false;
        for (std::size_t i = 0; i < arg.member_count; ++i) {
            const protocol::Arg &m = arg.members[i];
            if (m.required || (m.one_of && !one)) entry[m.name] = validValue(m);
            one |= m.one_of;
        }
        return json::array({entry});
    }
    }
    return nullptr;
}

// The request with every required argument of `command` given a valid value.
json minimalRequest(const protocol::Command &command) {
    json request = {{"cmd", command.name}};
    for (std::size_t i = 0; i < command.arg_count; ++i)
        if (command.args[i].required) request[command.args[i].name] = validValue(command.args[i]);
    return request;
}

::testing::AssertionResult refused(const json &request, const std::string &piece) {
    auto decoded = decodeCommand(request.value("cmd", ""), request);
    if (decoded) return ::testing::AssertionFailure() << "accepted: " << request.dump();
    if (decoded.error().code != protocol::kRefused)
        return ::testing::AssertionFailure() << "code " << decoded.error().code << ": " << request.dump();
    if (decoded.error().message.find(piece) == std::string::npos)
        return ::testing::AssertionFailure() << "'" << decoded.error().message << "' lacks '" << piece << "'";
    return ::testing::AssertionSuccess();
}

::testing::AssertionResult accepted(const json &request) {
    auto decoded = decodeCommand(request.value("cmd", ""), request);
    if (!decoded) return ::testing::AssertionFailure() << decoded.error().message << ": " << request.dump();
    return ::testing::AssertionSuccess();
}

json setPriority(int64_t priority) { return {{"cmd", "set_priority"}, {"module", "cntr1"}, {"priority", priority}}; }

json changes(std::size_t count, const json &entry_values) {
    json list = json::array();
    for (std::size_t i = 0; i < count; ++i) {
        json entry = entry_values;
        entry["module"] = "m" + std::to_string(i);
        list.push_back(entry);
    }
    return {{"cmd", "change"}, {"changes", list}};
}

std::string periodic(const std::string &name, int64_t period_ns, int64_t priority) {
    return "  <module><filename>./" + name +
           ".so</filename><moduletype>thread</moduletype>"
           "<operationtype>periodic</operationtype><period>" +
           std::to_string(period_ns) + "</period><priority>" + std::to_string(priority) + "</priority></module>\n";
}

irp::Result<irp::config::SetSpec> parsed(const std::string &modules) {
    return irp::config::parseModuleXmlText("<?xml version=\"1.0\"?>\n<root>\n" + modules + "</root>\n",
                                           "/sets/test/module.xml");
}

}  // namespace

TEST(ProtocolTable, EveryCommandDecodesWithTheArgumentsItsTableRequires) {
    std::set<std::string> names;
    for (const protocol::Command &command : protocol::kCommands) {
        names.insert(command.name);
        const json request = minimalRequest(command);
        auto decoded = decodeCommand(command.name, request);
        ASSERT_TRUE(decoded.ok()) << command.name << ": " << decoded.error().message;
        EXPECT_EQ(decoded->kind, command.cmd) << command.name;
        for (std::size_t i = 0; i < command.arg_count; ++i) {
            if (!command.args[i].required) continue;
            json without = request;
            without.erase(command.args[i].name);
            EXPECT_TRUE(refused(without, std::string("'") + command.args[i].name + "' is required")) << command.name;
        }
    }
    EXPECT_EQ(names.size(), protocol::kCommandCount) << "a command is in the table twice";
}

TEST(ProtocolTable, AnUnknownCommandIsRefusedListingEveryCommand) {
    auto decoded = decodeCommand("reboot", json{{"cmd", "reboot"}});
    ASSERT_FALSE(decoded.ok());
    EXPECT_EQ(decoded.error().code, protocol::kRefused);
    for (const protocol::Command &command : protocol::kCommands)
        EXPECT_NE(decoded.error().message.find(command.name), std::string::npos) << command.name;
}

TEST(ProtocolTable, ArgumentsOfTheWrongTypeAreRefusedNamingTheArgument) {
    EXPECT_TRUE(refused({{"cmd", "load"}, {"config", 7}}, "'config' must be a non-empty string"));
    EXPECT_TRUE(refused({{"cmd", "load"}, {"config", ""}}, "'config' must be a non-empty string"));
    EXPECT_TRUE(refused({{"cmd", "load"}, {"config", "a.xml"}, {"set_id", 3}}, "'set_id' must be a string"));
    EXPECT_TRUE(refused({{"cmd", "set_period"}, {"module", "cntr1"}, {"period_ns", 1.5}}, "'period_ns' must be"));
    EXPECT_TRUE(refused({{"cmd", "write"}, {"path", "x"}, {"value", "1"}}, "'value' must be a number or a boolean"));
    EXPECT_TRUE(
        refused({{"cmd", "write"}, {"path", "x"}, {"value", nullptr}}, "'value' must be a number or a boolean"));
    EXPECT_TRUE(refused({{"cmd", "trace"}, {"channels", "x"}}, "'channels' must be a list"));
    EXPECT_TRUE(refused({{"cmd", "trace"}, {"channels", {"x", 3}}}, "channels[1] must be a non-empty string"));
    EXPECT_TRUE(refused({{"cmd", "change"}, {"changes", {{{"module", "a"}, {"priority", 1}}}}, {"dry_run", "yes"}},
                        "'dry_run' must be true or false"));
    EXPECT_TRUE(refused({{"cmd", "change"}, {"changes", {"a"}}}, "changes[0] must be an object {module, "));
    EXPECT_TRUE(refused({{"cmd", "change"}, {"changes", {{{"module", "a"}, {"period", 5}}}}},
                        "changes[0]: unknown member 'period'; the members are module, period_ns, priority, enabled"));
    EXPECT_TRUE(refused({{"cmd", "change"}, {"changes", {{{"module", "a"}}}}},
                        "changes[0] (module 'a') changes nothing; give period_ns, priority or enabled"));
    EXPECT_TRUE(refused({{"cmd", "change"}, {"changes", {{{"priority", 1}}}}}, "changes[0]: 'module' is required"));
    EXPECT_TRUE(accepted({{"cmd", "trace"}, {"channels", json::array()}}));
    EXPECT_TRUE(accepted({{"cmd", "write"}, {"path", "x"}, {"value", false}}));
}

TEST(ProtocolLimits, PriorityIsAcceptedFromItsMinimumToItsMaximumAndRefusedOutside) {
    EXPECT_TRUE(refused(setPriority(protocol::kPriorityMin - 1), "'priority' must be an integer from 0 to 1000000"));
    EXPECT_TRUE(accepted(setPriority(protocol::kPriorityMin)));
    EXPECT_TRUE(accepted(setPriority(protocol::kPriorityMax)));
    EXPECT_TRUE(refused(setPriority(protocol::kPriorityMax + 1), "'priority' must be an integer from 0 to 1000000"));
    EXPECT_TRUE(refused(changes(1, {{"priority", protocol::kPriorityMin - 1}}), "changes[0]: 'priority' must be"));
    EXPECT_TRUE(accepted(changes(1, {{"priority", protocol::kPriorityMax}})));
    EXPECT_TRUE(refused(changes(1, {{"priority", protocol::kPriorityMax + 1}}), "changes[0]: 'priority' must be"));
    auto decoded = decodeCommand("set_priority", setPriority(protocol::kPriorityMax));
    ASSERT_TRUE(decoded.ok());
    EXPECT_EQ(decoded->changes.at(0).priority, protocol::kPriorityMax);
}

TEST(ProtocolLimits, AChangeListHoldsUpToItsLimit) {
    const json values = {{"enabled", true}};
    auto full = decodeCommand("change", changes(static_cast<std::size_t>(protocol::kMaxChanges), values));
    ASSERT_TRUE(full.ok()) << full.error().message;
    EXPECT_EQ(full->changes.size(), static_cast<std::size_t>(protocol::kMaxChanges));
    EXPECT_TRUE(refused(changes(static_cast<std::size_t>(protocol::kMaxChanges) + 1, values),
                        "'changes' holds more than 1024 entries"));
    EXPECT_TRUE(refused(changes(0, values), "'changes' must be a non-empty list"));
}

TEST(ProtocolLimits, PeriodModuleNameAndEventLimitAtTheirEdges) {
    json period = {{"cmd", "set_period"}, {"module", "cntr1"}, {"period_ns", 0}};
    EXPECT_TRUE(refused(period, "'period_ns' must be a positive integer"));
    period["period_ns"] = 1;
    EXPECT_TRUE(accepted(period));
    const auto longest = static_cast<std::size_t>(protocol::kMaxNameLength);
    EXPECT_TRUE(accepted({{"cmd", "enable"}, {"module", std::string(longest, 'n')}}));
    EXPECT_TRUE(refused({{"cmd", "enable"}, {"module", std::string(longest + 1, 'n')}},
                        "'module' must be a non-empty string of at most 63 characters"));
    EXPECT_TRUE(refused({{"cmd", "enable"}, {"module", ""}}, "'module' must be a non-empty string"));
    EXPECT_TRUE(refused({{"cmd", "events"}, {"limit", 0}}, "'limit' must be a positive integer"));
    EXPECT_TRUE(refused({{"cmd", "events"}, {"since", -1}}, "'since' must be a non-negative integer"));
    auto most = decodeCommand("events", json{{"cmd", "events"}, {"limit", protocol::kEventLogCapacity + 1}});
    ASSERT_TRUE(most.ok());
    EXPECT_EQ(most->limit, static_cast<std::size_t>(protocol::kEventLogCapacity))
        << "more than the log holds counts as all";
    auto plain = decodeCommand("events", json{{"cmd", "events"}});
    ASSERT_TRUE(plain.ok());
    EXPECT_EQ(plain->limit, static_cast<std::size_t>(protocol::kEventsDefaultLimit));
}

TEST(ProtocolLimits, ACommandTakesOnlyItsOwnValueFromTheRequest) {
    auto decoded = decodeCommand("enable", json{{"cmd", "enable"}, {"module", "cntr1"}, {"priority", 5}});
    ASSERT_TRUE(decoded.ok());
    ASSERT_EQ(decoded->changes.size(), 1u);
    EXPECT_EQ(decoded->changes[0].enabled, true);
    EXPECT_FALSE(decoded->changes[0].priority.has_value());
}

TEST(ProtocolLimits, ModuleXmlAcceptsThePriorityRangeTheProtocolDoes) {
    EXPECT_TRUE(parsed(periodic("cntr1", 100'000, protocol::kPriorityMin)).ok());
    EXPECT_TRUE(parsed(periodic("cntr1", 100'000, protocol::kPriorityMax)).ok());
    auto above = parsed(periodic("cntr1", 100'000, protocol::kPriorityMax + 1));
    ASSERT_FALSE(above.ok());
    EXPECT_NE(above.error().message.find("is above 1000000"), std::string::npos) << above.error().message;
    auto below = parsed(periodic("cntr1", 100'000, protocol::kPriorityMin - 1));
    ASSERT_FALSE(below.ok());
    EXPECT_NE(below.error().message.find("at least 0"), std::string::npos) << below.error().message;
}

TEST(ProtocolLimits, TheScheduleRefusesBelowTheMinimumBasicPeriodAndAboveTheSlotLimit) {
    const irp::schedule::Limits limits;  // the protocol's defaults
    EXPECT_EQ(limits.min_basic_ns, protocol::kMinBasicPeriodNs);
    const int64_t basic = protocol::kMinBasicPeriodNs;
    auto at_minimum = parsed(periodic("a", basic, 1));
    ASSERT_TRUE(at_minimum.ok());
    EXPECT_TRUE(irp::schedule::build(*at_minimum, limits).ok());
    auto below = parsed(periodic("a", basic - 1, 1));
    ASSERT_TRUE(below.ok());
    auto refused_below = irp::schedule::build(*below, limits);
    ASSERT_FALSE(refused_below.ok());
    EXPECT_NE(refused_below.error().message.find("below the minimum basic period"), std::string::npos);

    auto at_most = parsed(periodic("a", basic, 1) + periodic("b", basic * protocol::kMaxSlots, 2));
    ASSERT_TRUE(at_most.ok());
    auto table = irp::schedule::build(*at_most, limits);
    ASSERT_TRUE(table.ok()) << table.error().message;
    EXPECT_EQ(table->slots.size(), static_cast<std::size_t>(protocol::kMaxSlots));
    auto over = parsed(periodic("a", basic, 1) + periodic("b", basic * (protocol::kMaxSlots + 1), 2));
    ASSERT_TRUE(over.ok());
    auto refused_over = irp::schedule::build(*over, limits);
    ASSERT_FALSE(refused_over.ok());
    EXPECT_NE(refused_over.error().message.find("at most " + std::to_string(protocol::kMaxSlots)), std::string::npos)
        << refused_over.error().message;
}
