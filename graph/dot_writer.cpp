#include "graph/dot_writer.h"

#include <fmt/format.h>

namespace rig {

std::string toDot(const Graph& graph)
{
    std::string out = "digraph rig {\n  rankdir=LR;\n  node [shape=box, fontname=Helvetica];\n";
    for (NodeId n = 0; n < graph.nodeCount(); ++n)
        out += fmt::format("  n{} [label=\"{}\\n({})\"];\n", n, graph.nodeName(n), graph.nodeType(n).name());
    for (const Connection& c : graph.connections()) {
        const std::string from = graph.plugName(c.source);
        const std::string to = graph.plugName(c.destination);
        out += fmt::format("  n{} -> n{} [label=\"{} -> {}\", fontsize=9];\n", c.source.node, c.destination.node,
                           from.substr(from.find('.') + 1), to.substr(to.find('.') + 1));
    }
    out += "}\n";
    return out;
}

}  // namespace rig
