#include "nodes/contact_ranges.h"

#include <cmath>
#include <filesystem>

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include "core/input_file.h"
#include "nodes/clips/target_clip.h"

namespace rig {
namespace {

constexpr InputFileKind contactsFileKind{"a contacts file", "a contacts file (YAML or JSON)", 16u << 20,
                                         "give fewer contacts per file"};

SourceMark markOf(const std::string& file, const YAML::Node& node)
{
    const auto mark = node.Mark();
    return mark.line < 0 ? SourceMark{file, 0, 0} : SourceMark{file, mark.line + 1, mark.column + 1};
}

double frameNumber(const std::string& file, const YAML::Node& node)
{
    double number = 0.0;
    if (!node.IsScalar() || !YAML::convert<double>::decode(node, number) || !std::isfinite(number))
        throw Error(
            fmt::format("{}: a frame must be a number in the clip's numbering", formatMark(markOf(file, node))));
    return number;
}

}  // namespace

std::vector<ContactRange> readContactRanges(const std::string& file)
{
    const std::string text = readInputFile(file, contactsFileKind);
    // YAML reads a JSON file too, but would take trailing text as more of it.
    if (std::filesystem::path(file).extension() == ".json")
        checkStrictJson(text, file, "a contacts file maps joints to frame ranges ({\"LeftFoot\": [[1, 40]]})");
    YAML::Node root;
    try {
        root = YAML::Load(text);
    }
    catch (const YAML::Exception& e) {
        throw Error(
            fmt::format("{}: YAML syntax error: {}; a contacts file maps joints to frame ranges "
                        "(LeftFoot: [[1, 40]])",
                        formatMark({file, e.mark.line + 1, e.mark.column + 1}), e.msg));
    }
    if (!root.IsMap())
        throw Error(fmt::format("{}: a contacts file maps joints to lists of frame ranges (LeftFoot: [[1, 40]])",
                                formatMark(markOf(file, root))));
    std::vector<ContactRange> ranges;
    for (const auto& entry : root) {
        const std::string joint = entry.first.IsScalar() ? entry.first.Scalar() : std::string();
        if (!entry.second.IsSequence())
            throw Error(fmt::format("{}: '{}' must have a list of frame ranges [first, last] ([[1, 40], [81, 120]])",
                                    formatMark(markOf(file, entry.second.IsNull() ? entry.first : entry.second)),
                                    messageExcerpt(joint)));
        for (const auto& range : entry.second) {
            if (!range.IsSequence() || range.size() != 2)
                throw Error(fmt::format("{}: a frame range is [first, last], two frames of the clip",
                                        formatMark(markOf(file, range))));
            ranges.push_back({joint, frameNumber(file, range[0]), frameNumber(file, range[1]),
                              markOf(file, entry.first), markOf(file, range), markOf(file, range[0]),
                              markOf(file, range[1])});
        }
    }
    return ranges;
}

}  // namespace rig
