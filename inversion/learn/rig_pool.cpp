#include "inversion/learn/rig_pool.h"

#include <atomic>
#include <exception>
#include <mutex>
#include <thread>

#include <fmt/format.h>

#include "core/error.h"

namespace rig {

RigPool::RigPool(RigFunction& rig, int threads) : rig_(rig), threads_(threads)
{
    if (threads < 1) throw internalError(fmt::format("RigPool: {} threads; give 1 or more", threads));
}

RigPool::~RigPool() = default;

void RigPool::forEach(int count, const std::function<void(RigFunction& rig, int item)>& work)
{
    if (count <= 0) return;
    if (instances_.empty() && !noInstances_) {
        // Made here, on the caller's thread: making an instance reads the rig.
        for (int t = 0; t < threads_; ++t) {
            std::unique_ptr<RigFunction> instance = rig_.instance();
            if (!instance) {
                noInstances_ = true;
                instances_.clear();
                break;
            }
            instances_.push_back(std::move(instance));
        }
    }
    if (noInstances_) {
        for (int i = 0; i < count; ++i) {
            rig_.resetState();
            work(rig_, i);
        }
        return;
    }
    std::atomic<int> next{0};
    std::mutex errorMutex;
    std::exception_ptr error;
    int errorItem = count;
    auto run = [&](RigFunction& rig) {
        for (int i = next++; i < count; i = next++) {
            try {
                rig.resetState();
                work(rig, i);
            }
            catch (...) {
                const std::lock_guard lock(errorMutex);
                if (i < errorItem) {
                    error = std::current_exception();
                    errorItem = i;
                }
            }
        }
    };
    const int used = std::min(threads_, count);
    std::vector<std::thread> helpers;
    for (int t = 1; t < used; ++t) helpers.emplace_back(run, std::ref(*instances_[static_cast<std::size_t>(t)]));
    run(*instances_[0]);
    for (auto& h : helpers) h.join();
    if (error) std::rethrow_exception(error);
}

std::uint64_t RigPool::evaluationCount() const
{
    std::uint64_t total = 0;
    for (const auto& instance : instances_) total += instance->evaluationCount();
    return total;
}

}  // namespace rig
