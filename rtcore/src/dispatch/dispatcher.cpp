// dispatcher.cpp -- executor plans, RT threads and their common start time.
#include "dispatch/dispatcher.hpp"

#include "dispatch/running_marker.hpp"
#include "osal/rt.hpp"
#include "protocol/limits.hpp"

#include <pthread.h>

#include <algorithm>
#include <cstring>
#include <latch>
#include <map>
#include <numeric>

namespace irp::dispatch {

// Holds executor threads until all are set up, then releases them on one T0.
struct Dispatcher::StartGate {
    explicit StartGate(std::ptrdiff_t parties) : ready(parties) {}
    std::latch ready;
    std::latch go{1};
    std::atomic<int64_t> t0{0};
};

// One executor thread: how it is set up, its stats record, its loop and its own stop flag.
struct Dispatcher::Plan {
    ExecutorOptions options;
    std::size_t record_index = 0;
    stats::TimingRecord *record = nullptr;
    std::shared_ptr<Executor> executor;
    // No tasks: the table it runs while parked before the swap that adds it, and after the one
    // that takes it away until it is stopped.
    Table idle;
    std::atomic<bool> stop{false};
    std::atomic<bool> finished{false};
    std::optional<pthread_t> thread;
    ExecutorReport report;  // written by its thread before it is released
};

std::vector<ExecutorOptions> executorsOf(const config::SetSpec &set, const DispatcherOptions &options) {
    const int cpu = options.cpu >= 0 ? options.cpu : osal::lastAllowedCpu();
    std::vector<ExecutorOptions> all;
    all.push_back(
        {config::kMainExecutor, options.rt_priority, cpu, options.policy, options.max_catchup_ns, options.trace});
    for (const config::ExecutorSpec &e : set.executors)
        all.push_back({e.name, e.rt_priority ? e.rt_priority : std::max(1, options.rt_priority - 1),
                       e.cpu >= 0 ? e.cpu : cpu, options.policy, options.max_catchup_ns, nullptr});
    return all;
}

Status checkExecutors(const std::vector<ExecutorOptions> &executors) {
    for (const ExecutorOptions &e : executors) {
        if (!osal::cpuAllowed(e.cpu))
            return Error{"executor '" + e.name + "': CPU " + std::to_string(e.cpu) +
                         " is not available to irpd (see --cpu, <cpu>)"};
        if (e.rt_priority < 1 || e.rt_priority > 99)
            return Error{"executor '" + e.name + "': RT priority " + std::to_string(e.rt_priority) +
                         " is outside 1..99"};
    }
    return Ok{};
}

std::unique_ptr<Tables> buildTables(const config::SetSpec &set, const schedule::Schedule &schedule,
                                    const std::vector<ModuleBinding> &bindings) {
    auto tables = std::make_unique<Tables>();
    tables->macro_ns = schedule.macro_ns;
    std::map<std::string, Table *> by_name;
    tables->executors.resize(Dispatcher::executorCount(set));
    by_name[config::kMainExecutor] = &tables->executors[0];
    for (std::size_t e = 0; e < set.executors.size(); ++e) by_name[set.executors[e].name] = &tables->executors[e + 1];

    // Tasks of the dispatched modules, grouped by executor: periodic ones go into the slot table,
    // sporadic ones into the event handler's list (priority order, ties to the earlier in the file).
    tables->by_module.assign(set.modules.size(), nullptr);
    std::vector<const config::ModuleSpec *> by_priority;
    for (const config::ModuleSpec &m : set.modules) by_priority.push_back(&m);
    std::stable_sort(by_priority.begin(), by_priority.end(),
                     [](const auto *a, const auto *b) { return a->priority < b->priority; });
    for (const config::ModuleSpec *m : by_priority) {
        const ModuleBinding &b = bindings[static_cast<std::size_t>(m->index)];
        if (m->operation == config::OperationType::NonReal || (!b.run && !b.process)) continue;
        TaskConfig c;
        c.kind = b.process ? Task::Kind::Process : Task::Kind::Thread;
        c.sporadic = m->operation == config::OperationType::Sporadic;
        c.run = b.run;
        c.condition = b.condition;
        c.process = b.process;
        c.stats = b.stats;
        c.period_ns = m->period_ns;
        c.budget_ns = m->budget_ns;
        c.on_overrun = m->on_overrun;
        c.overrun_limit_ns = m->overrun_limit_ns;
        c.deadline_ns = m->deadline_ns;
        c.calls = b.calls;
        c.module = b.owner;
        c.disabled = b.disabled;
        c.alarm_source = b.alarm_source;
        c.fault_note = b.fault_note;
        auto task = std::make_unique<Task>(c);
        tables->by_module[static_cast<std::size_t>(m->index)] = task.get();
        Table &table = *by_name.at(m->executor);
        (c.sporadic ? table.events : table.tasks).push_back(task.get());
        tables->tasks.push_back(std::move(task));
    }

    // Each executor's basic period: the set's for main (the event handler runs every basic period),
    // the GCD of its own modules' periods for the others.  Its slots follow the set's table order.
    for (std::size_t p = 0; p < tables->executors.size(); ++p) {
        Table &table = tables->executors[p];
        const std::string &name = p == 0 ? std::string(config::kMainExecutor) : set.executors[p - 1].name;
        table.basic_ns = schedule.basic_ns;
        if (p > 0 && !table.tasks.empty()) {
            table.basic_ns = table.tasks.front()->config.period_ns;
            for (Task *t : table.tasks) table.basic_ns = std::gcd(table.basic_ns, t->config.period_ns);
        }
        const auto ratio = static_cast<std::size_t>(table.basic_ns / schedule.basic_ns);
        const std::size_t count = table.tasks.empty() ? 1 : schedule.slots.size() / ratio;
        table.slots.resize(count);
        for (std::size_t i = 0; i < count; ++i) {
            for (int index : schedule.slots[i * ratio].modules) {
                Task *t = tables->by_module[static_cast<std::size_t>(index)];
                if (t && set.modules[static_cast<std::size_t>(index)].executor == name) table.slots[i].push_back(t);
            }
        }
        for (Task *t : table.tasks) t->config.period_slots = t->config.period_ns / table.basic_ns;
        for (Task *t : table.tasks)
            t->config.leads = t->config.kind == Task::Kind::Process &&
                              std::all_of(table.slots.begin(), table.slots.end(), [t](const std::vector<Task *> &slot) {
                                  return std::find(slot.begin(), slot.end(), t) == slot.end() || slot.front() == t;
                              });
    }
    return tables;
}

Dispatcher::Dispatcher(const config::SetSpec &set, Tables &tables, stats::StatsSegment &segment,
                       DispatcherOptions options, osal::Clock &clock)
    : marker_used_(kLifecycleMarker, false), segment_(segment), options_(options), clock_(clock) {
    if (options_.cpu < 0) options_.cpu = osal::lastAllowedCpu();
    const std::vector<ExecutorOptions> executors = executorsOf(set, options_);
    tables.records.clear();
    tables.markers.clear();
    for (std::size_t p = 0; p < executors.size(); ++p) {
        plans_.push_back(makePlan(executors[p], p, &tables.executors[p]));
        tables.records.push_back(p);
        tables.markers.push_back(plans_.back()->options.marker);
    }
    macro_ns_ = tables.macro_ns;
}

std::unique_ptr<Dispatcher::Plan> Dispatcher::makePlan(const ExecutorOptions &options, std::size_t record,
                                                       const Table *table) {
    auto plan = std::make_unique<Plan>();
    plan->options = options;
    plan->options.halted = &halted_;
    plan->options.forces = options_.forces;
    // the crash handler's marker of this thread: the first free one
    auto free = std::find(marker_used_.begin(), marker_used_.end(), false);
    plan->options.marker = free == marker_used_.end() ? -1 : static_cast<int>(free - marker_used_.begin());
    if (free != marker_used_.end()) *free = true;
    plan->idle.basic_ns = table ? table->basic_ns : plans_.front()->executor->basicNs();
    plan->idle.slots.resize(1);
    plan->record_index = record;
    plan->record = &segment_.describe(record, stats::RecordKind::Dispatcher,
                                      plans_.empty() ? std::string("dispatcher") : "dispatcher@" + options.name,
                                      options.name, (table ? *table : plan->idle).basic_ns, options.rt_priority, 0);
    plan->executor = std::make_shared<Executor>(clock_, table ? table : &plan->idle, plan->record, plan->options);
    return plan;
}

void Dispatcher::release(Plan &plan) {
    segment_.release(plan.record_index);
    if (plan.options.marker >= 0) marker_used_[static_cast<std::size_t>(plan.options.marker)] = false;
}

Status Dispatcher::prepare(const config::SetSpec &set, Tables &next) {
    const std::vector<ExecutorOptions> wanted = executorsOf(set, options_);
    if (Status s = checkExecutors(wanted); !s) return s;
    next_.clear();
    std::vector<std::shared_ptr<Plan>> fresh;
    auto undo = [&] {
        for (const auto &plan : fresh) release(*plan);
        next_.clear();
    };
    for (const ExecutorOptions &w : wanted) {
        auto same = std::find_if(plans_.begin(), plans_.end(), [&](const auto &p) {
            return p->options.name == w.name && p->options.rt_priority == w.rt_priority && p->options.cpu == w.cpu;
        });
        if (same != plans_.end()) {
            next_.push_back(same->get());
            continue;
        }
        auto record = segment_.findUnused(1);
        if (!record) {
            undo();
            return Error{
                "no room for executor '" + w.name + "' in irpd's stats block (" +
                    std::to_string(segment_.recordCount()) +
                    " records for dispatchers and modules; irpd's "
                    "--module-records raises it): restart irpd onto this set, or with a larger --module-records",
                protocol::kRestartRequired};
        }
        fresh.push_back(makePlan(w, *record, nullptr));
        next_.push_back(fresh.back().get());
    }
    if (!fresh.empty()) {
        auto gate = std::make_shared<StartGate>(static_cast<std::ptrdiff_t>(fresh.size()) + 1);
        for (std::size_t i = 0; i < fresh.size(); ++i)
            if (Status s = launch(*fresh[i], gate, 0, false); !s) {
                for (std::size_t j = 0; j < fresh.size(); ++j) fresh[j]->stop.store(true, std::memory_order_relaxed);
                for (std::size_t j = i; j < fresh.size(); ++j) gate->ready.count_down();
                gate->go.count_down();
                for (const auto &plan : fresh) joinPlan(*plan);
                undo();
                return Error{"executor '" + fresh[i]->options.name + "': " + s.error().message};
            }
        gate->ready.arrive_and_wait();
        // Parked on the running grid (the main table's basic period from its T0): the offered
        // boundary is one of its slots.
        const int64_t basic = plans_.front()->executor->basicNs();
        const int64_t soon = clock_.now() + 1'000'000;
        gate->t0.store(epoch_ns_ + (soon - epoch_ns_ + basic - 1) / basic * basic);
        gate->go.count_down();
        std::lock_guard lock(plans_mutex_);
        arriving_ = std::move(fresh);
        executors_version_.fetch_add(1, std::memory_order_release);
    }
    next.records.clear();
    next.markers.clear();
    for (std::size_t i = 0; i < next_.size(); ++i) {
        next.records.push_back(next_[i]->record_index);
        next.markers.push_back(next_[i]->options.marker);
    }
    return Ok{};
}

int64_t Dispatcher::boundaryAfter(int64_t t) const {
    if (t <= epoch_ns_) return epoch_ns_;
    const int64_t n = (t - epoch_ns_ + macro_ns_ - 1) / macro_ns_;
    return epoch_ns_ + n * macro_ns_;
}

void Dispatcher::offer(const Tables &next, int64_t at) {
    offered_ = &next;
    offered_at_ = at;
    std::vector<Plan *> leaving;  // offered an empty table
    for (const auto &plan : plans_)
        if (std::find(next_.begin(), next_.end(), plan.get()) == next_.end()) leaving.push_back(plan.get());
    // A swap gate counts every executor offered a table (the new tables' and the leaving ones' empty),
    // set before any of them can take one.
    SwapGate *gate = next.executors.front().gate;
    if (gate) gate->expected = static_cast<int>(next_.size() + leaving.size());
    for (Plan *plan : leaving) {
        plan->idle.basic_ns = next.executors.front().basic_ns;  // not run now: it runs its own table
        plan->idle.gate = gate;
    }
    for (std::size_t i = 0; i < next_.size(); ++i) next_[i]->executor->offer(&next.executors[i], at);
    for (Plan *plan : leaving) plan->executor->offer(&plan->idle, at);
}

std::optional<std::vector<Switch>> Dispatcher::switched() {
    std::vector<Switch> all;
    if (!offered_) {
        for (const auto &plan : plans_) {
            auto s = plan->executor->switched();
            if (!s) return std::nullopt;
            all.push_back(*s);
        }
        return all;
    }
    for (Plan *plan : next_) {
        auto s = plan->executor->switched();
        if (!s) return std::nullopt;
        all.push_back(*s);
    }
    for (const auto &plan : plans_)
        if (!plan->executor->switched()) return std::nullopt;  // also those going to their empty table
    epoch_ns_ = offered_at_;
    macro_ns_ = offered_->macro_ns;
    for (std::size_t i = 0; i < next_.size(); ++i) next_[i]->record->period_ns = offered_->executors[i].basic_ns;
    std::vector<std::shared_ptr<Plan>> running;
    for (Plan *plan : next_) {
        for (auto *list : {&plans_, &arriving_})
            for (auto &p : *list)
                if (p.get() == plan) running.push_back(p);
    }
    {
        std::lock_guard lock(plans_mutex_);
        for (auto &p : plans_)
            if (std::find(next_.begin(), next_.end(), p.get()) == next_.end()) leaving_.push_back(p);
        plans_ = std::move(running);
        arriving_.clear();
        executors_version_.fetch_add(1, std::memory_order_release);
    }
    next_.clear();
    offered_ = nullptr;
    return all;
}

bool Dispatcher::withdraw() {
    bool all = true;
    for (Plan *plan : next_) all = plan->executor->withdraw() && all;
    for (const auto &plan : plans_)
        if (std::find(next_.begin(), next_.end(), plan.get()) == next_.end()) all = plan->executor->withdraw() && all;
    if (all) offered_ = nullptr;
    return all;
}

void Dispatcher::retire() {
    std::vector<std::shared_ptr<Plan>> going;
    {
        std::lock_guard lock(plans_mutex_);
        going = std::move(leaving_);
        going.insert(going.end(), arriving_.begin(), arriving_.end());
        leaving_.clear();
        arriving_.clear();
        executors_version_.fetch_add(1, std::memory_order_release);
    }
    next_.clear();
    for (const auto &plan : going) plan->stop.store(true, std::memory_order_relaxed);
    for (const auto &plan : going) {
        joinPlan(*plan);
        release(*plan);
    }
    foldStats();
}

void Dispatcher::foldStats() {
    for (const std::shared_ptr<Executor> &e : executors()) e->foldStats();
}

void Dispatcher::startFolder() {
    folder_quit_.store(false, std::memory_order_relaxed);
    folder_ = std::thread([this] {
        pthread_setname_np(pthread_self(), "irp@stats");
        // Lowest SCHED_FIFO priority (if allowed): above the machine's ordinary work, below every
        // RT thread of irpd.  Not pinned: irpd keeps it off the dispatchers' CPUs (keepOffCpus).
        if (options_.realtime) osal::makeCurrentThreadRealtime(1, -1);
        int64_t next = clock_.now();
        while (!folder_quit_.load(std::memory_order_relaxed)) {
            next = std::max(next + kFoldIntervalNs, clock_.now());
            clock_.sleepUntil(next);
            foldStats();
        }
    });
}

Dispatcher::~Dispatcher() {
    requestStop();
    join();
}

void Dispatcher::requestStop() {
    std::lock_guard lock(plans_mutex_);
    for (const auto *list : {&plans_, &arriving_, &leaving_})
        for (const auto &plan : *list) plan->stop.store(true, std::memory_order_relaxed);
}

bool Dispatcher::finished() const {
    std::lock_guard lock(plans_mutex_);
    return std::all_of(plans_.begin(), plans_.end(),
                       [](const auto &p) { return p->finished.load(std::memory_order_acquire); });
}

Status Dispatcher::start(int64_t duration_ns) {
    std::vector<ExecutorOptions> all;
    for (const auto &plan : plans_) all.push_back(plan->options);
    if (Status s = checkExecutors(all); !s) return s;
    auto gate = std::make_shared<StartGate>(static_cast<std::ptrdiff_t>(plans_.size()) + 1);
    for (std::size_t p = 0; p < plans_.size(); ++p)
        if (Status s = launch(*plans_[p], gate, duration_ns, p == 0); !s) {
            // Release the threads already waiting; with their stop set they leave at once.
            requestStop();
            for (std::size_t q = p; q < plans_.size(); ++q) gate->ready.count_down();
            gate->go.count_down();
            join();
            return Error{"executor '" + plans_[p]->options.name + "': " + s.error().message};
        }
    gate->ready.arrive_and_wait();
    // Slot 0 of every executor: a little after now, so that all threads are asleep on it.
    const int64_t t0 = clock_.now() + 2'000'000;
    epoch_ns_ = t0;
    gate->t0.store(t0);
    segment_.header()->started_ns.store(t0, std::memory_order_relaxed);
    segment_.header()->realtime.store(realtime() ? 1 : 0, std::memory_order_relaxed);
    segment_.header()->running.store(1, std::memory_order_relaxed);
    gate->go.count_down();
    startFolder();
    return Ok{};
}

Status Dispatcher::launch(Plan &plan, const std::shared_ptr<StartGate> &gate, int64_t duration_ns, bool main) {
    auto body = [this, &plan, gate, duration_ns, main] {
        // "irp@" and the executor's name, as `ps -L` and /proc/<pid>/task/*/comm show it (15 bytes)
        pthread_setname_np(pthread_self(), ("irp@" + plan.options.name).substr(0, 15).c_str());
        ExecutorReport &report = plan.report;
        report.name = plan.options.name;
        report.cpu = plan.options.cpu;
        report.rt_priority = plan.options.rt_priority;
        if (options_.realtime) {
            osal::RtStatus rt = osal::makeCurrentThreadRealtime(plan.options.rt_priority, plan.options.cpu);
            report.realtime = rt.realtime;
            report.detail = rt.detail;
        } else {
            osal::makeCurrentThreadRealtime(0, plan.options.cpu);  // pin only; priority 0 is refused
            report.detail = "SCHED_OTHER by request (--no-rt), pinned to CPU " + std::to_string(plan.options.cpu);
        }
        osal::prefaultStack();
        void *signal_stack = osal::useAlternateSignalStack();  // the crash handler runs on it
        gate->ready.count_down();
        gate->go.wait();
        uint64_t limit = duration_ns > 0 ? static_cast<uint64_t>(duration_ns / plan.executor->basicNs()) : 0;
        plan.executor->loop(gate->t0.load(), limit, plan.stop, main ? &segment_.header()->cycles : nullptr,
                            main ? &segment_.header()->finished_ns : nullptr);
        osal::releaseAlternateSignalStack(signal_stack);
        plan.finished.store(true, std::memory_order_release);
    };
    pthread_attr_t attr;
    pthread_attr_init(&attr);
    pthread_attr_setstacksize(&attr, kThreadStackBytes);  // locked and prefaulted: keep it small
    auto *heap = new std::function<void()>(std::move(body));
    pthread_t thread;
    int rc = pthread_create(
        &thread, &attr,
        [](void *arg) -> void * {
            std::unique_ptr<std::function<void()>> fn(static_cast<std::function<void()> *>(arg));
            (*fn)();
            return nullptr;
        },
        heap);
    pthread_attr_destroy(&attr);
    if (rc != 0) {
        delete heap;
        return Error{std::string("cannot start its thread: ") + std::strerror(rc)};
    }
    plan.thread = thread;
    return Ok{};
}

void Dispatcher::joinPlan(Plan &plan) {
    if (plan.thread) pthread_join(*plan.thread, nullptr);
    plan.thread.reset();
}

void Dispatcher::join() {
    std::vector<std::shared_ptr<Plan>> all;
    {
        std::lock_guard lock(plans_mutex_);
        for (const auto *list : {&plans_, &arriving_, &leaving_}) all.insert(all.end(), list->begin(), list->end());
    }
    for (const auto &plan : all) joinPlan(*plan);
    folder_quit_.store(true, std::memory_order_relaxed);
    if (folder_.joinable()) folder_.join();
    foldStats();  // (each loop folded its last samples when it ended)
    if (segment_.header()) segment_.header()->running.store(0, std::memory_order_relaxed);
}

std::vector<std::shared_ptr<Executor>> Dispatcher::executors() const {
    std::lock_guard lock(plans_mutex_);
    std::vector<std::shared_ptr<Executor>> all;
    for (const auto *list : {&plans_, &arriving_, &leaving_})
        for (const auto &plan : *list) all.push_back(plan->executor);
    return all;
}

uint64_t Dispatcher::forcesSeen() const {
    std::lock_guard lock(plans_mutex_);
    uint64_t oldest = UINT64_MAX;
    for (const auto *list : {&plans_, &arriving_, &leaving_})
        for (const auto &plan : *list) oldest = std::min(oldest, plan->executor->forceSeen());
    return oldest;
}

std::vector<ExecutorReport> Dispatcher::reports() const {
    std::lock_guard lock(plans_mutex_);
    std::vector<ExecutorReport> all;
    for (const auto &plan : plans_) all.push_back(plan->report);
    return all;
}

bool Dispatcher::realtime() const {
    std::lock_guard lock(plans_mutex_);
    return !plans_.empty() &&
           std::all_of(plans_.begin(), plans_.end(), [](const auto &p) { return p->report.realtime; });
}

}  // namespace irp::dispatch
