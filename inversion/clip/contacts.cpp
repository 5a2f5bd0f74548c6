#include "inversion/clip/contacts.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>

#include "inversion/clip/clip_inversion.h"
#include "inversion/model/approximation.h"

namespace rig {
namespace {

Eigen::Vector3d targetPosition(const ClipTargets& targets, int frame, int output)
{
    return targets.frames[static_cast<std::size_t>(frame)][static_cast<std::size_t>(output)].world.block<3, 1>(0, 3);
}

bool usable(const JointTarget& t) { return t.active && t.world.block<3, 1>(0, 3).allFinite(); }

}  // namespace

std::vector<int> contactJoints(const Approximation& approximation, const ClipTargets& targets)
{
    std::vector<int> outputs;
    for (std::size_t k = 0; k < approximation.outputs.size(); ++k) {
        std::string name = approximation.outputs[k].name;
        std::transform(name.begin(), name.end(), name.begin(), [](unsigned char c) { return std::tolower(c); });
        const bool targeted = std::any_of(targets.frames.begin(), targets.frames.end(),
                                          [&](const auto& frame) { return frame[k].active; });
        if (name.find("foot") != std::string::npos && targeted) outputs.push_back(static_cast<int>(k));
    }
    return outputs;
}

std::vector<Contact> detectContacts(const ClipTargets& targets, std::span<const int> outputs, const ContactDetection& d)
{
    std::vector<Contact> contacts;
    const int frames = static_cast<int>(targets.frames.size());
    for (const int output : outputs) {
        const auto target = [&](int f) -> const JointTarget& {
            return targets.frames[static_cast<std::size_t>(f)][static_cast<std::size_t>(output)];
        };
        double lowest = std::numeric_limits<double>::infinity();
        for (int f = 0; f < frames; ++f)
            if (usable(target(f))) lowest = std::min(lowest, target(f).world(1, 3));
        // Still towards the frame before or the one after: a contact's first frame moves little to the next, its
        // last from the one before (the foot landing and lifting off moves fast on the other side).
        const auto still = [&](int f, int g) {
            return g >= 0 && g < frames && usable(target(g)) &&
                   (targetPosition(targets, f, output) - targetPosition(targets, g, output)).norm() <=
                       d.speedCmPerFrame;
        };
        const auto planted = [&](int f) {
            return usable(target(f)) && target(f).world(1, 3) <= lowest + d.heightCm &&
                   (still(f, f - 1) || still(f, f + 1));
        };
        for (int f = 0; f < frames;) {
            if (!planted(f)) {
                ++f;
                continue;
            }
            int end = f;
            while (end + 1 < frames && planted(end + 1)) ++end;
            if (end - f + 1 >= d.minFrames) contacts.push_back({output, f, end});
            f = end + 1;
        }
    }
    return contacts;
}

void contactHolds(std::span<const Contact> contacts, const ClipTargets& targets, int frame,
                  std::span<const Eigen::Vector3d> shifts, std::vector<ContactHold>& holds)
{
    holds.clear();
    for (std::size_t i = 0; i < contacts.size(); ++i) {
        const Contact& c = contacts[i];
        if (c.first <= frame && frame <= c.last)
            holds.push_back({static_cast<int>(i), c.output, targetPosition(targets, c.first, c.output),
                             frame == c.first ? Eigen::Vector3d::Zero() : shifts[i]});
    }
}

void applyHolds(std::span<const ContactHold> holds, std::span<const JointTarget> targets,
                std::vector<JointTarget>& held)
{
    held.assign(targets.begin(), targets.end());
    for (const ContactHold& h : holds) {
        JointTarget& t = held[static_cast<std::size_t>(h.output)];
        t.active = true;
        t.world.block<3, 1>(0, 3) = h.position + h.shift;
        t.positionWeight = contactWeight;
    }
}

void ContactSlide::add(const Eigen::Vector3d& position)
{
    positions.push_back(position);
    const double d = (position - positions.front()).norm();
    if (std::isnan(d) || d > slideCm) slideCm = d;
}

void joinSlides(std::vector<ContactSlide>& slides, const std::vector<ContactSlide>& later)
{
    for (const ContactSlide& next : later) {
        auto it = std::find_if(slides.begin(), slides.end(), [&](const ContactSlide& s) {
            return s.output == next.output && s.first == next.first && s.last == next.last;
        });
        if (it == slides.end() || it->positions.empty()) {
            slides.push_back(next);
            continue;
        }
        for (const Eigen::Vector3d& p : next.positions) it->add(p);
    }
}

double maxSlideCm(std::span<const ContactSlide> slides)
{
    double worst = 0.0;
    for (const ContactSlide& s : slides)
        if (std::isnan(s.slideCm) || s.slideCm > worst) worst = s.slideCm;
    return worst;
}

double meanSlideCm(std::span<const ContactSlide> slides)
{
    double sum = 0.0;
    for (const ContactSlide& s : slides) sum += s.slideCm;
    return slides.empty() ? 0.0 : sum / static_cast<double>(slides.size());
}

}  // namespace rig
