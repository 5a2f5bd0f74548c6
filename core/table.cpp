#include "core/table.h"

#include <algorithm>

#include <fmt/format.h>

namespace rig {

std::string alignTable(const std::vector<std::vector<std::string>>& rows, const TableStyle& style)
{
    std::vector<std::size_t> widths;
    for (const auto& row : rows)
        for (std::size_t i = 0; i < row.size(); ++i) {
            if (widths.size() <= i) widths.push_back(0);
            widths[i] = std::max(widths[i], row[i].size());
        }
    std::string out;
    for (const auto& row : rows) {
        std::string line = style.indent;
        for (std::size_t i = 0; i < row.size(); ++i) {
            const bool left = i < style.align.size() && style.align[i] == Align::left;
            line += i ? "  " : "";
            line += left ? fmt::format("{:<{}}", row[i], widths[i]) : fmt::format("{:>{}}", row[i], widths[i]);
        }
        while (!line.empty() && line.back() == ' ') line.pop_back();
        out += line + "\n";
    }
    return out;
}

}  // namespace rig
