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
// One output of a run; a run of several outputs commits them together with OutputFiles.
void writeFileAtomically(const std::filesystem::path& file, std::string_view content);

// The outputs of one run, committed together: a run that fails while writing one of them (a full disk,
// `--report-json /dev/full`) replaces none. Each output is checked when it is added, before the work, and a
// FIFO or a device is opened then: a FIFO no process reads is refused at once (a run that solved for minutes
// would otherwise block on it when it writes). commit() writes every regular file to its temporary file, then
// the FIFOs and devices, and renames the temporary files over their outputs only when all of that succeeded.
class OutputFiles {
public:
    OutputFiles() = default;
    OutputFiles(const OutputFiles&) = delete;
    OutputFiles& operator=(const OutputFiles&) = delete;
    ~OutputFiles();

    // checkOutputFile's checks (with its `example` and `flag`), and a FIFO or a device opened.
    void add(const std::filesystem::path& file, std::string_view example = "out.json", std::string_view flag = "-o");
    // What an added output will hold; an added output given no content is not written.
    void set(const std::filesystem::path& file, std::string content);
    // Writes the outputs given content, all or none (see above). Throws rig::Error naming the output that failed.
    void commit();

private:
    struct Output {
        std::filesystem::path file;    // as the user named it, for messages
        std::filesystem::path target;  // the file it leads to (a link followed)
        int stream = -1;               // a FIFO's or a device's descriptor, open from add() on
        bool given = false;
        std::string content;
        std::string temporary;  // a regular file's staged content, until commit() renames it
    };
    Output& find(const std::filesystem::path& file);
    void removeTemporaries();
    std::vector<Output> outputs_;
};

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
