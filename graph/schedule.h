#pragma once
// Evaluation order of a graph's nodes, built once per topology and reused: a topological order for
// the serial reference evaluator and a tbb::flow::graph for the parallel one. It knows nodes only as
// numbers and edges; the body decides what visiting a node means.

#include <functional>
#include <memory>
#include <utility>
#include <vector>

namespace rig {

class Schedule {
public:
    // `edges` are (from, to) pairs between node numbers 0..nodeCount-1 and must form a DAG.
    Schedule(int nodeCount, const std::vector<std::pair<int, int>>& edges);
    ~Schedule();
    Schedule(const Schedule&) = delete;
    Schedule& operator=(const Schedule&) = delete;

    // Topological order: every edge's source before its destination.
    const std::vector<int>& order() const { return order_; }
    // Position of each node in order().
    const std::vector<int>& rank() const { return rank_; }

    // Runs body(node) for every node with active[node] set, each after all of its active or
    // inactive predecessors, on `threads` threads (at most the cores) of a tbb::flow::graph, built on
    // first use. Of the exceptions thrown by bodies, the one of the earliest node in order() is
    // rethrown here once the graph has drained: the one the serial order would have met.
    void runParallel(const std::vector<char>& active, int threads, const std::function<void(int)>& body);

private:
    struct Flow;
    int nodeCount_;
    std::vector<std::pair<int, int>> edges_;
    std::vector<int> order_;
    std::vector<int> rank_;
    std::unique_ptr<Flow> flow_;
};

}  // namespace rig
