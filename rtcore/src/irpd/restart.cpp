// restart.cpp -- the managed restart's plan (INDUROP_RESTART), the exec, and the desk the control
// and main threads share (restart.hpp).
#include "irpd/restart.hpp"

#include "events/event_log.hpp"
#include "irpd/say.hpp"
#include "osal/rt.hpp"
#include "protocol/errors.hpp"

#include <fcntl.h>
#include <linux/close_range.h>
#include <sys/prctl.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <iostream>

namespace irp::daemon {
namespace {

using json = nlohmann::ordered_json;

json setJson(const SetRef &s) { return json{{"config", s.config}, {"set_id", s.set_id}, {"layout", s.layout}}; }

SetRef setOf(const nlohmann::json &j) {
    return SetRef{j.value("config", ""), j.value("set_id", ""), j.value("layout", "")};
}

// Whether `arg` is the long option `name` (or a prefix of it getopt_long takes as it: at least
// `unique` characters), alone ("--config") or with its value ("--config=x").
bool isOption(const std::string &arg, const std::string &name, std::size_t unique) {
    if (arg.rfind("--", 0) != 0) return false;
    const std::string given = arg.substr(2, arg.find('=') == std::string::npos ? std::string::npos : arg.find('=') - 2);
    return given.size() >= unique && name.rfind(given, 0) == 0;
}

bool hasValue(const std::string &arg) { return arg.find('=') != std::string::npos; }

// The main thread's name is the process's (/proc/<pid>/comm): execv of /proc/self/exe would make
// it "exe".  The old image's name goes in the plan and is set again first thing.
std::string ownName() {
    char name[17] = {};
    prctl(PR_GET_NAME, name, 0, 0, 0);
    return name;
}

}  // namespace

std::string describeSet(const SetRef &set) { return set.set_id.empty() ? set.config : set.set_id; }

RestartPlan RestartPlan::fallBack(const Error &why) const {
    RestartPlan back = *this;
    back.fallback = true;
    back.error = why;
    return back;
}

json RestartPlan::toJson() const {
    return json{{"target", setJson(target)},
                {"origin", setJson(origin)},
                {"requested_ns", requested_ns},
                {"last_period_ns", last_period_ns},
                {"stop_ns", stop_ns},
                {"expected_downtime_ns", expected_downtime_ns},
                {"dma_latency_fd", dma_latency_fd},
                {"fallback", fallback},
                {"error", error.message},
                {"error_at", protocol::placeJson(error.place)},
                {"name", process_name.empty() ? ownName() : process_name}};
}

Result<RestartPlan> RestartPlan::fromJson(const std::string &text) {
    const nlohmann::json j = nlohmann::json::parse(text, nullptr, false);
    if (!j.is_object() || !j.contains("target") || !j["target"].is_object() || !j.contains("origin") ||
        !j["origin"].is_object())
        return Error{std::string(kRestartVariable) + " is not a restart plan (a JSON object with target and origin)"};
    RestartPlan plan;
    try {
        plan.target = setOf(j["target"]);
        plan.origin = setOf(j["origin"]);
        plan.requested_ns = j.value("requested_ns", int64_t{0});
        plan.last_period_ns = j.value("last_period_ns", int64_t{0});
        plan.stop_ns = j.value("stop_ns", int64_t{0});
        plan.expected_downtime_ns = j.value("expected_downtime_ns", int64_t{0});
        plan.dma_latency_fd = j.value("dma_latency_fd", -1);
        plan.fallback = j.value("fallback", false);
        plan.error.message = j.value("error", "");
        if (j.contains("error_at")) plan.error.place = protocol::placeFrom(j["error_at"]);
        plan.process_name = j.value("name", "");
    } catch (const nlohmann::json::exception &e) {
        return Error{std::string(kRestartVariable) + ": " + e.what()};
    }
    if (plan.starting().config.empty()) return Error{std::string(kRestartVariable) + " names no set to start"};
    return plan;
}

Result<std::optional<RestartPlan>> takeRestartPlan() {
    const char *text = std::getenv(kRestartVariable);
    if (!text) return std::optional<RestartPlan>();
    const std::string copy = text;
    unsetenv(kRestartVariable);
    auto plan = RestartPlan::fromJson(copy);
    if (!plan) return plan.error();
    return std::optional<RestartPlan>(std::move(*plan));
}

Error reexec(const std::vector<std::string> &argv, const RestartPlan &plan) {
    const SetRef &set = plan.starting();
    std::vector<std::string> args{argv.empty() ? std::string("irpd") : argv[0]};
    for (std::size_t i = 1; i < argv.size(); ++i) {
        const std::string &a = argv[i];
        if (isOption(a, "config", 4) || isOption(a, "layout", 1)) {
            if (!hasValue(a)) ++i;  // and its value
            continue;
        }
        args.push_back(a);
    }
    args.insert(args.end(), {"--config", set.config});
    if (!set.layout.empty()) args.insert(args.end(), {"--layout", set.layout});
    std::vector<char *> pointers;
    for (std::string &a : args) pointers.push_back(a.data());
    pointers.push_back(nullptr);

    if (setenv(kRestartVariable, plan.toJson().dump().c_str(), 1) != 0)
        return Error{std::string("cannot set ") + kRestartVariable + ": " + std::strerror(errno)};
    // Nothing of this image leaks into the next but the standard streams and the held
    // /dev/cpu_dma_latency (its number is in the plan).
    if (syscall(SYS_close_range, 3u, ~0u, CLOSE_RANGE_CLOEXEC) != 0)
        for (const auto &entry : std::filesystem::directory_iterator("/proc/self/fd")) {
            const int fd = std::atoi(entry.path().filename().c_str());
            if (fd > 2) fcntl(fd, F_SETFD, FD_CLOEXEC);
        }
    if (plan.dma_latency_fd >= 0) fcntl(plan.dma_latency_fd, F_SETFD, 0);
    // The main thread was kept off the RT CPUs; the next image must see every CPU irpd had.
    osal::restoreStartupCpus();
    std::cout.flush();
    std::cerr.flush();
    std::fflush(nullptr);
    execv("/proc/self/exe", pointers.data());
    return Error{std::string("cannot execute /proc/self/exe again for the restart: ") + std::strerror(errno)};
}

Status RestartDesk::request(RestartPlan plan) {
    std::lock_guard lock(mutex_);
    if (pending_ || taken_)
        return Error{"a restart is already under way (onto " + describeSet((pending_ ? *pending_ : plan).target) +
                     "); wait for irpd to come back"};
    pending_ = std::move(plan);
    return Ok{};
}

std::optional<RestartPlan> RestartDesk::take() {
    std::lock_guard lock(mutex_);
    if (!pending_) return std::nullopt;
    taken_ = true;
    return std::exchange(pending_, std::nullopt);
}

void RestartDesk::started(int64_t startup_ns, json last_restart) {
    std::lock_guard lock(mutex_);
    startup_ns_ = startup_ns;
    last_restart_ = std::move(last_restart);
}

json RestartDesk::lastRestart() const {
    std::lock_guard lock(mutex_);
    return last_restart_;
}

int64_t RestartDesk::expectedDowntimeNs(int64_t stop_estimate_ns) const {
    std::lock_guard lock(mutex_);
    if (last_restart_.is_object() && last_restart_.value("downtime_ns", int64_t{0}) > 0)
        return last_restart_["downtime_ns"].get<int64_t>();
    return startup_ns_ + stop_estimate_ns;
}

void reportRestart(const RestartPlan &plan, int64_t first_period_ns, int64_t startup_ns, RestartDesk &desk,
                   events::EventLog &events) {
    const int64_t downtime = first_period_ns - plan.last_period_ns;
    const std::string ms = std::to_string(downtime / 1'000'000) + "." + std::to_string(downtime / 100'000 % 10) + " ms";
    json last = {{"from_set_id", plan.origin.set_id.empty() ? json(nullptr) : json(plan.origin.set_id)},
                 {"set_id", plan.target.set_id.empty() ? json(nullptr) : json(plan.target.set_id)},
                 {"downtime_ns", downtime},
                 {"requested_ns", plan.requested_ns},
                 {"fell_back", plan.fallback},
                 {"error", plan.fallback ? json(plan.error.message) : json(nullptr)},
                 {"error_at", plan.fallback ? protocol::placeJson(plan.error.place) : json(nullptr)},
                 {"stop_ns", plan.stop_ns},
                 {"startup_ns", startup_ns}};
    desk.started(startup_ns, std::move(last));
    const std::string target = describeSet(plan.target), origin = describeSet(plan.origin);
    if (plan.fallback) {
        const std::string message = "could not start set " + target + " (" + plan.error.message +
                                    "); came back on set " + origin + ": downtime " + ms +
                                    ", from the last period of set " + origin + " to its first again";
        events.add("restart_failed", "", message);
        say(message);
    } else {
        const std::string message = "restarted onto set " + target + ": downtime " + ms +
                                    ", from the last period of set " + origin + " to the first of set " + target;
        events.add("restart", "", message);
        say(message);
    }
}

}  // namespace irp::daemon
