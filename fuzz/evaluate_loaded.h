#pragma once
// What the loader fuzz targets do with a graph that loaded: evaluate it serially and in parallel, where a node may
// throw rig::Error (a missing clip, a NaN into an enum); anything else is a bug.
#include <memory>

#include "core/error.h"
#include "graph/graph.h"

namespace rig::fuzz {

inline void evaluateLoaded(Graph& graph)
{
    for (const int threads : {1, 2}) {
        try {
            graph.setThreads(threads);
            graph.dirtyAll();
            graph.setTime(1.5);
            graph.evaluateAll();
        }
        catch (const rig::Error&) {
        }
    }
}

}  // namespace rig::fuzz
