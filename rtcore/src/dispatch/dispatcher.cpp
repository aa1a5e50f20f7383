// dispatcher.cpp -- executor plans, RT threads and their common start time.
#include "dispatch/dispatcher.hpp"

#include "osal/rt.hpp"

#include <pthread.h>

#include <algorithm>
#include <cstring>
#include <latch>
#include <map>
#include <numeric>

namespace irp::dispatch {

// Holds the executor threads until all are set up, then releases them on one T0.
struct Dispatcher::StartGate {
    explicit StartGate(std::ptrdiff_t parties) : ready(parties) {}
    std::latch ready;
    std::latch go{1};
    std::atomic<int64_t> t0{0};
};

struct Dispatcher::Plan {
    ExecutorOptions options;
    stats::TimingRecord *record = nullptr;
    std::unique_ptr<Executor> executor;
};

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
    std::stable_sort(by_priority.begin(), by_priority.end(), [](const auto *a, const auto *b) { return a->priority < b->priority; });
    for (const config::ModuleSpec *m : by_priority) {
        const ModuleBinding &b = bindings[static_cast<std::size_t>(m->index)];
        if (m->operation == config::OperationType::NonReal || (!b.run && !b.process)) continue;
        auto task = std::make_unique<Task>();
        task->kind = b.process ? Task::Kind::Process : Task::Kind::Thread;
        task->sporadic = m->operation == config::OperationType::Sporadic;
        task->run = b.run;
        task->condition = b.condition;
        task->process = b.process;
        task->stats = b.stats;
        task->period_ns = m->period_ns;
        task->budget_ns = m->budget_ns;
        task->deadline_ns = m->deadline_ns;
        task->calls = b.calls;
        task->module = b.owner;
        task->disabled = b.disabled;
        tables->by_module[static_cast<std::size_t>(m->index)] = task.get();
        Table &table = *by_name.at(m->executor);
        (task->sporadic ? table.events : table.tasks).push_back(task.get());
        tables->tasks.push_back(std::move(task));
    }

