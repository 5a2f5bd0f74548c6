#pragma once
// Random production-style characters (the developers' guide: "test on rigs you did not tune for"): a whole rig
// combining the constraint families of issues #32 and #46 as rigs/creature.yaml and production Maya rigs build
// them (IK arms with and without poles behind held ikFk switches, aimed eyes, forearm twist shares, a spine bend
// shared by fractions, finger curls; IK legs under reverse feet, orient-constrained ends, three bones, FK/IK blends
// through constraints, space switches, ikSCsolver chains), each part at random, written as a rig file and a spec.
// The tests (tests/inversion/learn/random_character_test.cpp) learn and solve them; rig-bench's random_characters
// row times their IK mode against their FK mode (bench_characters.h).

#include <array>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "adapter/graph_rig_function.h"
#include "inversion/clip/clip_inversion.h"
#include "inversion/clip/rig_binding.h"

namespace rig::bench {

// What the generator chose, for messages and for the family counts it expects.
struct CharacterParts {
    int spineJoints = 0, ikArms = 0, fkArms = 0, eyes = 0;
    std::vector<std::string> rigidIkSides;  // the IK arms without stretch ("L_", "R_")
    std::string summary;
};

struct Character {
    std::string rig, spec;
    std::array<std::string, 2> specAt;  // every switch held at FK, at IK
    CharacterParts parts;
    std::vector<Eigen::Matrix4d> rest;  // the outputs' rest worlds as the builder placed them
    // The whole character in FK and in IK mode, as rig and spec: every limb's controls those of one mode, where
    // `spec` keeps each arm's mode as drawn. FK: every switch held at FK with every arm's FK controls the
    // parameters, and the legs (which have no FK controls) an FK twin of the rig: the same joints, each turned by a
    // control of its own, no IK, reverse foot, constraint or space. IK: `rig`, every switch held at IK with every
    // arm's IK controls the parameters. The outputs are the same joints in the same order in both.
    std::array<std::string, 2> modeRig, modeSpec;
};

// The constructions of production Maya rigs the legged characters add (issue #46), one forced per character.
enum class Construction { reverseFoot, orientEnd, threeBones, constraintBlend, spaceSwitch, singleChain };

// A body with one or two IK legs where `forced` is drawn at random and
// the rest of each leg is plain: two bones, an ikHandle or a mayaIkHandle, a pole or none.
Character leggedCharacter(std::mt19937& rng, Construction forced);

// A body with one or two arms (IK or FK behind their switches) and one or two aimed eyes.
Character randomCharacter(std::mt19937& rng);

// A rig file and its spec written to `dir` as NAME.yaml and NAME.spec.yaml, loaded as rig-learn loads them (helper
// frames found); `rigFile` is set to the rig file's path.
GraphRigFunction loadCharacterRig(const std::string& rig, const std::string& spec, const std::filesystem::path& dir,
                                  const std::string& name, std::filesystem::path& rigFile);

// The character's rig and spec written to `dir`, loaded as rig-learn loads them (helper frames found).
GraphRigFunction loadCharacter(const Character& character, const std::filesystem::path& dir, int index,
                               std::filesystem::path& rigFile);

// A smooth random clip of `frames` poses of the real rig: each modelled parameter a sum of two slow sines (a quarter
// to a cycle and a quarter over the clip, random phases) within 0.4 of its range about its default, the parameters
// the approximation left out at their defaults (RigBinding). Targets on every joint output at the real rig's worlds,
// as a clip of that rig's animation gives them.
ClipTargets smoothClip(const Approximation& a, RigBinding& binding, int frames, std::mt19937& rng);

}  // namespace rig::bench
