#include "bench/bench_maya.h"

#include <algorithm>
#include <chrono>

#include "core/error.h"
#include "graph/rig_file.h"
#include "nodes/builtin_nodes.h"

namespace rig::bench {

Json mayaLoadJson(const std::filesystem::path& folder)
{
    if (!std::filesystem::is_directory(folder)) return Json();
    std::vector<std::filesystem::path> scenes;
    for (const auto& entry : std::filesystem::recursive_directory_iterator(folder))
        if (entry.path().extension() == ".ma") scenes.push_back(entry.path());
    std::sort(scenes.begin(), scenes.end());
    Json rows = Json::array();
    double largestSeconds = 0.0;
    std::uintmax_t largestBytes = 0;
    const auto registry = makeBuiltinRegistry();
    for (const auto& scene : scenes) {
        Json row{{"scene", scene.filename().string()}, {"bytes", std::filesystem::file_size(scene)}};
        double best = 1e300;
        for (int run = 0; run < 3; ++run) {
            const auto start = std::chrono::steady_clock::now();
            try {
                MayaSceneInfo info;
                const auto graph = loadRigFile(scene, registry, nullptr, &info);
                row["graph_nodes"] = graph->nodeCount();
                row["refused"] = Json();
            }
            catch (const Error& e) {
                row["refused"] = e.what();
            }
            best = std::min(best, std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
        }
        row["load_seconds"] = best;
        if (row.at("bytes").get<std::uintmax_t>() > largestBytes) {
            largestBytes = row.at("bytes").get<std::uintmax_t>();
            largestSeconds = best;
        }
        rows.push_back(std::move(row));
    }
    return Json{{"scenes", std::move(rows)}, {"largest_bytes", largestBytes}, {"largest_load_seconds", largestSeconds}};
}

}  // namespace rig::bench
