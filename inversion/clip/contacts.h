#pragma once
// Contacts: frames during which a joint stays planted (a foot on the ground), detected from a clip's targets or given
// as frame ranges, held by the solve with a priority above the other targets, and measured on the real rig
// (docs/retargeting.md, Contacts).
//
// The hold. During a contact the joint's position is held at its target's position at the contact's first frame. The
// hold comes from the targets, not from a previous solve, so that it does not depend on where a run or a chunk starts:
// chunks of a clip (rig-invert --frames with --after, rig-batch's shards) hold a contact that spans their boundary at
// the same position, and still give one run's values bit for bit. The priority is an augmented Lagrangian: the
// joint's position rows get the weight `contactWeight` and a target shifted by the multiplier's estimate, updated by
// the rows' residual after each solve (the method of multipliers) until the held position is met within
// `contactToleranceCm` on the approximation. The solve then minimizes the other targets subject to the hold (the
// multiplier carries the hold's force), which no finite weight alone does.

#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace rig {

struct ClipTargets;
struct JointTarget;
class Approximation;

// A joint planted over clip frames [first, last] (0-based clip indices, inclusive).
struct Contact {
    int output = -1;  // the approximation's output
    int first = 0;
    int last = 0;
};

// Contact detection from a clip's targets: a joint is planted at a frame where its target's height (the clip's up
// axis, Y, in cm) is at most `heightCm` above its lowest over the clip and its target moves at most `speedCmPerFrame`
// (cm per frame at the clip's rate) from the frame before or to the frame after (either: a contact's first and last
// frames, where the foot lands and lifts off, count); runs of at least `minFrames` such frames are contacts.
struct ContactDetection {
    double heightCm = 5.0;
    double speedCmPerFrame = 0.5;
    int minFrames = 3;
};

// The outputs `auto` detects on: the active targets whose names contain "foot" (any case; the CMU skeleton's ankles,
// LeftFoot and RightFoot). A toe held with its foot would ask for the clip's foot length, which a rig of other
// proportions does not have; a contacts file may name any joint.
std::vector<int> contactJoints(const Approximation& approximation, const ClipTargets& targets);

// The contacts of `outputs` in the whole clip (never only the frames a chunk reports: chunks agree), by output then
// frame.
std::vector<Contact> detectContacts(const ClipTargets& targets, std::span<const int> outputs,
                                    const ContactDetection& detection = {});

// The solve's hold (see above).
inline constexpr double contactWeight = 100.0;      // per cm of the held position's error
inline constexpr double contactToleranceCm = 1e-4;  // on the approximation; the real rig is within ~1e-3 cm of it
inline constexpr int contactSolves = 8;             // solves at most per held frame

// A contact held at one frame: its index among the contacts, its output, the position held and the multiplier's shift
// of the target (cm).
struct ContactHold {
    int contact = -1;
    int output = -1;
    Eigen::Vector3d position = Eigen::Vector3d::Zero();
    Eigen::Vector3d shift = Eigen::Vector3d::Zero();
};

// The holds of the contacts that cover clip frame `frame` (the positions from `targets`), into `holds`, each with its
// contact's entry of `shifts` (one per contact): the multiplier of the frame before, which a warm-start chain carries
// as it carries the values (a contact's first frame and a restart start from none), so that most frames meet their
// holds in one solve.
void contactHolds(std::span<const Contact> contacts, const ClipTargets& targets, int frame,
                  std::span<const Eigen::Vector3d> shifts, std::vector<ContactHold>& holds);

// `targets` with the holds applied: each held output's position its hold plus its shift, weighted contactWeight (its
// rotation as the target asks).
void applyHolds(std::span<const ContactHold> holds, std::span<const JointTarget> targets,
                std::vector<JointTarget>& held);

// The slide of one contact on the real rig: the largest distance of its joint from its position at the contact's
// first reported frame (its first frame, unless a chunk starts inside it), over the frames reported.
struct ContactSlide {
    int output = -1;
    int first = 0;  // the contact's frames (clip indices)
    int last = 0;
    int measuredFrom = -1;  // the first frame reported (the reference's)
    // The joint's real-rig positions from measuredFrom on, a frame each: rig-batch joins a contact that spans its
    // shards into the one run's slide (joinSlides).
    std::vector<Eigen::Vector3d> positions;
    double slideCm = 0.0;
    void add(const Eigen::Vector3d& position);
};
// `later`'s slides after `slides`' (the frames after theirs): a contact in both continues, its slide measured from
// the earlier reference over both.
void joinSlides(std::vector<ContactSlide>& slides, const std::vector<ContactSlide>& later);
// The largest and the mean slide over contacts (0 with none).
double maxSlideCm(std::span<const ContactSlide> slides);
double meanSlideCm(std::span<const ContactSlide> slides);

}  // namespace rig
