#pragma once
// What every command line shares: one style of flags, help and errors, and exit codes
// (0 success, 2 bad input with one "error: ..." line, 1 internal failure).

#include <filesystem>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include <CLI/CLI.hpp>

namespace rig::app {

// Parses the command line into `app` and runs `body`, turning errors into messages and exit codes.
int runMain(CLI::App& app, int argc, char** argv, const std::function<int()>& body);

// The check of a --threads option: a whole number from 0 (all cores) to 1024, else one line that says so.
CLI::Validator threadCount();

// Frames A:B[:STEP], inclusive, step > 0 (e.g. 1:240, 0:10:0.5).
struct FrameRange {
    double first = 0.0;
    double last = 0.0;
    double step = 1.0;
    std::vector<double> frames() const;
};
// Throws rig::Error naming the flag when the text is not a valid range.
FrameRange parseFrameRange(std::string_view text, std::string_view flag);

// Checks, before any work, that `file` can be an output: a non-empty name no longer than its folder's file
// system allows, not a folder, not a socket, not a read-only file (by its mode bits, which bind root too), in
// a folder that exists and this process may write into. A symbolic link is judged by the file it names. Throws
// rig::Error with what to do. `example` is the file name the message suggests when `file` is a folder; `flag` the
// option that names the file, for the messages.
void checkOutputFile(const std::filesystem::path& file, std::string_view example = "out.json",
                     std::string_view flag = "-o");

// Writes through a temporary file in the same folder and renames it, so a failing or interrupted run
// never leaves a truncated file or damages an existing one; an existing file keeps its mode. A
// symbolic link is followed (the file it names is replaced, the link kept); a FIFO or a device is
// written through, never replaced. Throws rig::Error when it cannot.
// The temporary file is ".NAME.PID.XXXXXX.tmp" (PID: the writing process; NAME cut and followed by a
// checksum of itself where that would be longer than the folder allows). A process killed while writing
// leaves it behind; the next write of NAME removes those whose process is gone.
void writeFileAtomically(const std::filesystem::path& file, std::string_view content);

// The file an output name leads to: a symbolic link (or a chain of them) followed, anything else as is.
std::filesystem::path outputTarget(const std::filesystem::path& file);

// A file a command line names, and what it is to the command ("-o", "--report-json", "the rig file").
struct NamedFile {
    std::string role;
    std::filesystem::path path;
};

// Refuses, before any work, an output that is one of the inputs or another output: the same file by
// device and inode (a link, another spelling of the path), or the same path once resolved when it does
// not exist yet. Devices (/dev/null) are exempt. Throws rig::Error with one line naming both.
void checkDistinctFiles(const std::vector<NamedFile>& inputs, const std::vector<NamedFile>& outputs);

// The temporary files of `file` that writeFileAtomically left behind in a killed process: the names
// match ".NAME.PID.XXXXXX.tmp" and no process PID is running. Exposed for tests.
std::vector<std::filesystem::path> staleTemporaryFiles(const std::filesystem::path& file);

}  // namespace rig::app
