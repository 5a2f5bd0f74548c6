#pragma once
// rig-bench's crowd_realtime row (issue 35, docs/crowds.md): a crowd of look-at bipeds written by
// scripts/make_crowd.py, each inverted by its own rigInversion node, played through the graph as graph-eval
// plays it, on 1 and 2 threads, for growing crowds.

#include <filesystem>

#include "bench/bench_common.h"
#include "bench/bench_suite.h"

namespace rig::bench {

// The crowd_realtime object: per thread count, the largest crowd whose mean frame time is within 33.3 ms
// (agents_at_30fps), that crowd's frame-time median and 99th percentile, the worst look-at error on the real
// rig, and one row per crowd size. `approximation` is the biped's approximation file (rig-learn's defaults).
Json crowdRealtimeJson(const BenchOptions& options, const std::filesystem::path& approximation);

// Issue #45's flatness, over one thread count's rows (each with `agents` and `cpu_ms_per_agent`): the largest CPU
// time per biped among the crowds of 16 bipeds and more over that of the smallest of them (1: flat); null when fewer
// than two such crowds were played.
Json perAgentGrowth(const Json& rows);

}  // namespace rig::bench
