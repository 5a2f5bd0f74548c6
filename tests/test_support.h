#pragma once
// Helpers shared by the test suites: running the command lines, paths, temporary folders.

#include <filesystem>
#include <functional>
#include <string>

namespace rig::test {

struct CommandResult {
    int exitCode = -1;
    std::string out;
    std::string err;
};

// Runs a shell command line from the source folder, capturing standard output and error.
CommandResult run(const std::string& commandLine);

// build/bin/<tool>, quoted for the shell.
std::string tool(const std::string& name);

std::filesystem::path sourceDir();
std::filesystem::path binaryDir();

// A fresh empty folder under the build tree for one test.
std::filesystem::path scratchDir(const std::string& name);

// What `f` throws as a rig::Error (its what()), or "(no error)".
std::string errorOf(const std::function<void()>& f);

// Writes `text` to `file` and returns the path.
std::filesystem::path writeFile(const std::filesystem::path& file, const std::string& text);

// The whole file, "" when it cannot be read.
std::string readFile(const std::filesystem::path& file);

}  // namespace rig::test
