#pragma once
// Output files as every command line and the Python module write them: checked before the work, written
// atomically, never an input overwritten.

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace rig::app {

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
