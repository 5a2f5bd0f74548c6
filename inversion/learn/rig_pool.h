#pragma once
// Independent black-box work spread over instances of a rig (RigFunction::instance), one per thread.
// Each item starts from a fresh state (RigFunction::resetState), so what it computes depends neither on
// the items before it nor on the thread count: the learner's results are the same for any count.

#include <cstdint>
#include <functional>
#include <memory>
#include <vector>

#include "inversion/model/rig_function.h"

namespace rig {

class RigPool {
public:
    // `threads`: 1 or more (0 is not allowed: the caller resolves "all cores"). The instances are made on
    // first use; a rig without instances runs every item on `rig` itself, one after another.
    RigPool(RigFunction& rig, int threads);
    ~RigPool();
    RigPool(const RigPool&) = delete;
    RigPool& operator=(const RigPool&) = delete;

    // Runs work(instance, i) for i in 0..count-1. Items write their results by index. Of the exceptions
    // thrown, the one of the lowest item is rethrown once every thread has stopped.
    void forEach(int count, const std::function<void(RigFunction& rig, int item)>& work);

    // Evaluations made by the instances (the rig's own count has those made on it).
    std::uint64_t evaluationCount() const;

private:
    RigFunction& rig_;
    int threads_;
    std::vector<std::unique_ptr<RigFunction>> instances_;
    bool noInstances_ = false;
};

}  // namespace rig
