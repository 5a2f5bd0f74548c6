#pragma once
// What every command line shares: one style of flags, help and errors, and exit codes
// (0 success, 2 bad input with one "error: ..." line, 1 internal failure).

#include <filesystem>
#include <functional>
#include <string_view>
#include <vector>

#include <CLI/CLI.hpp>

namespace rig::cli {

// Parses the command line into `app` and runs `body`, turning errors into messages and exit codes.
int runMain(CLI::App& app, int argc, char** argv, const std::function<int()>& body);

// Frames A:B[:STEP], inclusive, step > 0 (e.g. 1:240, 0:10:0.5).
struct FrameRange {
    double first = 0.0;
    double last = 0.0;
    double step = 1.0;
    std::vector<double> frames() const;
};
// Throws rig::Error naming the flag when the text is not a valid range.
FrameRange parseFrameRange(std::string_view text, std::string_view flag);

// Writes through a temporary file in the same folder and renames it, so a failing or interrupted run
// never leaves a truncated file or damages an existing one. Throws rig::Error when it cannot.
void writeFileAtomically(const std::filesystem::path& file, std::string_view content);

}  // namespace rig::cli
