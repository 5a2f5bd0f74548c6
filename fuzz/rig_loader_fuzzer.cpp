// libFuzzer target: rig files from arbitrary bytes. loadGraphText must either build a graph or throw
// rig::Error (a user's mistake, one line); a graph that loads is then evaluated, serially and in
// parallel, where a node may throw rig::Error too (a missing clip, a NaN into an enum). Anything else
// (another exception, a crash, a sanitizer report, a timeout, memory past the limit) is a bug.
// scripts/fuzz.sh runs it; docs/robustness.md.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "core/error.h"
#include "fuzz/evaluate_loaded.h"
#include "graph/yaml_loader.h"
#include "nodes/builtin_nodes.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    static const auto registry = rig::makeBuiltinRegistry();
    const std::string_view text(reinterpret_cast<const char*>(data), size);
    std::unique_ptr<rig::Graph> graph;
    try {
        graph = rig::loadGraphText(text, "fuzz.yaml", registry);
    }
    catch (const rig::Error&) {
        return 0;
    }
    rig::fuzz::evaluateLoaded(*graph);
    return 0;
}
