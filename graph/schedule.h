#pragma once
// Evaluation order of a graph's nodes, built once per topology and shared by every instance of the
// graph: a topological order for the serial reference evaluator, and the edges a parallel evaluator
// (flow_executor.h) is built from. It knows nodes only as numbers and edges.

#include <utility>
#include <vector>

namespace rig {

class Schedule {
public:
    // `edges` are (from, to) pairs between node numbers 0..nodeCount-1 and must form a DAG.
    Schedule(int nodeCount, const std::vector<std::pair<int, int>>& edges);
    Schedule(const Schedule&) = delete;
    Schedule& operator=(const Schedule&) = delete;

    // Topological order: every edge's source before its destination.
    const std::vector<int>& order() const { return order_; }
    // Position of each node in order().
    const std::vector<int>& rank() const { return rank_; }

    int nodeCount() const { return nodeCount_; }
    const std::vector<std::pair<int, int>>& edges() const { return edges_; }

private:
    int nodeCount_;
    std::vector<std::pair<int, int>> edges_;
    std::vector<int> order_;
    std::vector<int> rank_;
};

}  // namespace rig
