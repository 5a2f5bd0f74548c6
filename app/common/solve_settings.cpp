#include "app/common/solve_settings.h"

#include <algorithm>
#include <charconv>
#include <limits>
#include <type_traits>

#include <fmt/format.h>

#include "core/error.h"

namespace rig::app {
namespace {

// The object of a SolveSettings (const or not) that holds members of `Holder`.
template <class Holder, class Settings>
auto& holder(Settings& s)
{
    if constexpr (std::is_same_v<Holder, SolverOptions>) return s.clip.solver;
    else if constexpr (std::is_same_v<Holder, ClipInversionOptions>) return s.clip;
    else return s;
}

// A row's accessors from a member pointer: the member read and written as an int (a bool or an enum as its value).
// Negated: a flag that clears a bool member (--no-partition clears SolverOptions::partition).
template <auto member, bool negated = false>
struct Lands;
template <class Holder, class T, T Holder::*member, bool negated>
struct Lands<member, negated> {
    static int get(const SolveSettings& s)
    {
        const int value = static_cast<int>(holder<Holder>(s).*member);
        return negated ? !value : value;
    }
    static void set(SolveSettings& s, int value)
    {
        holder<Holder>(s).*member = static_cast<T>(negated ? !value : value);
    }
};

template <auto member, bool negated = false>
SolveSetting row(std::string_view name, SettingKind kind, std::string_view help)
{
    SolveSetting s;
    s.name = name;
    s.kind = kind;
    s.help = help;
    s.get = &Lands<member, negated>::get;
    s.set = &Lands<member, negated>::set;
    return s;
}

template <auto member>
SolveSetting count(std::string_view name, std::string_view help, int least, int most, std::string_view rule)
{
    SolveSetting s = row<member>(name, SettingKind::count, help);
    s.least = least;
    s.most = most;
    s.rule = rule;
    return s;
}

std::array<SolveSetting, solveSettingCount> makeTable()
{
    constexpr int many = std::numeric_limits<int>::max();
    SolveSetting jacobian = row<&SolverOptions::jacobian>(
        "jacobian", SettingKind::choice,
        "How the solver forms the Jacobian: analytic, or fd (finite differences, in parallel)");
    jacobian.words = {"analytic", "fd"};  // JacobianMethod::analytic, finiteDifference (a choice has two words)
    SolveSetting term = row<&SolveSettings::term>(
        "term", SettingKind::choice,
        "The residual of every target: jointTarget (its position and rotation) or position (its position alone)");
    term.words = {"jointTarget", "position"};  // TargetTerm's values, the kinds' names in the registry
    // In the order the manifest has always held them: its settings are part of every shard's key.
    return {
        count<&SolverOptions::threads>("threads", "Threads for the solver (0: all cores); results do not depend on it",
                                       0, 1024, "not a thread count; give a whole number from 0 (all cores) to 1024"),
        row<&SolverOptions::partition, true>("no-partition", SettingKind::flag,
                                             "Solve all parameters as one dense problem"),
        row<&SolverOptions::coupledBlocks, true>(
            "block-by-block", SettingKind::flag,
            "Solve the partition's blocks one after another, each outer block held (faster, a worse optimum on "
            "unreachable targets)"),
        jacobian,
        count<&ClipInversionOptions::polishCorrections>(
            "polish", "Real-rig corrections per frame (0: approximation only)", 0, many,
            "give 0 (the approximation only) or more real-rig corrections per frame"),
        count<&ClipInversionOptions::restartInterval>(
            "restart-every", "Frames between warm-start restarts (chunks of a clip then match one run)", 1, many,
            "give 1 or more frames between warm-start restarts (default {})"),
        row<&ClipInversionOptions::coldStart, true>(
            "rest-starts", SettingKind::flag,
            "Restart frames start from the rest values instead of the approximation's initial guess"),
        row<&SolveSettings::hybrid>("hybrid", SettingKind::flag,
                                    "Fit the outputs the approximation does not model (an IK leg) by Gauss-Newton on "
                                    "the real rig, after the approximation's solve"),
        term,
    };
}

const SolveSetting& named(std::string_view name)
{
    const auto& table = solveSettings();
    return *std::find_if(table.begin(), table.end(), [&](const SolveSetting& s) { return s.name == name; });
}

Error badValue(const SolveSetting& s, std::string_view text, Spelling spelling)
{
    // A rule may cite the default ("{}"), which is that of SolveSettings{}.
    const std::string rule = s.kind == SettingKind::choice
                                 ? fmt::format("expected {} or {}", s.words[0], s.words[1])
                                 : fmt::format(fmt::runtime(s.rule), settingText(s, s.get(SolveSettings{})));
    return Error(fmt::format("{} {}: {}", settingName(s, spelling), text, rule));
}

}  // namespace

SolveSettings concurrentSolveDefaults()
{
    SolveSettings s;
    s.clip.solver.threads = 1;
    return s;
}

const std::array<SolveSetting, solveSettingCount>& solveSettings()
{
    static const std::array<SolveSetting, solveSettingCount> table = makeTable();
    return table;
}

std::string settingName(const SolveSetting& setting, Spelling spelling)
{
    std::string name(setting.name);
    if (spelling == Spelling::flag) return "--" + name;
    std::replace(name.begin(), name.end(), '-', '_');
    return name;
}

std::string settingText(const SolveSetting& setting, int value)
{
    switch (setting.kind) {
        case SettingKind::count:
            return std::to_string(value);
        case SettingKind::flag:
            return value ? "true" : "false";
        case SettingKind::choice:
            break;
    }
    return std::string(setting.words.at(static_cast<std::size_t>(value)));
}

int parseSetting(const SolveSetting& setting, std::string_view text, Spelling spelling)
{
    if (setting.kind == SettingKind::choice) {
        const auto word = std::find(setting.words.begin(), setting.words.end(), text);
        if (word == setting.words.end()) throw badValue(setting, text, spelling);
        return static_cast<int>(word - setting.words.begin());
    }
    if (setting.kind == SettingKind::flag)
        throw internalError(fmt::format("parseSetting: {} is a flag, which takes no text", setting.name));
    int value = 0;
    const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
    if (ec != std::errc() || end != text.data() + text.size() || value < setting.least || value > setting.most)
        throw badValue(setting, text, spelling);
    return value;
}

void checkSettings(const SolveSettings& settings, Spelling spelling)
{
    // A choice is always one of its words (parseSetting made it); a count may have been set in code.
    for (const SolveSetting& s : solveSettings())
        if (const int value = s.get(settings); s.kind == SettingKind::count && (value < s.least || value > s.most))
            throw badValue(s, std::to_string(value), spelling);
    const SolveSetting& polish = named("polish");
    if (settings.hybrid && polish.get(settings) > 0)
        throw Error(
            fmt::format("{} with {} {}: choose one; the hybrid solve fits what the approximation does not model on "
                        "the real rig itself",
                        settingName(named("hybrid"), spelling), settingName(polish, spelling), polish.get(settings)));
}

}  // namespace rig::app
