#include "graph/flow_executor.h"

#include <algorithm>

#include <tbb/blocked_range.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>

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
                    if ((*active_)[static_cast<std::size_t>(n)]) runBody(n);
                }));
            if (!hasPredecessor[static_cast<std::size_t>(n)]) tbb::flow::make_edge(*start_, *nodes_.back());
        }
        for (const auto& [from, to] : schedule_->edges())
            tbb::flow::make_edge(*nodes_[static_cast<std::size_t>(from)], *nodes_[static_cast<std::size_t>(to)]);
    });
    predecessors_.resize(static_cast<std::size_t>(schedule_->nodeCount()));
    for (const auto& [from, to] : schedule_->edges()) predecessors_[static_cast<std::size_t>(to)].push_back(from);
    level_.assign(predecessors_.size(), 0);
}

void FlowExecutor::runBody(int n)
{
    try {
        (*body_)(n);
    }
    catch (...) {
        // Keep the failure the serial order would have met first, so the message does not depend on the
        // thread count.
        const std::lock_guard lock(errorMutex_);
        const int r = schedule_->rank()[static_cast<std::size_t>(n)];
        if (!error_ || r < errorRank_) {
            error_ = std::current_exception();
            errorRank_ = r;
        }
    }
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

void FlowExecutor::runActive(std::vector<int>& nodes, const std::vector<char>& active,
                             const std::function<void(int)>& body, const std::function<void(int, bool)>& prefetch)
{
    const auto& rank = schedule_->rank();
    std::sort(nodes.begin(), nodes.end(),
              [&](int a, int b) { return rank[static_cast<std::size_t>(a)] < rank[static_cast<std::size_t>(b)]; });
    // Kept from run to run, emptied but not freed: a crowd's frame allocates nothing.
    std::vector<std::vector<int>>& levels = levels_;
    for (auto& level : levels) level.clear();
    std::size_t used = 0;
    for (const int n : nodes) {
        int level = 0;
        for (const int p : predecessors_[static_cast<std::size_t>(n)])
            if (active[static_cast<std::size_t>(p)]) level = std::max(level, level_[static_cast<std::size_t>(p)] + 1);
        level_[static_cast<std::size_t>(n)] = level;
        used = std::max(used, static_cast<std::size_t>(level) + 1);
        if (used > levels.size()) levels.resize(used);
        levels[static_cast<std::size_t>(level)].push_back(n);
    }
    body_ = &body;
    error_ = nullptr;
    arena_.execute([&] {
        for (std::size_t l = 0; l < used; ++l) {
            const std::vector<int>& level = levels[l];
            tbb::parallel_for(tbb::blocked_range<std::size_t>(0, level.size()),
                              [&](const tbb::blocked_range<std::size_t>& r) {
                                  for (std::size_t i = r.begin(); i != r.end(); ++i) {
                                      if (i + recordsAhead < r.end()) prefetch(level[i + recordsAhead], true);
                                      if (i + nodesAhead < r.end()) prefetch(level[i + nodesAhead], false);
                                      runBody(level[i]);
                                  }
                              });
        }
    });
    if (error_) std::rethrow_exception(error_);
}

}  // namespace rig
