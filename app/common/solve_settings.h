#pragma once
// The solve settings in one table (in the manner of Ceres' Minimizer::Options::Init: settings live in one place), from
// which rig-invert's and rig-batch's flags (tools/solve_flags.h), the batch manifest's fields
// (app/batch/batch_manifest.cpp) and Python's keyword arguments (python/riginv.cpp) are all made: each row has the
// setting's name, kind, help, check and where it lands; its default is read from where it lands in a default
// SolveSettings, that is from the options structs' own defaults. No CLI11 here: the Python module includes it.

#include <array>
#include <cstddef>
#include <string>
#include <string_view>

#include "inversion/clip/clip_inversion.h"

namespace rig::app {

// What the table's settings land in: the options of invertClip (the solver's inside) and the hybrid solve's switch
// (inversion/clip/hybrid_solve.h, which app/invert/invert_run.cpp sets up from it).
// The residual term of every target (inversion/solve/residual_term.h): the built-in kinds, as the registry names them.
enum class TargetTerm { jointTarget, position };

struct SolveSettings {
    ClipInversionOptions clip;
    bool hybrid = false;
    TargetTerm term = TargetTerm::jointTarget;
};

// The defaults where many solves run at once (rig-batch's shards, processes side by side; Python's callers, who
// run their own threads): one solver thread each. Every other setting as in SolveSettings{}.
SolveSettings concurrentSolveDefaults();

enum class SettingKind {
    count,   // a whole number in [least, most]
    flag,    // a switch: absent is false (the default of every flag row), given is true
    choice,  // one of a few words, stored as the index of the word (an enum's value)
};

struct SolveSetting {
    // The flag's name without its dashes ("restart-every"); the manifest's key and Python's keyword are it with
    // '_' for '-' (settingName).
    std::string_view name;
    SettingKind kind = SettingKind::flag;
    std::string_view help;
    // count: the range, and the rule a value outside it is told ("give 1 or more frames ..."), which may cite the
    // default as "{}".
    int least = 0;
    int most = 0;
    std::string_view rule;
    // choice: the words, in the order of the enum's values (two: a bad value is told "expected A or B").
    std::array<std::string_view, 2> words{};
    // Where it lands, its value as an int (a count; a flag as 0 or 1; a choice as its word's index): an accessor
    // made from a member pointer into SolverOptions, ClipInversionOptions or SolveSettings (solve_settings.cpp).
    int (*get)(const SolveSettings& settings) = nullptr;
    void (*set)(SolveSettings& settings, int value) = nullptr;
};

inline constexpr std::size_t solveSettingCount = 9;
// The table, in the order the flags, fields and keywords are listed (the manifest's order, which shard keys hash).
const std::array<SolveSetting, solveSettingCount>& solveSettings();

// How a consumer spells a setting: as a flag ("--restart-every") or as a key (the manifest's field and Python's
// keyword, "restart_every").
enum class Spelling { flag, key };
std::string settingName(const SolveSetting& setting, Spelling spelling);

// A value as text: a count in decimal, a flag as true or false, a choice as its word.
std::string settingText(const SolveSetting& setting, int value);
// A count or choice from its text ("12", "fd"); throws rig::Error "NAME TEXT: RULE" (the table's one line), an
// internal one for a flag.
int parseSetting(const SolveSetting& setting, std::string_view text, Spelling spelling);
// Every row's value in range, and the combinations the solve refuses (--hybrid with --polish); throws rig::Error
// with the table's one line, naming the setting as `spelling` spells it.
void checkSettings(const SolveSettings& settings, Spelling spelling);

}  // namespace rig::app
