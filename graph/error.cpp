#include "graph/error.h"

#include <fmt/format.h>

namespace rig {

std::string formatMark(const SourceMark& mark)
{
    if (mark.line <= 0) return mark.file;
    return fmt::format("{}:{}:{}", mark.file, mark.line, mark.column);
}

}  // namespace rig
