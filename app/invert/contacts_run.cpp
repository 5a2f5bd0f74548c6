#include "app/invert/contacts_run.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "core/error.h"
#include "nodes/contact_ranges.h"

namespace rig::app {
namespace {

// The clip index of frame `number`, which a contacts file gives at `mark`.
int frameIndex(double number, const SourceMark& mark, const TargetClip& clip)
{
    const auto found = std::find(clip.frameNumbers.begin(), clip.frameNumbers.end(), number);
    if (found == clip.frameNumbers.end())
        throw Error(fmt::format("{}: {} has no frame {} (its frames are {} to {})", formatMark(mark), clip.file, number,
                                clip.frameNumbers.front(), clip.frameNumbers.back()));
    return static_cast<int>(found - clip.frameNumbers.begin());
}

int outputNamed(const ContactRange& range, const Approximation& a, const ClipTargets& targets)
{
    for (std::size_t k = 0; k < a.outputs.size(); ++k) {
        if (a.outputs[k].name != range.joint) continue;
        if (std::none_of(targets.frames.begin(), targets.frames.end(), [&](const auto& f) { return f[k].active; }))
            throw Error(fmt::format("{}: '{}' has no target in the clip; a contact holds a joint the clip moves",
                                    formatMark(range.jointMark), messageExcerpt(range.joint)));
        return static_cast<int>(k);
    }
    throw Error(
        fmt::format("{}: '{}' is not an output of the approximation; name a joint the clip targets "
                    "(LeftFoot)",
                    formatMark(range.jointMark), messageExcerpt(range.joint)));
}

std::vector<Contact> contactsFile(const std::string& file, const Approximation& a, const TargetClip& clip,
                                  const ClipTargets& targets)
{
    std::vector<Contact> contacts;
    for (const ContactRange& range : readContactRanges(file)) {
        const int output = outputNamed(range, a, targets);
        const int first = frameIndex(range.first, range.firstMark, clip);
        const int last = frameIndex(range.last, range.lastMark, clip);
        // The hold is the target's position at the first frame (inversion/clip/contacts.h): it must have one.
        const JointTarget& held = targets.frames[static_cast<std::size_t>(first)][static_cast<std::size_t>(output)];
        if (!held.active || !held.world.allFinite())
            throw Error(
                fmt::format("{}: '{}' has no finite target at frame {}, where its hold would be; start the "
                            "contact at a frame that has one",
                            formatMark(range.firstMark), messageExcerpt(range.joint), range.first));
        if (first > last)
            throw Error(fmt::format("{}: frame range [{}, {}] ends before it starts; give [first, last]",
                                    formatMark(range.rangeMark), range.first, range.last));
        const auto overlaps = [&](const Contact& c) {
            return c.output == output && c.first <= last && first <= c.last;
        };
        if (std::any_of(contacts.begin(), contacts.end(), overlaps))
            throw Error(fmt::format("{}: frame range overlaps another of '{}'; join them into one",
                                    formatMark(range.rangeMark), messageExcerpt(range.joint)));
        contacts.push_back({output, first, last});
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
                {"multiplier_updates", s.multiplierUpdates},
                {"per_contact", std::move(each)}};
}

}  // namespace rig::app
