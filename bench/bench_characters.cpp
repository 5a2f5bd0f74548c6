#include "bench/bench_characters.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <memory>
#include <numbers>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "bench/random_character.h"
#include "core/error.h"
#include "inversion/clip/clip_inversion.h"
#include "inversion/clip/rig_binding.h"
#include "inversion/learn/learner.h"
#include "inversion/solve/solver.h"

namespace rig::bench {
namespace {

constexpr std::array modeNames{"fk", "ik"};

// One mode's figures, summed over characters: its learning, and its inversion of a clip.
struct ModeFigures {
    int characters = 0, modelled = 0;  // characters learned, and those with every output modelled
    long long unmodelled = 0, parameters = 0;
    std::uint64_t evaluations = 0;
    double learnSeconds = 0.0;
    int frames = 0, reached = 0;
    // Where a clip's time goes: frames solved again from the initial guess (a stuck jump), and every solve's
    // iterations (Gauss-Newton and Levenberg-Marquardt, retries included).
    int retried = 0;
    long long iterations = 0;
    double solveSeconds = 0.0, solveCpuSeconds = 0.0;

    void add(const ModeFigures& m)
    {
        characters += m.characters;
        modelled += m.modelled;
        unmodelled += m.unmodelled;
        parameters += m.parameters;
        evaluations += m.evaluations;
        learnSeconds += m.learnSeconds;
        frames += m.frames;
        reached += m.reached;
        retried += m.retried;
        iterations += m.iterations;
        solveSeconds += m.solveSeconds;
        solveCpuSeconds += m.solveCpuSeconds;
    }
    double msPerFrame() const { return frames ? 1e3 * solveSeconds / frames : 0.0; }
    double cpuMsPerFrame() const { return frames ? 1e3 * solveCpuSeconds / frames : 0.0; }
    Json clipJson() const
    {
        return Json{{"frames", frames},
                    {"reached", reached},
                    {"retried_frames", retried},
                    {"mean_iterations", frames ? static_cast<double>(iterations) / frames : 0.0},
                    {"ms_per_frame", msPerFrame()},
                    {"cpu_ms_per_frame", cpuMsPerFrame()}};
    }
    Json json() const
    {
        Json j{{"characters", characters}, {"fully_modelled", modelled},          {"unmodelled_outputs", unmodelled},
               {"parameters", parameters}, {"training_evaluations", evaluations}, {"learn_seconds", learnSeconds}};
        j.update(clipJson());
        return j;
    }
};

// IK's time over FK's, null without an FK time.
Json ratio(double ik, double fk) { return fk > 0.0 ? Json(ik / fk) : Json(); }

// One character in one mode, learned with rig-learn's defaults (helpers auto).
struct LearnedMode {
    GraphRigFunction rig;
    Approximation approximation;
    std::optional<RigBinding> binding;
    ModeFigures learned;  // the learning's figures, no clip
};

std::unique_ptr<LearnedMode> learnMode(const Character& character, int mode, const std::filesystem::path& dir,
                                       const std::string& name)
{
    const auto m = static_cast<std::size_t>(mode);
    std::filesystem::path rigFile;
    auto l = std::unique_ptr<LearnedMode>(
        new LearnedMode{loadCharacterRig(character.modeRig[m], character.modeSpec[m], dir, name, rigFile), {}, {}, {}});
    std::vector<UnmodelledOutput> unmodelled;
    l->approximation = learnApproximation(l->rig, LearnOptions{}, rigFile.string(), &unmodelled);
    l->binding.emplace(l->approximation, l->rig);
    const Approximation& a = l->approximation;
    l->learned = {1,
                  unmodelled.empty() ? 1 : 0,
                  static_cast<long long>(unmodelled.size()),
                  static_cast<long long>(a.parameters.size()),
                  a.training.evaluations,
                  a.training.seconds};
    return l;
}

// `targets` inverted as rig-invert inverts a clip (no --hybrid), the best of three runs timed (the answers are the
// same each time): the learning's figures with the clip's.
ModeFigures invertTimed(LearnedMode& l, const ClipTargets& targets)
{
    const Solver solver(l.approximation, SolverOptions{});
    const int last = static_cast<int>(targets.frames.size()) - 1;
    std::vector<std::vector<double>> values;
    ModeFigures m = l.learned;
    m.solveSeconds = m.solveCpuSeconds = 1e300;
    for (int run = 0; run < 3; ++run) {
        const ClipInversionSummary s = invertClip(solver, *l.binding, targets, 0, last, {}, values);
        m.frames = s.frames;
        m.reached = s.count(FrameStatus::reached);
        m.retried = s.retriedFrames;
        m.iterations = 0;
        for (const FrameInversion& f : s.perFrame) m.iterations += f.solve.iterations;
        m.solveSeconds = std::min(m.solveSeconds, s.solveSeconds);
        m.solveCpuSeconds = std::min(m.solveCpuSeconds, s.solveCpuSeconds);
    }
    return m;
}

// IK mode's clip as targets of FK mode's approximation: the same joints by name (FK mode has no helper frame).
ClipTargets sameJoints(const Approximation& fk, const Approximation& ik, const ClipTargets& ikClip)
{
    std::vector<int> from;
    for (const ApproximationOutput& out : fk.outputs) {
        const auto at = std::find_if(ik.outputs.begin(), ik.outputs.end(),
                                     [&](const ApproximationOutput& o) { return o.name == out.name; });
        if (at == ik.outputs.end()) throw Error(fmt::format("random characters: IK mode has no output {}", out.name));
        from.push_back(static_cast<int>(at - ik.outputs.begin()));
    }
    ClipTargets targets;
    for (const std::vector<JointTarget>& frame : ikClip.frames) {
        std::vector<JointTarget>& out = targets.frames.emplace_back(fk.outputs.size());
        for (std::size_t k = 0; k < out.size(); ++k) out[k] = frame[static_cast<std::size_t>(from[k])];
    }
    return targets;
}

// A group of characters (one construction, or randomCharacter's) and their figures in both modes.
struct Group {
    std::string name;
    bool construction = true;  // one of issue #46's leg constructions (else randomCharacter's arms and eyes)
    std::vector<Character> characters;
    // FK and IK mode on their own clips, and FK mode on IK mode's clip.
    ModeFigures fk, ik, fkOnIk;
    Json rows = Json::array();
};

Json groupJson(const Group& g)
{
    return Json{{"construction", g.name},
                {"characters", g.characters.size()},
                {"fk", g.fk.json()},
                {"ik", g.ik.json()},
                {"fk_on_ik_clip", g.fkOnIk.clipJson()},
                {"ratio", ratio(g.ik.cpuMsPerFrame(), g.fkOnIk.cpuMsPerFrame())},
                {"ratio_wall", ratio(g.ik.msPerFrame(), g.fkOnIk.msPerFrame())},
                {"ratio_own_clips", ratio(g.ik.cpuMsPerFrame(), g.fk.cpuMsPerFrame())},
                {"per_character", g.rows}};
}

// The characters, drawn from one stream in a fixed order: each construction's, then randomCharacter's.
std::vector<Group> drawCharacters(const CharactersBenchOptions& o)
{
    constexpr std::array<std::pair<Construction, const char*>, 6> constructions{
        {{Construction::reverseFoot, "reverseFoot"},
         {Construction::orientEnd, "orientEnd"},
         {Construction::threeBones, "threeBones"},
         {Construction::constraintBlend, "constraintBlend"},
         {Construction::spaceSwitch, "spaceSwitch"},
         {Construction::singleChain, "singleChain"}}};
    std::mt19937 rng(o.seed);
    std::vector<Group> groups;
    for (const auto& [construction, name] : constructions) {
        if (o.perConstruction <= 0) break;
        Group& g = groups.emplace_back(Group{name, true, {}, {}, {}, {}});
        for (int c = 0; c < o.perConstruction; ++c) g.characters.push_back(leggedCharacter(rng, construction));
    }
    if (o.randomCharacters > 0) {
        Group& g = groups.emplace_back(Group{"random (arms, eyes)", false, {}, {}, {}, {}});
        for (int c = 0; c < o.randomCharacters; ++c) g.characters.push_back(randomCharacter(rng));
    }
    return groups;
}

// One character in both modes into its group: each mode's own clip, and IK mode's clip in FK mode.
void characterRow(Group& g, const Character& character, int index, const CharactersBenchOptions& o,
                  const std::filesystem::path& dir)
{
    // The clips' own stream: a character's clips do not depend on the characters before it.
    std::mt19937 clipRng(o.seed * 31u + static_cast<unsigned>(index));
    std::array<std::unique_ptr<LearnedMode>, 2> modes;
    std::array<ClipTargets, 2> clips;
    for (const int mode : {0, 1}) {
        const auto m = static_cast<std::size_t>(mode);
        modes[m] = learnMode(character, mode, dir, fmt::format("character{}.{}", index, modeNames[m]));
        clips[m] = smoothClip(modes[m]->approximation, *modes[m]->binding, o.frames, clipRng);
    }
    const ModeFigures fk = invertTimed(*modes[0], clips[0]), ik = invertTimed(*modes[1], clips[1]);
    const ModeFigures fkOnIk =
        invertTimed(*modes[0], sameJoints(modes[0]->approximation, modes[1]->approximation, clips[1]));
    g.fk.add(fk);
    g.ik.add(ik);
    g.fkOnIk.add(fkOnIk);
    const auto brief = [](const ModeFigures& m) {
        return Json{{"unmodelled_outputs", m.unmodelled},
                    {"parameters", m.parameters},
                    {"reached", m.reached},
                    {"retried_frames", m.retried},
                    {"mean_iterations", m.frames ? static_cast<double>(m.iterations) / m.frames : 0.0},
                    {"cpu_ms_per_frame", m.cpuMsPerFrame()}};
    };
    g.rows.push_back(Json{{"character", index},
                          {"parts", character.parts.summary},
                          {"fk", brief(fk)},
                          {"ik", brief(ik)},
                          {"fk_on_ik_clip", brief(fkOnIk)}});
}

}  // namespace

Json randomCharactersJson(const CharactersBenchOptions& o, const std::filesystem::path& workDir,
                          const std::function<void(std::string_view)>& log)
{
    if (o.perConstruction <= 0 && o.randomCharacters <= 0) return Json();
    const auto start = std::chrono::steady_clock::now();
    const std::filesystem::path dir = workDir / "random_characters";
    std::filesystem::create_directories(dir);
    std::vector<Group> groups = drawCharacters(o);
    ModeFigures fk, ik, fkOnIk;
    Json rows = Json::array();
    int index = 0;
    for (Group& g : groups) {
        if (log)
            log(fmt::format("random characters: {} ({}), learned and inverted in FK and IK mode", g.name,
                            g.characters.size()));
        for (const Character& character : g.characters) characterRow(g, character, index++, o, dir);
        if (g.construction) {
            fk.add(g.fk);
            ik.add(g.ik);
            fkOnIk.add(g.fkOnIk);
        }
        rows.push_back(groupJson(g));
    }
    return Json{{"seed", o.seed},
                {"characters_per_construction", o.perConstruction},
                {"random_characters", o.randomCharacters},
                {"frames_per_clip", o.frames},
                {"constructions", std::move(rows)},
                // Over issue #46's leg constructions: randomCharacter's stretched IK arms are out of FK's reach, and
                // FK's best fits there are no measure of its time.
                {"fk", fk.json()},
                {"ik", ik.json()},
                {"fk_on_ik_clip", fkOnIk.clipJson()},
                {"ratio", ratio(ik.solveCpuSeconds, fkOnIk.solveCpuSeconds)},
                {"ratio_wall", ratio(ik.solveSeconds, fkOnIk.solveSeconds)},
                {"ratio_own_clips", ratio(ik.cpuMsPerFrame(), fk.cpuMsPerFrame())},
                {"seconds", secondsSince(start)},
                {"note",
                 "each character in FK mode (every switch at FK, the arms' FK controls; the legs an FK twin of the "
                 "rig: the same joints turned by controls of their own) and in IK mode (the rig, every switch at IK, "
                 "the arms' IK controls), learned with rig-learn's defaults (helpers auto); in each mode a smooth "
                 "random clip of the real rig's own poses in that mode, and IK mode's clip in FK mode too (the same "
                 "targets: FK reaches an IK leg's poses; a stretched IK arm's it cannot), inverted as rig-invert "
                 "inverts a clip (no --hybrid), the best of three runs timed; reached: every joint within the target "
                 "tolerance on the real rig; ratio: IK's thread CPU time per frame over FK's on IK's clip (wall: "
                 "ratio_wall; over FK's on its own clip: ratio_own_clips); the totals (fk, ik, fk_on_ik_clip, the "
                 "ratios) over the leg constructions of issue #46, not randomCharacter's"}};
}

}  // namespace rig::bench
