#pragma once
// The solve settings' table (app/common/solve_settings.h) as flags of rig-invert and rig-batch (docs/rig-invert.md,
// Solver flags; docs/cluster.md): each flag, its help, its default and its check come from the table, so that the two
// command lines, the batch manifest and Python cannot drift apart.

#include <array>
#include <string>

#include <CLI/CLI.hpp>

#include "app/common/solve_settings.h"

namespace rig::cli {

class SolveFlags {
public:
    // Adds a flag per row of the table to `app`, its help ending with its default in `defaults`. `threadsHelp`, when
    // given, says what --threads counts instead of the table (rig-batch: each shard's threads). The flags' texts
    // are kept as given and read by settings(): it keeps references into itself, so it stays where it is made.
    SolveFlags(CLI::App& app, const app::SolveSettings& defaults, const std::string& threadsHelp = "");
    SolveFlags(const SolveFlags&) = delete;
    SolveFlags& operator=(const SolveFlags&) = delete;

    // The defaults with each flag given, once `app` has parsed the command line. Throws rig::Error with the table's
    // one line for a bad value or combination (a user error: exit code 2).
    app::SolveSettings settings() const;

private:
    app::SolveSettings defaults_;
    std::array<std::string, app::solveSettingCount> texts_;
    std::array<const CLI::Option*, app::solveSettingCount> options_{};
};

}  // namespace rig::cli