    // Each executor's basic period: the set's for main (the event handler runs every basic period),
    // the GCD of its own modules' periods for the others.  Its slots follow the set's table order.
    for (std::size_t p = 0; p < tables->executors.size(); ++p) {
        Table &table = tables->executors[p];
        const std::string &name = p == 0 ? std::string(config::kMainExecutor) : set.executors[p - 1].name;
        table.basic_ns = schedule.basic_ns;
        if (p > 0 && !table.tasks.empty()) {
            table.basic_ns = table.tasks.front()->period_ns;
            for (Task *t : table.tasks) table.basic_ns = std::gcd(table.basic_ns, t->period_ns);
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
        for (Task *t : table.tasks) t->period_slots = t->period_ns / table.basic_ns;
    }
    return tables;
}

Dispatcher::Dispatcher(const config::SetSpec &set, const Tables &tables, stats::StatsSegment &segment,
                       DispatcherOptions options, osal::Clock &clock)
    : segment_(segment), options_(options), clock_(clock) {
    if (options_.cpu < 0) options_.cpu = osal::lastAllowedCpu();
    std::vector<ExecutorOptions> executors;
    executors.push_back({config::kMainExecutor, options_.rt_priority, options_.cpu, options_.policy, options_.max_catchup_ns,
                         options_.trace});
    for (const config::ExecutorSpec &e : set.executors)
        executors.push_back({e.name, e.rt_priority ? e.rt_priority : std::max(1, options_.rt_priority - 1),
                             e.cpu >= 0 ? e.cpu : options_.cpu, options_.policy, options_.max_catchup_ns});
    for (std::size_t p = 0; p < executors.size(); ++p) {
        auto plan = std::make_unique<Plan>();
        plan->options = executors[p];
        plan->options.marker = static_cast<int>(p);  // the crash handler's marker of this thread
        const Table &table = tables.executors[p];
        plan->record = &segment_.describe(p, stats::RecordKind::Dispatcher,
                                          p == 0 ? std::string("dispatcher") : "dispatcher@" + plan->options.name,
                                          plan->options.name, table.basic_ns, plan->options.rt_priority, 0);
        plan->executor = std::make_unique<Executor>(clock_, &table, plan->record, plan->options);
        plans_.push_back(std::move(plan));
    }
    macro_ns_ = tables.macro_ns;
}

int64_t Dispatcher::boundaryAfter(int64_t t) const {
    if (t <= epoch_ns_) return epoch_ns_;
    const int64_t n = (t - epoch_ns_ + macro_ns_ - 1) / macro_ns_;
    return epoch_ns_ + n * macro_ns_;
}

void Dispatcher::offer(const Tables &next, int64_t at) {
    offered_ = &next;
    offered_at_ = at;
    for (std::size_t p = 0; p < plans_.size(); ++p) plans_[p]->executor->offer(&next.executors[p], at);
}

std::optional<std::vector<Switch>> Dispatcher::switched() {
    std::vector<Switch> all;
    for (const auto &plan : plans_) {
        auto s = plan->executor->switched();
        if (!s) return std::nullopt;
        all.push_back(*s);
    }
    if (offered_) {
        epoch_ns_ = offered_at_;
        macro_ns_ = offered_->macro_ns;
        for (std::size_t p = 0; p < plans_.size(); ++p) plans_[p]->record->period_ns = offered_->executors[p].basic_ns;
        offered_ = nullptr;
    }
    return all;
}

bool Dispatcher::withdraw() {
    bool all = true;
    for (const auto &plan : plans_) all = plan->executor->withdraw() && all;
    if (all) offered_ = nullptr;
    return all;
}

Dispatcher::~Dispatcher() {
    requestStop();
    join();
}

Status Dispatcher::start(int64_t duration_ns) {
    for (const auto &plan : plans_) {
        if (!osal::cpuAllowed(plan->options.cpu))
            return Error{"executor '" + plan->options.name + "': CPU " + std::to_string(plan->options.cpu) +
                         " is not available to irpd (see --cpu, <cpu>)"};
        if (plan->options.rt_priority < 1 || plan->options.rt_priority > 99)
            return Error{"executor '" + plan->options.name + "': RT priority " + std::to_string(plan->options.rt_priority) +
                         " is outside 1..99"};
    }
    reports_.resize(plans_.size());
    gate_ = std::make_unique<StartGate>(static_cast<std::ptrdiff_t>(plans_.size()) + 1);
    for (std::size_t p = 0; p < plans_.size(); ++p) {
        auto body = [this, p, duration_ns, gate = gate_.get()] {
            Plan &plan = *plans_[p];
            ExecutorReport &report = reports_[p];
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
            plan.executor->loop(gate->t0.load(), limit, stop_, p == 0 ? &segment_.header()->cycles : nullptr,
                                p == 0 ? &segment_.header()->finished_ns : nullptr);
            osal::releaseAlternateSignalStack(signal_stack);
            finished_threads_.fetch_add(1, std::memory_order_release);
        };
        if (Status s = spawn(std::move(body)); !s) {
            // Release the threads already waiting; with stop_ set they leave at once.
            requestStop();
            for (std::size_t q = p; q < plans_.size(); ++q) gate_->ready.count_down();
            gate_->go.count_down();
            join();
            return Error{"executor '" + plans_[p]->options.name + "': " + s.error().message};
        }
    }
    gate_->ready.arrive_and_wait();
    // Slot 0 of every executor: a little after now, so that all threads are asleep on it.
    const int64_t t0 = clock_.now() + 2'000'000;
    epoch_ns_ = t0;
    gate_->t0.store(t0);
    segment_.header()->started_ns.store(t0, std::memory_order_relaxed);
    segment_.header()->realtime.store(realtime() ? 1 : 0, std::memory_order_relaxed);
    segment_.header()->running.store(1, std::memory_order_relaxed);
    gate_->go.count_down();
    return Ok{};
}

Status Dispatcher::spawn(std::function<void()> body) {
    pthread_attr_t attr;
    pthread_attr_init(&attr);
    pthread_attr_setstacksize(&attr, kThreadStackBytes);  // locked and prefaulted: keep it small
    auto *heap = new std::function<void()>(std::move(body));
    pthread_t thread;
    int rc = pthread_create(&thread, &attr, [](void *arg) -> void * {
        std::unique_ptr<std::function<void()>> fn(static_cast<std::function<void()> *>(arg));
        (*fn)();
        return nullptr;
    }, heap);
    pthread_attr_destroy(&attr);
    if (rc != 0) {
        delete heap;
        return Error{std::string("cannot start its thread: ") + std::strerror(rc)};
    }
    threads_.push_back(thread);
    return Ok{};
}

void Dispatcher::join() {
    for (pthread_t t : threads_) pthread_join(t, nullptr);
    threads_.clear();
    if (segment_.header()) segment_.header()->running.store(0, std::memory_order_relaxed);
}

bool Dispatcher::realtime() const {
    return !reports_.empty() &&
           std::all_of(reports_.begin(), reports_.end(), [](const ExecutorReport &r) { return r.realtime; });
}

} // namespace irp::dispatch
