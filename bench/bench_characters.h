#pragma once
// rig-bench's random_characters row (issue #46's goal: on random characters built with the production constructions
// of Maya legs, in IK mode, the solve within 3 times the FK spec's time). Each character of the generator
// (bench/random_character.h) in FK and in IK mode (Character::modeRig, modeSpec), learned as rig-learn learns it; a
// smooth random clip of the real rig's own poses in IK mode inverted in both modes as rig-invert inverts a clip (the
// same targets: the legs' FK twin reaches every pose of the IK legs), and each mode's own clip too.

#include <filesystem>
#include <functional>
#include <string_view>

#include "bench/bench_common.h"

namespace rig::bench {

struct CharactersBenchOptions {
    int perConstruction = 2;   // legged characters per construction (Construction)
    int randomCharacters = 2;  // and randomCharacter's (arms behind switches, eyes): 0 for none
    int frames = 60;           // frames of each clip
    unsigned seed = 4646;      // the characters' (the clips have their own streams)
};

// Null when o.perConstruction and o.randomCharacters are both 0. Rig files and specs go to `workDir`; `log` says each
// step (may be empty). JSON: per construction (and over issue #46's), for each mode the characters fully modelled,
// the unmodelled outputs, the frames reached on the real rig and ms per frame (wall and thread CPU) on its own clip,
// FK's on IK's clip, and the ratios IK/FK.
Json randomCharactersJson(const CharactersBenchOptions& o, const std::filesystem::path& workDir,
                          const std::function<void(std::string_view)>& log);

}  // namespace rig::bench
