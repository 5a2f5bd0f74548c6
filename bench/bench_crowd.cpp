#include "bench/bench_crowd.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <ctime>
#include <numbers>
#include <numeric>
#include <vector>

#include <fmt/format.h>
#include <Eigen/Geometry>

#include "app/eval/eval_run.h"
#include "core/error.h"
#include "graph/yaml_loader.h"
#include "nodes/clips/target_clip.h"

namespace rig::bench {
namespace {

namespace fs = std::filesystem;

constexpr double budgetMs = 1000.0 / 30.0;
// Growth stops past twice the budget (the next size would only be slower) or past this much memory.
constexpr double stopMs = 2.0 * budgetMs;
constexpr double memoryLimitMb = 8000.0;
// The lookAt put the edited head's aim on the target (no limit reached) when within this angle.
constexpr double reachedDeg = 1e-6;

// scripts/make_crowd.py COUNT, every file by its absolute path, written to the work folder.
fs::path writeCrowd(const BenchOptions& o, const fs::path& approximation, int count)
{
    const fs::path file = o.workDir / fmt::format("crowd_lookat{}.yaml", count);
    const fs::path script = o.makeRigs.parent_path() / "make_crowd.py";
    const std::string command =
        fmt::format("{} {} {} --rig {} --approximation {} --map {} --clip {} -o {}", shellQuote(o.python),
                    shellQuote(script.string()), count, shellQuote(fs::absolute(o.rig).string()),
                    shellQuote(fs::absolute(approximation).string()), shellQuote(fs::absolute(o.crowdMap).string()),
                    shellQuote(fs::absolute(o.clip).string()), shellQuote(file.string()));
    if (std::system(command.c_str()) != 0) throw Error(fmt::format("could not write a crowd: {}", command));
    return file;
}

// CPU time of the whole process (every thread), seconds: on a busy machine, what the frames cost.
double processCpuSeconds()
{
    timespec t{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
    return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

double angleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b)
{
    return std::atan2(a.cross(b).norm(), a.dot(b)) * 180.0 / std::numbers::pi;
}

// One crowd played on `threads` graph threads: each frame's wall time, and the heads' aim on the real rig.
struct CrowdPlay {
    std::vector<double> frameMs;
    double cpuMsPerFrame = 0.0;  // the process's CPU time over the timed frames, per frame (every thread)
    double lookatMaxDeg = 0.0;   // over the heads whose lookAt reached the target
    long long samples = 0;       // heads x frames measured
    long long limited = 0;       // of those, heads whose lookAt was stopped by a limit (not measured)
    double loadSeconds = 0.0;
    double memoryMb = 0.0;  // the peak resident growth, loading included
    double heldMb = 0.0;    // the heap the crowd holds while it plays
};

// Each member's edited head (the lookAt's output, in the clip's units) against its real head (the biped's
// joint after inversion, cm): the angle between the real head's aim (+Z) and the target, where the limits let
// the lookAt reach it.
void measureHeads(const std::vector<Value>& values, std::size_t first, int count, double scale, CrowdPlay& play)
{
    const Eigen::Vector3d target = std::get<Eigen::Vector3d>(values[first]);
    for (int i = 0; i < count; ++i) {
        const auto& edited = std::get<Eigen::Matrix4d>(values[first + 1 + 2 * static_cast<std::size_t>(i)]);
        const auto& head = std::get<Eigen::Matrix4d>(values[first + 2 + 2 * static_cast<std::size_t>(i)]);
        ++play.samples;
        if (angleDeg(edited.block<3, 1>(0, 2), target - edited.block<3, 1>(0, 3)) > reachedDeg) {
            ++play.limited;
            continue;
        }
        play.lookatMaxDeg =
            std::max(play.lookatMaxDeg, angleDeg(head.block<3, 1>(0, 2), scale * target - head.block<3, 1>(0, 3)));
    }
}

// Frame 1 is played untimed (it reads the approximation and starts every member cold), then `frames` frames
// in order, as graph-eval --frames plays them: every member's curves (inverter.value) and heads.
CrowdPlay playCrowd(const fs::path& file, int count, int threads, int frames, double scale)
{
    CrowdPlay play;
    resetPeakResident();
    const double before = residentMb(), heapBefore = heapInUseMb();
    const auto start = std::chrono::steady_clock::now();
    auto graph = loadGraphFile(file, app::nodeRegistry({}));
    graph->setThreads(threads);
    std::vector<Plug> plugs = app::selectPlugs(*graph, file.string(), {"*:inverter.value[*]"}, 1.0);
    app::settleLargeGraph(*graph);  // as graph-eval does before its frames
    const std::size_t first = plugs.size();
    plugs.push_back(graph->plug("camera.translate"));
    for (int i = 0; i < count; ++i) {
        plugs.push_back(graph->plug(fmt::format("c{:04d}:look.outMatrix[3]", i)));
        plugs.push_back(graph->plug(fmt::format("c{:04d}:Head.worldMatrix", i)));
    }
    app::evaluateFrame(*graph, file.string(), 1, true, plugs);
    play.loadSeconds = secondsSince(start);  // the first frame with the load, as a player starts
    double cpu = 0.0;
    std::vector<Value> values;  // kept, as a player keeps it
    const std::string name = file.string();
    for (int f = 2; f <= frames + 1; ++f) {
        const auto t0 = std::chrono::steady_clock::now();
        const double c0 = processCpuSeconds();
        app::evaluateFrame(*graph, name, f, true, plugs, values);
        cpu += processCpuSeconds() - c0;
        play.frameMs.push_back(1e3 * secondsSince(t0));
        measureHeads(values, first, count, scale, play);
    }
    play.cpuMsPerFrame = 1e3 * cpu / static_cast<double>(frames);
    play.memoryMb = peakResidentMb() - before;
    play.heldMb = heapInUseMb() - heapBefore;
    return play;
}

double percentile(std::vector<double> v, double p)
{
    std::sort(v.begin(), v.end());
    const auto rank = static_cast<std::size_t>(std::ceil(p * static_cast<double>(v.size())));
    return v[std::clamp<std::size_t>(rank, 1, v.size()) - 1];
}

Json rowJson(int count, const CrowdPlay& p)
{
    const double mean =
        std::accumulate(p.frameMs.begin(), p.frameMs.end(), 0.0) / static_cast<double>(p.frameMs.size());
    return Json{{"agents", count},
                {"frame_ms_mean", mean},
                {"frame_ms_median", percentile(p.frameMs, 0.5)},
                {"frame_ms_p99", percentile(p.frameMs, 0.99)},
                {"cpu_ms_per_frame", p.cpuMsPerFrame},
                {"cpu_ms_per_agent", p.cpuMsPerFrame / count},
                {"lookat_max_error_deg", p.samples > p.limited ? Json(p.lookatMaxDeg) : Json()},
                {"heads_measured", p.samples - p.limited},
                {"heads_at_a_limit", p.limited},
                {"load_seconds", p.loadSeconds},
                {"memory_mb", p.memoryMb},
                {"memory_held_mb", p.heldMb}};
}

// Crowds of 1, 2, 4, ... bipeds on `threads` threads, until a frame takes over twice the budget on average.
Json threadsJson(const BenchOptions& o, const fs::path& approximation, int threads, double scale)
{
    Json rows = Json::array();
    Json best;  // the largest crowd within the budget
    double worstDeg = 0.0;
    for (int count = 1; count <= o.realtimeMaxAgents; count *= 2) {
        if (o.log)
            o.log(
                fmt::format("crowd_realtime: {} bipeds on {} thread(s), {} frames", count, threads, o.realtimeFrames));
        const CrowdPlay play = playCrowd(writeCrowd(o, approximation, count), count, threads, o.realtimeFrames, scale);
        Json row = rowJson(count, play);
        worstDeg = std::max(worstDeg, play.lookatMaxDeg);
        const double mean = row.at("frame_ms_mean").get<double>();
        if (mean <= budgetMs) best = row;
        rows.push_back(std::move(row));
        if (mean > stopMs || play.memoryMb > memoryLimitMb) break;
    }
    return Json{{"threads", threads},
                {"agents_at_30fps", best.is_null() ? 0 : best.at("agents").get<int>()},
                {"per_agent_growth", perAgentGrowth(rows)},
                {"frame_ms_median", best.is_null() ? Json() : best.at("frame_ms_median")},
                {"frame_ms_p99", best.is_null() ? Json() : best.at("frame_ms_p99")},
                {"lookat_max_error_deg", worstDeg},
                {"rows", std::move(rows)}};
}

}  // namespace

Json crowdRealtimeJson(const BenchOptions& o, const fs::path& approximation)
{
    const double scale = readTargetMap(o.crowdMap).scale;
    Json byThreads = Json::array();
    for (const int threads : {1, 2}) byThreads.push_back(threadsJson(o, approximation, threads, scale));
    // The headline is the two-thread run's (the goal: 256 bipeds at 30 fps with 2 threads).
    const Json& two = byThreads.back();
    return Json{{"agents_at_30fps", two.at("agents_at_30fps")},
                {"threads", two.at("threads")},
                {"frame_ms_median", two.at("frame_ms_median")},
                {"frame_ms_p99", two.at("frame_ms_p99")},
                {"lookat_max_error_deg", two.at("lookat_max_error_deg")},
                {"budget_ms", budgetMs},
                {"frames", o.realtimeFrames},
                {"max_agents", o.realtimeMaxAgents},
                {"by_threads", std::move(byThreads)},
                {"note",
                 "scripts/make_crowd.py's crowd played through the graph (graph-eval's evaluation), each "
                 "biped's curves and head joint per frame; agents_at_30fps: the largest crowd of 1, 2, 4, "
                 "... bipeds whose mean frame time is at most 33.3 ms; lookat_max_error_deg: the real "
                 "head's aim against the target where the lookAt's limits let it reach"}};
}

Json perAgentGrowth(const Json& rows)
{
    constexpr int from = 16;  // the smallest crowd: below it a crowd's state stays in the caches
    double first = 0.0, largest = 0.0;
    int crowds = 0;
    for (const Json& row : rows) {
        if (row.at("agents").get<int>() < from) continue;
        const double perAgent = row.at("cpu_ms_per_agent").get<double>();
        if (crowds++ == 0) first = perAgent;
        largest = std::max(largest, perAgent);
    }
    return crowds >= 2 && first > 0.0 ? Json(largest / first) : Json();
}

}  // namespace rig::bench
