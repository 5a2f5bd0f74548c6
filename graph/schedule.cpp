#include "graph/schedule.h"

#include <algorithm>
#include <exception>
#include <mutex>

#include <tbb/flow_graph.h>
#include <tbb/info.h>
#include <tbb/task_arena.h>

#include "core/error.h"

namespace rig {

// The flow graph lives in its own arena so that `threads` bounds its concurrency; it reads the
// current run's `active` and `body` through pointers set by runParallel.
struct Schedule::Flow {
    explicit Flow(int threads) : arena(threads) {}
    const std::vector<int>* rank = nullptr;

    tbb::task_arena arena;
    std::unique_ptr<tbb::flow::graph> graph;
    std::unique_ptr<tbb::flow::broadcast_node<tbb::flow::continue_msg>> start;
    std::vector<std::unique_ptr<tbb::flow::continue_node<tbb::flow::continue_msg>>> nodes;
    const std::vector<char>* active = nullptr;
    const std::function<void(int)>* body = nullptr;
    std::mutex errorMutex;
    std::exception_ptr error;
    int errorRank = 0;
};

Schedule::Schedule(int nodeCount, const std::vector<std::pair<int, int>>& edges)
    : nodeCount_(nodeCount), edges_(edges)
{
    // Kahn's algorithm, taking ready nodes in increasing number so the order is deterministic.
    std::vector<std::vector<int>> successors(static_cast<std::size_t>(nodeCount));
    std::vector<int> indegree(static_cast<std::size_t>(nodeCount), 0);
    for (const auto& [from, to] : edges) {
        successors[static_cast<std::size_t>(from)].push_back(to);
        ++indegree[static_cast<std::size_t>(to)];
    }
    std::vector<int> ready;
    for (int n = nodeCount - 1; n >= 0; --n)
        if (indegree[static_cast<std::size_t>(n)] == 0) ready.push_back(n);
    while (!ready.empty()) {
        const int n = ready.back();
        ready.pop_back();
        order_.push_back(n);
        for (int s : successors[static_cast<std::size_t>(n)])
            if (--indegree[static_cast<std::size_t>(s)] == 0) ready.push_back(s);
    }
    if (static_cast<int>(order_.size()) != nodeCount) throw internalError("Schedule: the graph has a cycle");
    rank_.resize(static_cast<std::size_t>(nodeCount));
    for (std::size_t i = 0; i < order_.size(); ++i) rank_[static_cast<std::size_t>(order_[i])] = static_cast<int>(i);
}

Schedule::~Schedule() = default;

void Schedule::runParallel(const std::vector<char>& active, int threads, const std::function<void(int)>& body)
{
    using tbb::flow::continue_msg;
    // More threads than cores only adds contention (and TBB warns about the workers it cannot give).
    threads = std::clamp(threads, 1, tbb::info::default_concurrency());
    if (!flow_ || flow_->arena.max_concurrency() != threads) {
        flow_ = std::make_unique<Flow>(threads);
        Flow& f = *flow_;
        f.arena.execute([&] {
            f.graph = std::make_unique<tbb::flow::graph>();
            f.start = std::make_unique<tbb::flow::broadcast_node<continue_msg>>(*f.graph);
            std::vector<char> hasPredecessor(static_cast<std::size_t>(nodeCount_), 0);
            for (const auto& edge : edges_) hasPredecessor[static_cast<std::size_t>(edge.second)] = 1;
            for (int n = 0; n < nodeCount_; ++n) {
                f.nodes.push_back(std::make_unique<tbb::flow::continue_node<continue_msg>>(
                    *f.graph, [&f, n](const continue_msg&) {
                        if (!(*f.active)[static_cast<std::size_t>(n)]) return;
                        try {
                            (*f.body)(n);
                        }
                        catch (...) {
                            // Keep the failure the serial order would have met first, so the
                            // message does not depend on the thread count.
                            const std::lock_guard lock(f.errorMutex);
                            const int r = (*f.rank)[static_cast<std::size_t>(n)];
                            if (!f.error || r < f.errorRank) {
                                f.error = std::current_exception();
                                f.errorRank = r;
                            }
                        }
                    }));
                if (!hasPredecessor[static_cast<std::size_t>(n)])
                    tbb::flow::make_edge(*f.start, *f.nodes.back());
            }
            for (const auto& [from, to] : edges_)
                tbb::flow::make_edge(*f.nodes[static_cast<std::size_t>(from)], *f.nodes[static_cast<std::size_t>(to)]);
        });
    }
    Flow& f = *flow_;
    f.active = &active;
    f.rank = &rank_;
    f.body = &body;
    f.error = nullptr;
    f.arena.execute([&] {
        f.start->try_put(continue_msg());
        f.graph->wait_for_all();
    });
    if (f.error) std::rethrow_exception(f.error);
}

}  // namespace rig
