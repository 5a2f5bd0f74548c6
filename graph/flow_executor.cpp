#include "graph/flow_executor.h"

#include <algorithm>

#include <tbb/info.h>

namespace rig {

FlowExecutor::FlowExecutor(std::shared_ptr<const Schedule> schedule, int threads)
    : schedule_(std::move(schedule)), arena_(std::clamp(threads, 1, tbb::info::default_concurrency()))
{
    using tbb::flow::continue_msg;
    arena_.execute([&] {
        graph_ = std::make_unique<tbb::flow::graph>();
        start_ = std::make_unique<tbb::flow::broadcast_node<continue_msg>>(*graph_);
        const int count = schedule_->nodeCount();
        std::vector<char> hasPredecessor(static_cast<std::size_t>(count), 0);
        for (const auto& edge : schedule_->edges()) hasPredecessor[static_cast<std::size_t>(edge.second)] = 1;
        for (int n = 0; n < count; ++n) {
            nodes_.push_back(
                std::make_unique<tbb::flow::continue_node<continue_msg>>(*graph_, [this, n](const continue_msg&) {
                    if (!(*active_)[static_cast<std::size_t>(n)]) return;
                    try {
                        (*body_)(n);
                    }
                    catch (...) {
                        // Keep the failure the serial order would have met first, so the message does not
                        // depend on the thread count.
                        const std::lock_guard lock(errorMutex_);
                        const int r = schedule_->rank()[static_cast<std::size_t>(n)];
                        if (!error_ || r < errorRank_) {
                            error_ = std::current_exception();
                            errorRank_ = r;
                        }
                    }
                }));
            if (!hasPredecessor[static_cast<std::size_t>(n)]) tbb::flow::make_edge(*start_, *nodes_.back());
        }
        for (const auto& [from, to] : schedule_->edges())
            tbb::flow::make_edge(*nodes_[static_cast<std::size_t>(from)], *nodes_[static_cast<std::size_t>(to)]);
    });
}

void FlowExecutor::run(const std::vector<char>& active, const std::function<void(int)>& body)
{
    active_ = &active;
    body_ = &body;
    error_ = nullptr;
    arena_.execute([&] {
        start_->try_put(tbb::flow::continue_msg());
        graph_->wait_for_all();
    });
    if (error_) std::rethrow_exception(error_);
}

}  // namespace rig
