#include "graph/suggest.h"

#include <algorithm>
#include <cctype>

#include <fmt/format.h>

namespace rig {
namespace {

// Case-insensitive edit distance counting a swap of neighbours as one edit ("jiont" is one from
// "joint"): the optimal string alignment distance.
std::size_t editDistance(std::string_view a, std::string_view b)
{
    auto same = [](char x, char y) {
        return std::tolower(static_cast<unsigned char>(x)) == std::tolower(static_cast<unsigned char>(y));
    };
    const std::size_t w = b.size() + 1;
    std::vector<std::size_t> d((a.size() + 1) * w);
    for (std::size_t i = 0; i <= a.size(); ++i) d[i * w] = i;
    for (std::size_t j = 0; j <= b.size(); ++j) d[j] = j;
    for (std::size_t i = 1; i <= a.size(); ++i)
        for (std::size_t j = 1; j <= b.size(); ++j) {
            std::size_t v = std::min({d[(i - 1) * w + j] + 1, d[i * w + j - 1] + 1,
                                      d[(i - 1) * w + j - 1] + (same(a[i - 1], b[j - 1]) ? 0 : 1)});
            if (i > 1 && j > 1 && same(a[i - 1], b[j - 2]) && same(a[i - 2], b[j - 1]))
                v = std::min(v, d[(i - 2) * w + j - 2] + 1);
            d[i * w + j] = v;
        }
    return d[a.size() * w + b.size()];
}

}  // namespace

std::string closestName(std::string_view name, const std::vector<std::string>& candidates)
{
    // A third of the name may be wrong, and never all of it ("b" is no typo of "a").
    const std::size_t allowed = std::max<std::size_t>(1, name.size() / 3);
    // Ties go to the candidate sharing more of the name's start and end ("rotatZ": "rotateZ", not "rotate").
    auto sharedEnds = [&](std::string_view c) {
        std::size_t n = 0;
        while (n < c.size() && n < name.size() && c[n] == name[n]) ++n;
        for (std::size_t k = 1; k <= c.size() && k <= name.size() && c[c.size() - k] == name[name.size() - k]; ++k) ++n;
        return n;
    };
    // A name this long is no typo of anything (and the distance would cost its length squared).
    if (name.size() > 256) return {};
    std::string best;
    std::size_t bestDistance = allowed + 1;
    for (const std::string& candidate : candidates) {
        // The distance is at least the difference of the lengths: skip what cannot be close.
        const std::size_t gap =
            candidate.size() > name.size() ? candidate.size() - name.size() : name.size() - candidate.size();
        if (gap > allowed) continue;
        const std::size_t d = editDistance(name, candidate);
        if (d >= name.size()) continue;
        if (d < bestDistance || (d == bestDistance && !best.empty() && sharedEnds(candidate) > sharedEnds(best))) {
            bestDistance = d;
            best = candidate;
        }
    }
    return best;
}

std::string didYouMean(std::string_view name, const std::vector<std::string>& candidates)
{
    const std::string best = closestName(name, candidates);
    return best.empty() ? std::string() : fmt::format("; did you mean '{}'?", best);
}

}  // namespace rig
