#include "graph/plug_glob.h"

#include <fnmatch.h>

#include <algorithm>

#include <fmt/format.h>

#include "core/error.h"

namespace rig {

std::vector<Plug> allPlugs(const Graph& graph)
{
    std::vector<Plug> plugs;
    forEachPlug(graph, [&](const Plug& p) { plugs.push_back(p); });
    return plugs;
}

namespace {

bool isIndex(std::string_view text)
{
    return !text.empty() && text.find_first_not_of("0123456789") == std::string_view::npos;
}

// Where the set opened at `open` closes, as fnmatch reads it: a ']' right after '[', '[!' or '[^' belongs to
// the set. npos when it does not close (the '[' is then a plain character).
std::size_t setEnd(std::string_view pattern, std::size_t open)
{
    std::size_t at = open + 1;
    if (at < pattern.size() && (pattern[at] == '!' || pattern[at] == '^')) ++at;
    if (at < pattern.size() && pattern[at] == ']') ++at;
    return pattern.find(']', at);
}

// The fnmatch pattern of a plug glob: `[*]` becomes "any element index", `[N]` the index N as plug names
// write it (no leading zeros), and every other bracket stays a set, copied whole. A plug name holds at most
// one index, its only ']', so the '*' in "\[[0-9]*\]" cannot run past it.
std::string fnmatchPattern(std::string_view pattern)
{
    std::string out;
    for (std::size_t at = 0; at < pattern.size(); ++at) {
        const char c = pattern[at];
        if (c == '\\' && at + 1 < pattern.size()) {
            out += pattern.substr(at++, 2);
            continue;
        }
        if (c != '[') {
            out += c;
            continue;
        }
        const auto close = pattern.find(']', at + 1);
        const auto inside = close == std::string_view::npos ? "" : pattern.substr(at + 1, close - at - 1);
        if (inside == "*" || isIndex(inside)) {
            const auto digits = inside.substr(std::min(inside.find_first_not_of('0'), inside.size() - 1));
            out += inside == "*" ? std::string("\\[[0-9]*\\]") : fmt::format("\\[{}\\]", digits);
            at = close;
            continue;
        }
        const auto end = setEnd(pattern, at);
        if (end == std::string_view::npos) {
            out += c;
            continue;
        }
        out += pattern.substr(at, end - at + 1);
        at = end;
    }
    return out;
}

}  // namespace

bool isGlobPattern(std::string_view pattern)
{
    if (pattern.find_first_of("*?") != std::string_view::npos) return true;
    // '[' starts a set unless it is an array index such as matrixIn[3].
    for (auto open = pattern.find('['); open != std::string_view::npos; open = pattern.find('[', open + 1)) {
        const auto close = pattern.find(']', open);
        if (close == std::string_view::npos) return false;
        const auto inside = pattern.substr(open + 1, close - open - 1);
        if (inside.empty() || inside.find_first_not_of("0123456789") != std::string_view::npos) return true;
    }
    return false;
}

std::vector<Plug> matchPlugs(const Graph& graph, std::string_view pattern)
{
    if (!isGlobPattern(pattern)) return {graph.plug(pattern)};
    const std::string glob = fnmatchPattern(pattern);
    std::vector<Plug> matches;
    forEachPlug(graph, [&](const Plug& p) {
        if (fnmatch(glob.c_str(), graph.plugName(p).c_str(), 0) == 0) matches.push_back(p);
    });
    if (matches.empty())
        throw Error(
            fmt::format("no plug matches '{}'; patterns look like '*.worldMatrix' or 'L_arm_*.rotate?'", pattern));
    return matches;
}

}  // namespace rig
