#include "tools/solve_flags.h"

#include <fmt/format.h>

namespace rig::cli {

using namespace rig::app;  // the table's names (a constructor's `app` is CLI11's)

SolveFlags::SolveFlags(CLI::App& app, const SolveSettings& defaults, const std::string& threadsHelp)
    : defaults_(defaults)
{
    const auto& table = solveSettings();
    for (std::size_t i = 0; i < table.size(); ++i) {
        const SolveSetting& s = table[i];
        const std::string name = settingName(s, Spelling::flag);
        if (s.kind == SettingKind::flag) {
            options_[i] = app.add_flag(name)->description(std::string(s.help));
            continue;
        }
        const std::string help = s.name == "threads" && !threadsHelp.empty() ? threadsHelp : std::string(s.help);
        // Taken as text and read by the table (settings()), so that every bad value is the table's one line.
        options_[i] =
            app.add_option(name, texts_[i], fmt::format("{} (default {})", help, settingText(s, s.get(defaults))))
                ->type_name(s.kind == SettingKind::count ? "INT" : "WORD");
    }
}

SolveSettings SolveFlags::settings() const
{
    SolveSettings out = defaults_;
    const auto& table = solveSettings();
    for (std::size_t i = 0; i < table.size(); ++i) {
        if (options_[i]->count() == 0) continue;
        const SolveSetting& s = table[i];
        s.set(out, s.kind == SettingKind::flag ? 1 : parseSetting(s, texts_[i], Spelling::flag));
    }
    checkSettings(out, Spelling::flag);
    return out;
}

}  // namespace rig::cli
