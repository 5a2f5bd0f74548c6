#pragma once
// Enum name lists shared by several node types.

#include <string>
#include <vector>

#include "nodes/transform_math.h"

namespace rig {

// Maya's rotateOrder enum names in index order: xyz, yzx, zxy, xzy, yxz, zyx.
inline std::vector<std::string> rotateOrderEnumNames()
{
    std::vector<std::string> names;
    for (int i = 0; auto order = rotateOrderFromIndex(i); ++i) names.emplace_back(rotateOrderName(*order));
    return names;
}

}  // namespace rig
