#pragma once
// The parallel evaluator of one graph instance: a tbb::flow::graph over a shared Schedule's edges, in
// its own task arena. Each instance has its own, so instances of one model evaluate at the same time.

#include <exception>
#include <functional>
#include <memory>
#include <mutex>
#include <vector>

#include <tbb/flow_graph.h>
#include <tbb/task_arena.h>

#include "graph/schedule.h"

namespace rig {

class FlowExecutor {
public:
    // `threads` is clamped to 1..the cores: more only adds contention (and TBB warns about the workers
    // it cannot give).
    FlowExecutor(std::shared_ptr<const Schedule> schedule, int threads);
    FlowExecutor(const FlowExecutor&) = delete;
    FlowExecutor& operator=(const FlowExecutor&) = delete;

    const Schedule* schedule() const { return schedule_.get(); }
    int threads() const { return arena_.max_concurrency(); }

    // Runs body(node) for every node with active[node] set, each after all of its active or inactive
    // predecessors. Of the exceptions thrown by bodies, the one of the earliest node in the schedule's
    // order is rethrown here once the graph has drained: the one the serial order would have met.
    void run(const std::vector<char>& active, const std::function<void(int)>& body);

    // The same for the active nodes `nodes` only, level by level (a node's level: one more than its active
    // predecessors' highest), each level's nodes in parallel: a frame that needs a small part of a large
    // graph (a crowd's curves) costs what it computes, where run() passes a message along every edge.
    // prefetch(node, true) is called recordsAhead nodes ahead of body(node) on the same thread, prefetch(node, false)
    // nodesAhead (Graph::prefetchRecords and prefetchNode). Sorts `nodes` in the schedule's order.
    static constexpr std::size_t recordsAhead = 8, nodesAhead = 3;
    void runActive(std::vector<int>& nodes, const std::vector<char>& active, const std::function<void(int)>& body,
                   const std::function<void(int, bool)>& prefetch);

private:
    std::shared_ptr<const Schedule> schedule_;
    tbb::task_arena arena_;
    std::unique_ptr<tbb::flow::graph> graph_;
    std::unique_ptr<tbb::flow::broadcast_node<tbb::flow::continue_msg>> start_;
    std::vector<std::unique_ptr<tbb::flow::continue_node<tbb::flow::continue_msg>>> nodes_;
    // The current run's inputs, read by the node bodies.
    const std::vector<char>* active_ = nullptr;
    const std::function<void(int)>* body_ = nullptr;
    std::mutex errorMutex_;
    std::exception_ptr error_;
    int errorRank_ = 0;
    // runActive's: each node's predecessors (from the schedule's edges), its level in the current run, and the
    // nodes of each level.
    std::vector<std::vector<int>> predecessors_;
    std::vector<int> level_;
    std::vector<std::vector<int>> levels_;

    void runBody(int node);  // body(node), its exception kept as run() keeps them
};

}  // namespace rig
