#include "bench/bench_common.h"

#include <malloc.h>

#include <algorithm>
#include <cmath>
#include <ctime>
#include <fstream>
#include <numbers>
#include <sstream>
#include <thread>

#include <fmt/format.h>
#include <oneapi/tbb/version.h>
#include <Eigen/Core>

#ifndef RIG_BENCH_BUILD_TYPE
#define RIG_BENCH_BUILD_TYPE "unknown"
#endif
#ifndef RIG_BENCH_CXX_FLAGS
#define RIG_BENCH_CXX_FLAGS ""
#endif

namespace rig::bench {

// --- timing ---

double secondsSince(std::chrono::steady_clock::time_point start)
{
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

namespace {

double median(std::vector<double> v)
{
    std::sort(v.begin(), v.end());
    const std::size_t n = v.size();
    return n == 0 ? 0.0 : n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

}  // namespace

Timing timeRepeated(const std::function<void()>& operation, double budgetSeconds, int minBatches)
{
    using Clock = std::chrono::steady_clock;
    // One call first: it warms caches and pools, and sizes the batches.
    auto start = Clock::now();
    operation();
    const double first = secondsSince(start);
    const long long batch = std::max(1LL, static_cast<long long>(std::ceil(1e-3 / std::max(first, 1e-9))));
    std::vector<double> wall, cpu;
    const auto begin = Clock::now();
    Timing timing;
    while (static_cast<int>(wall.size()) < minBatches || secondsSince(begin) < budgetSeconds) {
        const double cpuStart = threadCpuSeconds();
        start = Clock::now();
        for (long long i = 0; i < batch; ++i) operation();
        wall.push_back(secondsSince(start) / static_cast<double>(batch));
        cpu.push_back((threadCpuSeconds() - cpuStart) / static_cast<double>(batch));
        timing.calls += batch;
        if (wall.size() >= 10000) break;
    }
    timing.medianMs = 1e3 * median(wall);
    timing.minMs = 1e3 * *std::min_element(wall.begin(), wall.end());
    timing.cpuMedianMs = 1e3 * median(cpu);
    return timing;
}

// --- machine ---

namespace {

std::string firstLineWith(const char* file, std::string_view key)
{
    std::ifstream in(file);
    std::string line;
    while (std::getline(in, line))
        if (line.starts_with(key)) {
            const auto colon = line.find(':');
            if (colon == std::string::npos) return {};
            const auto begin = line.find_first_not_of(" \t", colon + 1);
            return begin == std::string::npos ? std::string() : line.substr(begin);
        }
    return {};
}

// A "Key:   123 kB" line of a /proc file, in kB (0 when absent).
double kbIn(const char* file, std::string_view key)
{
    const std::string value = firstLineWith(file, key);
    return value.empty() ? 0.0 : std::strtod(value.c_str(), nullptr);
}

std::string osName()
{
    std::ifstream in("/etc/os-release");
    std::string line;
    while (std::getline(in, line))
        if (line.starts_with("PRETTY_NAME=")) {
            std::string name = line.substr(12);
            std::erase(name, '"');
            return name;
        }
    return {};
}

}  // namespace

std::vector<double> loadAverage()
{
    std::ifstream in("/proc/loadavg");
    std::vector<double> load(3);
    if (!(in >> load[0] >> load[1] >> load[2])) return {};
    return load;
}

Json machineDescription()
{
    Json m = Json::object();
    m["cores"] = static_cast<int>(std::thread::hardware_concurrency());
    m["cpu"] = firstLineWith("/proc/cpuinfo", "model name");
    m["memory_gb"] = std::round(kbIn("/proc/meminfo", "MemTotal") / (1024.0 * 1024.0) * 10.0) / 10.0;
#if defined(__clang__)
    m["compiler"] = fmt::format("clang {}", __clang_version__);
#elif defined(__GNUC__)
    m["compiler"] = fmt::format("g++ {}", __VERSION__);
#else
    m["compiler"] = "unknown";
#endif
    m["build_type"] = RIG_BENCH_BUILD_TYPE;
    m["cxx_flags"] = RIG_BENCH_CXX_FLAGS;
#ifdef NDEBUG
    m["assertions"] = false;
#else
    m["assertions"] = true;
#endif
    m["eigen"] = fmt::format("{}.{}.{}", EIGEN_WORLD_VERSION, EIGEN_MAJOR_VERSION, EIGEN_MINOR_VERSION);
    m["tbb"] = TBB_VERSION_STRING;
    m["os"] = osName();
    Json load = Json::array();
    for (const double l : loadAverage()) load.push_back(l);
    m["load_average_at_start"] = std::move(load);
    char date[32] = {};
    const std::time_t now = std::time(nullptr);
    std::strftime(date, sizeof date, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&now));
    m["date"] = std::string(date);
    return m;
}

// --- memory ---

double residentMb() { return kbIn("/proc/self/status", "VmRSS") / 1024.0; }
double peakResidentMb() { return kbIn("/proc/self/status", "VmHWM") / 1024.0; }

double heapInUseMb()
{
    const struct mallinfo2 info = mallinfo2();
    return static_cast<double>(info.uordblks + info.hblkhd) / (1024.0 * 1024.0);
}

bool resetPeakResident()
{
    malloc_trim(0);
    std::ofstream out("/proc/self/clear_refs");
    out << "5";
    out.flush();
    return static_cast<bool>(out);
}

// --- fits ---

std::optional<double> growthExponent(std::span<const double> x, std::span<const double> y)
{
    std::vector<std::pair<double, double>> points;
    for (std::size_t i = 0; i < std::min(x.size(), y.size()); ++i)
        if (x[i] > 0 && y[i] > 0 && std::isfinite(x[i]) && std::isfinite(y[i]))
            points.emplace_back(std::log(x[i]), std::log(y[i]));
    if (points.size() < 2) return std::nullopt;
    double mx = 0, my = 0;
    for (const auto& [a, b] : points) {
        mx += a;
        my += b;
    }
    mx /= static_cast<double>(points.size());
    my /= static_cast<double>(points.size());
    double sxx = 0, sxy = 0;
    for (const auto& [a, b] : points) {
        sxx += (a - mx) * (a - mx);
        sxy += (a - mx) * (b - my);
    }
    if (!(sxx > 1e-12)) return std::nullopt;
    return sxy / sxx;
}

std::string shellQuote(const std::string& s)
{
    std::string out = "'";
    for (const char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
    return out + "'";
}

}  // namespace rig::bench
