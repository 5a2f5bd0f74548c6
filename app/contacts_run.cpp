#include "app/contacts_run.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include "core/error.h"
#include "core/input_file.h"

namespace rig::app {
namespace {

constexpr InputFileKind contactsFileKind{"contacts file", "give the path of a contacts file (YAML or JSON)", 16u << 20,
                                         "give fewer contacts per file"};

std::string where(const std::string& file, const YAML::Node& node)
{
    const auto mark = node.Mark();
    return mark.line < 0 ? file : formatMark({file, mark.line + 1, mark.column + 1});
}

YAML::Node parseContacts(const std::string& file)
{
    const std::string text = readInputFile(file, contactsFileKind);
    try {
        return YAML::Load(text);
    }
    catch (const YAML::Exception& e) {
        throw Error(
            fmt::format("{}: YAML syntax error: {}; a contacts file maps joints to frame ranges "
                        "(LeftFoot: [[1, 40]])",
                        formatMark({file, e.mark.line + 1, e.mark.column + 1}), e.msg));
    }
}

// The clip index of frame number `node` of a range.
int frameIndex(const YAML::Node& node, const std::string& file, const TargetClip& clip)
{
    double number = 0.0;
    if (!node.IsScalar() || !YAML::convert<double>::decode(node, number) || !std::isfinite(number))
        throw Error(fmt::format("{}: a frame must be a number in the clip's numbering", where(file, node)));
    const auto found = std::find(clip.frameNumbers.begin(), clip.frameNumbers.end(), number);
    if (found == clip.frameNumbers.end())
        throw Error(fmt::format("{}: {} has no frame {} (its frames are {} to {})", where(file, node), clip.file,
                                number, clip.frameNumbers.front(), clip.frameNumbers.back()));
    return static_cast<int>(found - clip.frameNumbers.begin());
}

int outputNamed(const YAML::Node& key, const std::string& file, const Approximation& a, const ClipTargets& targets)
{
    const std::string name = key.IsScalar() ? key.Scalar() : std::string();
    for (std::size_t k = 0; k < a.outputs.size(); ++k) {
        if (a.outputs[k].name != name) continue;
        if (std::none_of(targets.frames.begin(), targets.frames.end(), [&](const auto& f) { return f[k].active; }))
            throw Error(fmt::format("{}: '{}' has no target in the clip; a contact holds a joint the clip moves",
                                    where(file, key), messageExcerpt(name)));
        return static_cast<int>(k);
    }
    throw Error(
        fmt::format("{}: '{}' is not an output of the approximation; name a joint the clip targets "
                    "(LeftFoot)",
                    where(file, key), messageExcerpt(name)));
}

std::vector<Contact> contactsFile(const std::string& file, const Approximation& a, const TargetClip& clip,
                                  const ClipTargets& targets)
{
    const YAML::Node root = parseContacts(file);
    if (!root.IsMap())
        throw Error(fmt::format("{}: a contacts file maps joints to lists of frame ranges (LeftFoot: [[1, 40]])",
                                where(file, root)));
    std::vector<Contact> contacts;
    for (const auto& entry : root) {
        const int output = outputNamed(entry.first, file, a, targets);
        if (!entry.second.IsSequence())
            throw Error(fmt::format("{}: '{}' must have a list of frame ranges [first, last] ([[1, 40], [81, 120]])",
                                    where(file, entry.second.IsNull() ? entry.first : entry.second),
                                    messageExcerpt(entry.first.Scalar())));
        for (const auto& range : entry.second) {
            if (!range.IsSequence() || range.size() != 2)
                throw Error(
                    fmt::format("{}: a frame range is [first, last], two frames of the clip", where(file, range)));
            const int first = frameIndex(range[0], file, clip), last = frameIndex(range[1], file, clip);
            if (first > last)
                throw Error(fmt::format("{}: frame range [{}, {}] ends before it starts; give [first, last]",
                                        where(file, range), clip.frameNumbers[static_cast<std::size_t>(first)],
                                        clip.frameNumbers[static_cast<std::size_t>(last)]));
            const auto overlaps = [&](const Contact& c) {
                return c.output == output && c.first <= last && first <= c.last;
            };
            if (std::any_of(contacts.begin(), contacts.end(), overlaps))
                throw Error(fmt::format("{}: frame range overlaps another of '{}'; join them into one",
                                        where(file, range), messageExcerpt(entry.first.Scalar())));
            contacts.push_back({output, first, last});
        }
    }
    return contacts;
}

}  // namespace

std::vector<Contact> readContacts(const std::string& spec, const std::string& flag, const Approximation& approximation,
                                  const TargetClip& clip, const ClipTargets& targets)
{
    if (spec == "auto") {
        const std::vector<int> joints = contactJoints(approximation, targets);
        if (joints.empty())
            throw Error(
                fmt::format("{} auto: the clip targets no joint named like a foot; give a contacts file "
                            "naming the joints to hold",
                            flag));
        return detectContacts(targets, joints);
    }
    try {
        return contactsFile(spec, approximation, clip, targets);
    }
    catch (const Error& e) {
        throw e.in(flag);
    }
}

Json contactsJson(const ClipInversionSummary& s, const Approximation& a, std::span<const double> frameNumbers,
                  bool asked)
{
    if (!asked) return Json();
    Json each = Json::array();
    for (const ContactSlide& c : s.contacts)
        each.push_back({{"joint", a.outputs[static_cast<std::size_t>(c.output)].name},
                        {"first_frame", numberJson(frameNumbers[static_cast<std::size_t>(c.first)])},
                        {"last_frame", numberJson(frameNumbers[static_cast<std::size_t>(c.last)])},
                        {"slide_cm", numberJson(c.slideCm)}});
    return Json{{"count", s.contacts.size()},
                {"max_slide_cm", numberJson(maxSlideCm(s.contacts))},
                {"mean_slide_cm", numberJson(meanSlideCm(s.contacts))},
                {"multiplier_updates", s.contactRounds},
                {"per_contact", std::move(each)}};
}

}  // namespace rig::app
