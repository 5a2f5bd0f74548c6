#pragma once
// The solve flags rig-invert and rig-batch share, declared once (docs/rig-invert.md, Solver flags; docs/cluster.md):
// each flag, its help and its default come from this one table, so the two command lines cannot drift apart.

#include <string>

#include <CLI/CLI.hpp>

#include "app/invert_run.h"

namespace rig::cli {

// Adds --threads, --jacobian, --no-partition, --block-by-block, --polish, --restart-every, --rest-starts and
// --hybrid to `app`, each into its field of `settings` (whose values are the defaults shown). `threadsHelp` says
// what --threads counts (rig-invert: the solve's threads; rig-batch: each shard's).
void addSolveFlags(CLI::App& app, app::InvertSettings& settings, const std::string& threadsHelp);

}  // namespace rig::cli
