// rig-bench's crowd_realtime row (bench/bench_crowd.h): issue #45's flatness figure, the CPU time per biped of the
// crowds of 16 bipeds and more against that of the smallest of them. The crowds themselves are played by
// tests/tools/rig_bench_test.cpp (--quick: 1 and 2 bipeds, below the figure's range).
#include <doctest/doctest.h>

#include "bench/bench_crowd.h"

using namespace rig;

namespace {

bench::Json rowsOf(std::initializer_list<std::pair<int, double>> perAgent)
{
    bench::Json rows = bench::Json::array();
    for (const auto& [agents, ms] : perAgent) rows.push_back({{"agents", agents}, {"cpu_ms_per_agent", ms}});
    return rows;
}

}  // namespace

TEST_CASE("rig-bench crowd_realtime: the time per biped from 16 bipeds on, against that of 16")
{
    // The largest over the first crowd of 16 or more; the smaller crowds (whose state stays cached) left out.
    CHECK(bench::perAgentGrowth(rowsOf({{1, 0.05}, {8, 0.07}, {16, 0.08}, {32, 0.09}, {64, 0.104}, {128, 0.1}}))
              .get<double>() == doctest::Approx(1.3));
    // Flat: 1; a crowd faster than 16's does not lower it below the largest.
    CHECK(bench::perAgentGrowth(rowsOf({{16, 0.1}, {32, 0.1}})).get<double>() == doctest::Approx(1.0));
    CHECK(bench::perAgentGrowth(rowsOf({{16, 0.1}, {32, 0.09}, {64, 0.12}})).get<double>() == doctest::Approx(1.2));
    // Fewer than two crowds in the range: nothing to compare.
    CHECK(bench::perAgentGrowth(rowsOf({{1, 0.05}, {2, 0.06}})).is_null());
    CHECK(bench::perAgentGrowth(rowsOf({{8, 0.05}, {16, 0.06}})).is_null());
    CHECK(bench::perAgentGrowth(bench::Json::array()).is_null());
}
