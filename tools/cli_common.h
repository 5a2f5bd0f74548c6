#pragma once
// What every command line shares: one style of flags, help and errors, and exit codes
// (0 success, 2 bad input with one "error: ..." line, 3 a result measured as wrong, 1 internal failure).

#include <functional>
#include <string>

#include <CLI/CLI.hpp>

namespace rig::cli {

// Parses the command line into `app` and runs `body`, turning errors into messages and exit codes.
int runMain(CLI::App& app, int argc, char** argv, const std::function<int()>& body);

// The check of a --threads option: a whole number from 0 (all cores) to 1024, else one line that says so.
CLI::Validator threadCount();

// The check of an option whose empty value would mean the same as leaving it out (--take '', --contacts '': a
// shell variable left empty): refused, with `give` saying what to give instead.
CLI::Validator nonEmpty(std::string give);

}  // namespace rig::cli
