// libFuzzer target: Maya ASCII scenes from arbitrary bytes. loadMayaText must either build a graph or throw rig::Error
// (a user's mistake, one line); a graph that loads is then evaluated, serially and in parallel, where a node may throw
// rig::Error too. Anything else (another exception, a crash, a sanitizer report, a timeout) is a bug. scripts/fuzz.sh
// seeds it with the scenes of ../shared/maya and tests/corpus/maya; docs/robustness.md.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "core/error.h"
#include "fuzz/evaluate_loaded.h"
#include "graph/maya/maya_loader.h"
#include "nodes/builtin_nodes.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    static const auto registry = rig::makeBuiltinRegistry();
    const std::string_view text(reinterpret_cast<const char*>(data), size);
    std::unique_ptr<rig::Graph> graph;
    try {
        graph = rig::loadMayaText(text, "fuzz.ma", registry);
    }
    catch (const rig::Error&) {
        return 0;
    }
    rig::fuzz::evaluateLoaded(*graph);
    return 0;
}
