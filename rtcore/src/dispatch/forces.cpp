// forces.cpp -- publishing force tables and freeing the ones no executor reads any more.
#include "dispatch/forces.hpp"

namespace irp::dispatch {

ForceBoard::ForceBoard() : owned_(std::make_unique<ForceTable>()) {
    owned_->generation = 1;
    current_.store(owned_.get(), std::memory_order_release);
}

uint64_t ForceBoard::publish(std::vector<ForcedLeaf> leaves) {
    auto next = std::make_unique<ForceTable>();
    next->leaves = std::move(leaves);
    std::lock_guard lock(mutex_);
    next->generation = owned_->generation + 1;
    current_.store(next.get(), std::memory_order_release);
    retired_.push_back(std::move(owned_));
    owned_ = std::move(next);
    return owned_->generation;
}

void ForceBoard::reclaim(uint64_t oldest_seen) {
    std::lock_guard lock(mutex_);
    std::erase_if(retired_, [&](const std::unique_ptr<ForceTable> &t) { return t->generation < oldest_seen; });
}

std::size_t ForceBoard::retired() const {
    std::lock_guard lock(mutex_);
    return retired_.size();
}

}  // namespace irp::dispatch
