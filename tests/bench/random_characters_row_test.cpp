// rig-bench's random_characters row (bench/bench_characters.h) and the characters' FK and IK modes it times
// (bench/random_character.h, Character::modeRig and modeSpec). The row's figures are rig-bench's run
// (docs/performance.md).
#include <doctest/doctest.h>

#include <algorithm>
#include <array>
#include <random>
#include <vector>

#include <fmt/format.h>

#include "bench/bench_characters.h"
#include "bench/random_character.h"
#include "test_support.h"

using namespace rig;

namespace {

// The rest worlds of a character in one mode, and its outputs' names.
std::vector<Eigen::Matrix4d> restOf(const bench::Character& character, int mode, const std::filesystem::path& dir,
                                    const std::string& name, std::vector<std::string>& outputs)
{
    std::filesystem::path rigFile;
    GraphRigFunction rig =
        bench::loadCharacterRig(character.modeRig[static_cast<std::size_t>(mode)],
                                character.modeSpec[static_cast<std::size_t>(mode)], dir, name, rigFile);
    std::vector<double> rest;
    for (const RigParameter& p : rig.parameters()) rest.push_back(p.defaultValue);
    std::vector<Eigen::Matrix4d> worlds;
    rig.evaluate(rest, worlds);
    outputs = rig.outputs();
    return worlds;
}

}  // namespace

TEST_CASE("random characters: each character's FK mode (the legs' FK twin) rests where its IK mode does")
{
    std::mt19937 rng(46);
    const auto dir = test::scratchDir("random_characters_modes");
    std::vector<bench::Character> characters;
    for (const bench::Construction c :
         {bench::Construction::reverseFoot, bench::Construction::orientEnd, bench::Construction::threeBones,
          bench::Construction::constraintBlend, bench::Construction::spaceSwitch, bench::Construction::singleChain})
        characters.push_back(bench::leggedCharacter(rng, c));
    characters.push_back(bench::randomCharacter(rng));
    for (std::size_t c = 0; c < characters.size(); ++c) {
        CAPTURE(characters[c].parts.summary);
        std::array<std::vector<std::string>, 2> outputs;
        const auto fk = restOf(characters[c], 0, dir, fmt::format("c{}.fk", c), outputs[0]);
        const auto ik = restOf(characters[c], 1, dir, fmt::format("c{}.ik", c), outputs[1]);
        // The spec's joints, first in both; IK mode adds the helper frames its constraints read.
        REQUIRE(outputs[0].size() <= outputs[1].size());
        CHECK(std::equal(outputs[0].begin(), outputs[0].end(), outputs[1].begin()));
        double worst = 0.0;
        for (std::size_t k = 0; k < fk.size(); ++k) worst = std::max(worst, (fk[k] - ik[k]).cwiseAbs().maxCoeff());
        // Equal up to the rounding of the file's nine digits through the IK.
        CHECK(worst < 1e-5);
    }
}

TEST_CASE("rig-bench random_characters: a character learned and its clip inverted in both modes")
{
    const auto dir = test::scratchDir("random_characters_row");
    bench::CharactersBenchOptions o;
    o.perConstruction = 0;
    o.randomCharacters = 1;
    o.frames = 10;
    const bench::Json row = bench::randomCharactersJson(o, dir, {});
    INFO(row.dump());
    REQUIRE(row.at("constructions").size() == 1);
    const bench::Json& group = row.at("constructions")[0];
    for (const char* mode : {"fk", "ik"}) {
        const bench::Json& m = group.at(mode);
        CHECK(m.at("characters") == 1);
        CHECK(m.at("unmodelled_outputs") == 0);
        CHECK(m.at("frames") == 10);
        CHECK(m.at("reached") == 10);  // each mode's own poses
        CHECK(m.at("parameters").get<int>() > 0);
        CHECK(m.at("cpu_ms_per_frame").get<double>() > 0.0);
        CHECK(m.at("retried_frames").get<int>() >= 0);
        CHECK(m.at("mean_iterations").get<double>() > 0.0);
    }
    CHECK(group.at("fk_on_ik_clip").at("frames") == 10);
    CHECK(group.at("ratio").get<double>() > 0.0);
    // The totals are over issue #46's leg constructions, which this run has none of.
    CHECK(row.at("ik").at("characters") == 0);
    CHECK(row.at("ratio").is_null());
    o.randomCharacters = 0;
    CHECK(bench::randomCharactersJson(o, dir, {}).is_null());
}
