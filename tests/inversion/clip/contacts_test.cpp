// Contacts (inversion/clip/contacts.h, docs/retargeting.md): a synthetic walk of the biped whose feet are planted by
// construction is detected exactly, its feet held on the real rig within 0.01 cm where the other targets pull them
// off, and chunks of it give one run's values bit for bit.
#include <doctest/doctest.h>

#include <cmath>
#include <numbers>

#include "adapter/graph_rig_function.h"
#include "inversion/clip/clip_inversion.h"
#include "inversion/clip/contacts.h"
#include "inversion/model/approximation_io.h"
#include "inversion/solver_rigs.h"
#include "learned_fixtures.h"
#include "test_support.h"

using namespace rig;

namespace {

constexpr int walkFrames = 96;
constexpr int halfCycle = 24;  // frames a foot stands, then swings

struct Biped {
    Approximation a = readApproximationFile(test::bipedApproximation());
    GraphRigFunction rig{test::sourceDir() / "rigs" / "biped.yaml", rigOptionsFor(a)};
    RigBinding binding{a, rig};
};

// Which foot output (0 left, 1 right) an output follows: the foot and the joints below it; -1 for the body.
int footOf(const std::string& name)
{
    if (name.starts_with("LeftFoot") || name.starts_with("LeftToe")) return 0;
    if (name.starts_with("RightFoot") || name.starts_with("RightToe")) return 1;
    return -1;
}

// The rest pose walking forward along Z at 0.5 cm per frame; each foot stands still for halfCycle frames at the
// ground (its rest height), then swings 24 cm forward in halfCycle frames (0.96 cm per frame, 6 cm up at most), the
// right foot half a cycle after the left. The legs' other joints move with the body: the targets pull the planted
// feet along, which only a hold keeps in place.
ClipTargets walk(Biped& b)
{
    std::vector<Eigen::Matrix4d> rest;
    b.binding.evaluate(b.a.defaults(), rest);
    ClipTargets clip;
    clip.frames.assign(walkFrames, std::vector<JointTarget>(b.a.outputs.size()));
    for (int f = 0; f < walkFrames; ++f) {
        for (std::size_t k = 0; k < b.a.outputs.size(); ++k) {
            JointTarget& t = clip.frames[static_cast<std::size_t>(f)][k];
            t.active = !b.a.outputs[k].helper;
            t.world = rest[k];
            const int foot = footOf(b.a.outputs[k].name);
            if (foot < 0) {
                t.world(2, 3) += 0.5 * f;
                continue;
            }
            const int phase = f - foot * halfCycle;
            const int cycle = static_cast<int>(std::floor(phase / (2.0 * halfCycle)));
            const int within = phase - cycle * 2 * halfCycle;
            const double base = 24.0 * cycle + 12.0 * foot;
            if (within < halfCycle) {
                t.world(2, 3) += base;
            } else {
                const double s = (within - halfCycle + 1) / (halfCycle + 1.0);
                t.world(2, 3) += base + 24.0 * s;
                t.world(1, 3) += 6.0 * std::sin(std::numbers::pi * s);
            }
        }
    }
    return clip;
}

// The contacts the walk has by construction: each foot's standing frames.
std::vector<Contact> plantedByConstruction(const Approximation& a)
{
    std::vector<Contact> contacts;
    const int left = test::outputIndex(a, "LeftFoot"), right = test::outputIndex(a, "RightFoot");
    for (int first = 0; first < walkFrames; first += 2 * halfCycle) contacts.push_back({left, first, first + 23});
    for (int first = halfCycle; first < walkFrames; first += 2 * halfCycle)
        contacts.push_back({right, first, first + 23});
    return contacts;
}

}  // namespace

TEST_CASE("contacts: a synthetic walk's planted feet are detected exactly and held within 0.01 cm on the real rig")
{
    Biped b;
    const ClipTargets clip = walk(b);
    const std::vector<int> joints = contactJoints(b.a, clip);
    REQUIRE(joints == std::vector<int>{test::outputIndex(b.a, "LeftFoot"), test::outputIndex(b.a, "RightFoot")});
    const std::vector<Contact> contacts = detectContacts(clip, joints);
    const std::vector<Contact> expected = plantedByConstruction(b.a);
    REQUIRE(contacts.size() == expected.size());
    for (std::size_t i = 0; i < contacts.size(); ++i) {
        CAPTURE(i);
        CHECK(contacts[i].output == expected[i].output);
        CHECK(contacts[i].first == expected[i].first);
        CHECK(contacts[i].last == expected[i].last);
    }

    ClipInversionOptions options;
    options.contacts = contacts;
    const Solver solver(b.a, options.solver);
    std::vector<std::vector<double>> values;
    options.holdContacts = false;
    const ClipInversionSummary free = invertClip(solver, b.binding, clip, 0, walkFrames - 1, options, values);
    options.holdContacts = true;
    const ClipInversionSummary held = invertClip(solver, b.binding, clip, 0, walkFrames - 1, options, values);
    REQUIRE(free.contacts.size() == contacts.size());
    REQUIRE(held.contacts.size() == contacts.size());
    MESSAGE("foot slide on the real rig: " << maxSlideCm(free.contacts) << " cm not held, " << maxSlideCm(held.contacts)
                                           << " cm held (" << held.multiplierUpdates
                                           << " multiplier updates); mean error " << free.meanPositionErrorCm << " -> "
                                           << held.meanPositionErrorCm << " cm");
    CHECK(maxSlideCm(held.contacts) < 0.01);
    CHECK(maxSlideCm(free.contacts) > 0.1);  // the body's targets drag a foot that is not held
    // Each contact held where its target stands, on the real rig too.
    std::vector<Eigen::Matrix4d> real;
    for (const Contact& c : contacts) {
        b.binding.evaluate(values[static_cast<std::size_t>(c.last)], real);
        const auto& target = clip.frames[static_cast<std::size_t>(c.first)][static_cast<std::size_t>(c.output)];
        CHECK((real[static_cast<std::size_t>(c.output)].block<3, 1>(0, 3) - target.world.block<3, 1>(0, 3)).norm() <
              0.01);
    }
}

TEST_CASE("contacts: chunks of a walk continued from the frame before their lead-in give one run's values")
{
    Biped b;
    const ClipTargets clip = walk(b);
    ClipInversionOptions options;
    options.restartInterval = 20;
    options.contacts = detectContacts(clip, contactJoints(b.a, clip));
    const Solver solver(b.a, options.solver);
    std::vector<std::vector<double>> whole;
    const ClipInversionSummary one = invertClip(solver, b.binding, clip, 0, walkFrames - 1, options, whole);
    // 50 starts inside the left foot's second contact (48..71), its lead-in from 40 inside the right's (24..47).
    for (const int split : {30, 50}) {
        CAPTURE(split);
        std::vector<std::vector<double>> head, tail;
        invertClip(solver, b.binding, clip, 0, split - 1, options, head);
        ClipInversionOptions continued = options;
        continued.continueFrom = whole[static_cast<std::size_t>(split - split % options.restartInterval - 1)];
        const ClipInversionSummary rest = invertClip(solver, b.binding, clip, split, walkFrames - 1, continued, tail);
        REQUIRE(head.size() + tail.size() == whole.size());
        for (std::size_t f = 0; f < whole.size(); ++f)
            CHECK((f < head.size() ? head[f] : tail[f - head.size()]) == whole[f]);
        CHECK(maxSlideCm(rest.contacts) < 0.01);
    }
    CHECK(maxSlideCm(one.contacts) < 0.01);
}
