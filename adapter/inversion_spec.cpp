#include "adapter/inversion_spec.h"

#include <cerrno>
#include <cstring>
#include <fstream>
#include <optional>
#include <sstream>

#include <fmt/format.h>
#include <yaml-cpp/depthguard.h>
#include <yaml-cpp/yaml.h>

#include "core/error.h"
#include "core/parse_number.h"

namespace rig {
namespace {

// set: {PLUG: VALUE, ...}: plugs held at a value while learning.
template <class At>
void readSet(InversionSpec& spec, const YAML::Node& set, const At& at)
{
    if (!set.IsMap())
        throw Error(
            fmt::format("{}: 'set' must be a map of plugs to numbers, e.g. set: {{L_leg_settings.ikFk: 1}}", at(set)));
    for (const auto& entry : set) {
        if (!entry.first.IsScalar() || entry.first.Scalar().empty())
            throw Error(fmt::format("{}: a key of 'set' is a plug name (node.attribute)", at(entry.first)));
        const std::string plug = entry.first.Scalar();
        const YAML::Node& v = entry.second;
        const auto value = v.IsScalar() ? parseFiniteNumber(v.Scalar()) : std::nullopt;
        if (!value)
            throw Error(
                fmt::format("{}: 'set' holds {} at {}, not a number; give a finite number in the rig file's "
                            "units (degrees for angles)",
                            at(v.IsNull() ? entry.first : v), messageExcerpt(plug),
                            v.IsScalar() ? "'" + messageExcerpt(v.Scalar()) + "'"
                            : v.IsNull() ? std::string("nothing")
                                         : std::string("a list or a map")));
        if (!spec.setPlaces.emplace(plug, at(entry.first)).second)
            throw Error(fmt::format("{}: 'set' names {} twice; give it once", at(entry.first), messageExcerpt(plug)));
        spec.set.push_back({plug, *value});
    }
}

// ranges: {GLOB: [MIN, MAX], ...}: where controls without declared limits are learned.
template <class At>
void readRanges(InversionSpec& spec, const YAML::Node& ranges, const At& at)
{
    const std::string example = "e.g. ranges: {'[LR]_knee_ctrl.rotateX': [-90, 160]}";
    if (!ranges.IsMap())
        throw Error(
            fmt::format("{}: 'ranges' must be a map of parameter globs to [min, max], {}", at(ranges), example));
    for (const auto& entry : ranges) {
        if (!entry.first.IsScalar() || entry.first.Scalar().empty())
            throw Error(fmt::format("{}: a key of 'ranges' is a parameter glob, {}", at(entry.first), example));
        const YAML::Node& v = entry.second;
        std::optional<double> low, high;
        if (v.IsSequence() && v.size() == 2 && v[0].IsScalar() && v[1].IsScalar()) {
            low = parseFiniteNumber(v[0].Scalar());
            high = parseFiniteNumber(v[1].Scalar());
        }
        if (!low || !high || !(*low < *high))
            throw Error(
                fmt::format("{}: 'ranges' gives {} no [min, max] of two finite numbers with min < max "
                            "(the rig file's units, degrees for angles), {}",
                            at(v.IsNull() ? entry.first : v), messageExcerpt(entry.first.Scalar()), example));
        spec.ranges.push_back({entry.first.Scalar(), *low, *high});
    }
}

// A name as a single-quoted YAML scalar: Maya's '|' and ':' and a glob's '[' stay text.
std::string quoted(const std::string& text)
{
    std::string out = "'";
    for (const char c : text) out += c == '\'' ? std::string("''") : std::string(1, c);
    return out + "'";
}

std::string listYaml(const std::string& key, const std::vector<std::string>& names, bool automatic)
{
    if (automatic && names.empty()) return key + ": auto\n";
    if (names.empty() && !automatic) return {};
    std::string out = key + ":\n";
    if (automatic) out += "  - auto\n";
    for (const std::string& name : names) out += "  - " + quoted(name) + "\n";
    return out;
}

}  // namespace

std::string inversionSpecYaml(const InversionSpec& spec, const std::vector<std::string>& header)
{
    std::string out;
    for (const std::string& line : header) out += line.empty() ? "#\n" : "# " + line + "\n";
    out += listYaml("params", spec.params, spec.autoParams);
    out += listYaml("outputs", spec.outputs, spec.autoOutputs);
    if (spec.autoHelpers || spec.noHelpers) out += fmt::format("helpers: {}\n", spec.autoHelpers ? "auto" : "none");
    else out += listYaml("helpers", spec.helpers, false);
    if (!spec.set.empty()) out += "set:\n";
    for (const HeldPlug& h : spec.set) out += fmt::format("  {}: {}\n", quoted(h.plug), h.value);
    if (!spec.ranges.empty()) out += "ranges:\n";
    for (const auto& r : spec.ranges) out += fmt::format("  {}: [{}, {}]\n", quoted(r.glob), r.min, r.max);
    return out;
}

InversionSpec readInversionSpec(const std::filesystem::path& path)
{
    const std::string file = path.string();
    InversionSpec spec;
    // Checked before reading: a folder reads as a stream error, a FIFO or a device never ends.
    std::error_code ec;
    const auto status = std::filesystem::status(file, ec);
    if (!std::filesystem::exists(status)) throw Error(fmt::format("{}: no such spec file; check the path", file));
    if (std::filesystem::is_directory(status))
        throw Error(fmt::format(
            "{}: is a folder; give a spec file ('params:' and 'outputs:', lists of globs, and 'set:', a map)", file));
    if (!std::filesystem::is_regular_file(status))
        throw Error(fmt::format("{}: is not a regular file (a device or a pipe?); give a spec file", file));
    std::ifstream in(file, std::ios::binary);
    if (!in) throw Error(fmt::format("{}: cannot read it ({}); check its permissions", file, std::strerror(errno)));
    std::ostringstream text;
    text << in.rdbuf();
    YAML::Node root;
    try {
        root = YAML::Load(text.str());
    }
    catch (const YAML::DeepRecursion& e) {
        throw Error(
            fmt::format("{}: lists and maps nested more than {} levels deep; a spec nests two levels, so the "
                        "file is damaged",
                        formatMark({file, e.mark.line + 1, e.mark.column + 1}), e.depth() - 1));
    }
    catch (const YAML::ParserException& e) {
        throw Error(
            fmt::format("{}: YAML syntax error: {}", formatMark({file, e.mark.line + 1, e.mark.column + 1}), e.msg));
    }
    const auto at = [&](const YAML::Node& n) { return formatMark({file, n.Mark().line + 1, n.Mark().column + 1}); };
    if (!root.IsMap())
        throw Error(fmt::format(
            "{}: a spec is a map with 'params:' (and 'outputs:'), lists of globs (and 'set:', a map)", at(root)));
    const std::string keys = "a spec has 'params:', 'outputs:', 'helpers:', 'set:' and 'ranges:'";
    for (const auto& entry : root) {
        if (!entry.first.IsScalar())
            throw Error(fmt::format("{}: a key of a spec is a list or a map; {}", at(entry.first), keys));
        const std::string key = entry.first.Scalar();
        if (key == "set") {
            readSet(spec, entry.second, at);
            continue;
        }
        if (key == "ranges") {
            readRanges(spec, entry.second, at);
            continue;
        }
        if (key == "helpers" && entry.second.IsScalar() &&
            (entry.second.Scalar() == "auto" || entry.second.Scalar() == "none")) {
            (entry.second.Scalar() == "auto" ? spec.autoHelpers : spec.noHelpers) = true;
            continue;
        }
        bool* const autoFlag = key == "params" ? &spec.autoParams : key == "outputs" ? &spec.autoOutputs : nullptr;
        if (autoFlag && entry.second.IsScalar() && entry.second.Scalar() == "auto") {
            *autoFlag = true;
            continue;
        }
        auto* list = key == "params"    ? &spec.params
                     : key == "outputs" ? &spec.outputs
                     : key == "helpers" ? &spec.helpers
                                        : nullptr;
        if (!list) throw Error(fmt::format("{}: unknown key '{}'; {}", at(entry.first), messageExcerpt(key), keys));
        if (!entry.second.IsSequence())
            throw Error(fmt::format("{}: '{}' must be a list of globs or 'auto'", at(entry.second), key));
        for (const auto& glob : entry.second) {
            if (!glob.IsScalar() || glob.Scalar().empty())
                throw Error(fmt::format("{}: '{}' must be a list of globs", at(glob), key));
            if (autoFlag && glob.Scalar() == "auto") {
                *autoFlag = true;
                continue;
            }
            list->push_back(glob.Scalar());
            spec.places.emplace(glob.Scalar(), at(glob));
        }
    }
    return spec;
}

}  // namespace rig
