#include "test_support.h"

#include "core/error.h"

#include <sys/wait.h>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include <fmt/format.h>
#include <unistd.h>

namespace rig::test {

std::filesystem::path sourceDir() { return RIG_SOURCE_DIR; }

std::filesystem::path binaryDir() { return RIG_BINARY_DIR; }

std::string tool(const std::string& name) { return fmt::format("'{}'", (binaryDir() / "bin" / name).string()); }

std::filesystem::path scratchDir(const std::string& name)
{
    const auto dir = binaryDir() / "test-scratch" / name;
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
    return dir;
}

std::string errorOf(const std::function<void()>& f)
{
    try {
        f();
    }
    catch (const Error& e) {
        return e.what();
    }
    return "(no error)";
}

std::filesystem::path writeFile(const std::filesystem::path& file, const std::string& text)
{
    std::ofstream(file, std::ios::binary) << text;
    return file;
}

std::string readFile(const std::filesystem::path& file)
{
    std::ifstream in(file, std::ios::binary);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
}

namespace {

}  // namespace

CommandResult run(const std::string& commandLine)
{
    static int counter = 0;
    const auto dir = binaryDir() / "test-scratch" / "commands";
    std::filesystem::create_directories(dir);
    const auto tag = fmt::format("{}-{}", ::getpid(), counter++);
    const auto outFile = dir / fmt::format("{}.out", tag);
    const auto errFile = dir / fmt::format("{}.err", tag);
    const std::string full = fmt::format("cd '{}' && {} > '{}' 2> '{}' < /dev/null", sourceDir().string(), commandLine,
                                         outFile.string(), errFile.string());
    const int status = std::system(full.c_str());
    CommandResult result;
    result.exitCode = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    result.out = readFile(outFile);
    result.err = readFile(errFile);
    std::filesystem::remove(outFile);
    std::filesystem::remove(errFile);
    return result;
}

}  // namespace rig::test
