#include "graph/schedule.h"

#include <algorithm>

#include "core/error.h"

namespace rig {

Schedule::Schedule(int nodeCount, const std::vector<std::pair<int, int>>& edges) : nodeCount_(nodeCount), edges_(edges)
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

}  // namespace rig
