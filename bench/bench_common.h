#pragma once
// What rig-bench's measurements share: JSON reports (nlohmann), repeated timing, the machine's
// description, memory readings, log-log growth fits and real-rig error statistics (docs/performance.md).

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "core/thread_clock.h"
#include "inversion/solve/jacobian.h"

namespace rig::bench {

// Reports keep their keys in insertion order: the JSON reads top to bottom as the report does.
using Json = nlohmann::ordered_json;

// A figure that may be missing: null in the report.
inline Json orNull(std::optional<double> x) { return x ? Json(*x) : Json(); }

// Per-call time of an operation, repeated in batches (each batch at least ~1 ms, so that the clock's
// resolution does not matter) until `budgetSeconds` have passed and at least `minBatches` batches ran.
struct Timing {
    double medianMs = 0.0;  // wall clock, median of the batches' per-call times
    double minMs = 0.0;     // wall clock, fastest batch
    // CPU time of the calling thread, median per call: what a single-threaded operation costs, whatever
    // else the machine runs (a neighbour's process does not count; it only waits). Meaningless for an
    // operation that hands work to other threads.
    double cpuMedianMs = 0.0;
    long long calls = 0;
};
Timing timeRepeated(const std::function<void()>& operation, double budgetSeconds, int minBatches = 5);

double secondsSince(std::chrono::steady_clock::time_point start);

// `s` in single quotes for the shell (the generator's command lines).
std::string shellQuote(const std::string& s);

// The machine and build: cores, CPU model, compiler, build type, library versions, load average.
Json machineDescription();
// The 1-, 5- and 15-minute load averages (/proc/loadavg), empty when unreadable.
std::vector<double> loadAverage();

// Memory of this process, MB, from /proc/self/status: resident now, and the peak since the last reset.
double residentMb();
double peakResidentMb();
// The heap this process holds now, MB (malloc's blocks in use, mallinfo2): what stays of a structure once built,
// without the pages a load touched and freed, which the peak counts.
double heapInUseMb();
// Returns freed memory to the system and sets the peak to the current resident size (Linux
// /proc/self/clear_refs), so that the next peak belongs to the work that follows. False when the
// kernel refuses (the peak then spans the whole run).
bool resetPeakResident();

// Least-squares slope of log(y) against log(x) over the points with x, y > 0: y ~ x^slope.
// nullopt with fewer than two such points or a single distinct x.
std::optional<double> growthExponent(std::span<const double> x, std::span<const double> y);

}  // namespace rig::bench
