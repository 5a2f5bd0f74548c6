#pragma once
// Text tables to read on a terminal: columns padded to their widest cell, written once for every tool.

#include <string>
#include <vector>

namespace rig {

enum class Align { left, right };

struct TableStyle {
    std::string indent;        // before each row
    std::vector<Align> align;  // per column; columns past its end are right-aligned (numbers)
};

// Rows of cells, columns two spaces apart, trailing spaces removed; each row ends with a newline.
std::string alignTable(const std::vector<std::vector<std::string>>& rows, const TableStyle& style = {});

}  // namespace rig
