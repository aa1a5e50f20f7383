// alarm_ring.hpp -- the tests' reader of the alarm segment's ring, by <indurop/alarms.h>'s
// protocol: record s is copied between two loads of its seq that both give s; a later seq means
// it was overwritten (lost); an earlier one that it is not written yet, unless the ring has
// lapped it or the caller knows no writer is left (then it is lost too).
#pragma once

#include <indurop/alarms.h>

#include <atomic>
#include <cstdint>
#include <optional>

namespace testing_support {

class AlarmRing {
public:
    explicit AlarmRing(const indurop_alarm_header *header) : h_(header) {}

    enum class State { Intact, Lost, NotYet };
    struct Outcome {
        State state = State::NotYet;
        indurop_alarm_record record{};
    };

    // Record s.  `settled`: no writer is inside the ring any more (the test stopped them).
    Outcome take(uint64_t s, bool settled = true) const {
        const indurop_alarm_record &slot = records()[s & (h_->capacity - 1)];
        Outcome o;
        const uint64_t before = __atomic_load_n(&slot.seq, __ATOMIC_ACQUIRE);
        if (before == s) {
            o.record = slot;  // a plain copy: what a reader in another language does
            std::atomic_thread_fence(std::memory_order_acquire);
            if (__atomic_load_n(&slot.seq, __ATOMIC_RELAXED) == s) {
                o.state = State::Intact;
                return o;
            }
            o.state = State::Lost;  // overwritten while copied
            return o;
        }
        if (before > s) {
            o.state = State::Lost;
            return o;
        }
        const uint64_t head = __atomic_load_n(&h_->head, __ATOMIC_ACQUIRE);
        o.state = settled || head >= s + h_->capacity ? State::Lost : State::NotYet;
        return o;
    }

    std::optional<indurop_alarm_record> read(uint64_t s) const {
        Outcome o = take(s);
        if (o.state != State::Intact) return std::nullopt;
        return o.record;
    }

private:
    const indurop_alarm_record *records() const {
        return reinterpret_cast<const indurop_alarm_record *>(reinterpret_cast<const char *>(h_) + h_->records_offset);
    }
    const indurop_alarm_header *h_;
};

}  // namespace testing_support
