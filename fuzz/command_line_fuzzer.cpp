// libFuzzer target: the command lines end to end. An input is a small script:
//
//   TOOL                      graph-eval, bvh2rig, rig-learn or rig-invert (first line)
//   ARG                       one argument per line, until a line "---" or the end; "{dir}" in an
//   ...                       argument is a fresh folder for this run
//   --- NAME                  then files: the lines up to the next "--- NAME" are {dir}/NAME
//   ...
//
// The tool runs as a child process (build/bin) with a 20 s limit, in a sandbox: its working folder is a
// copy of the project's rigs/ and tests/corpus/ made once per fuzzing process, so the corpus cases'
// relative paths work and whatever a run writes (-o rigs/biped.yaml) lands in the copy, never in the
// checkout. An argument that is an absolute path or climbs out with ".." (other than {dir}) skips the
// input: running as root, a fuzzer must not write over system files. Exit codes 0, 2 and 3 are
// answers; exit code 1 ("internal error"), a signal or the time limit is a bug: the input may name any
// file and flag, and none of them may reach an internal error. scripts/fuzz.sh seeds it from
// tests/corpus/cases.yaml; docs/robustness.md.
#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

extern char** environ;

namespace {

const std::vector<std::string_view> tools{"graph-eval", "bvh2rig", "rig-learn", "rig-invert"};

std::vector<std::string_view> lines(std::string_view text)
{
    std::vector<std::string_view> out;
    while (!text.empty()) {
        const auto end = text.find('\n');
        out.push_back(text.substr(0, end));
        if (end == std::string_view::npos) break;
        text.remove_prefix(end + 1);
    }
    return out;
}

std::string replaceDir(std::string_view text, const std::string& dir)
{
    std::string out(text);
    for (std::size_t at = out.find("{dir}"); at != std::string::npos; at = out.find("{dir}", at + dir.size()))
        out.replace(at, 5, dir);
    return out;
}

// An argument that stays in the sandbox: not an absolute path, no ".." component.
bool staysInside(std::string_view arg)
{
    if (arg.starts_with('/')) return false;
    for (std::size_t at = arg.find(".."); at != std::string_view::npos; at = arg.find("..", at + 1)) {
        const bool starts = at == 0 || arg[at - 1] == '/' || arg[at - 1] == '=';
        const bool ends = at + 2 == arg.size() || arg[at + 2] == '/';
        if (starts && ends) return false;
    }
    return true;
}

// The sandbox's working folder: a copy of the project's inputs, made once per process and removed at
// exit. (Never destroyed: the exit handler still reads it after static objects are gone.)
const std::filesystem::path& sandbox()
{
    static const std::filesystem::path& folder = *new std::filesystem::path([] {
        const auto root = std::filesystem::temp_directory_path() / ("rig-cli-fuzz." + std::to_string(::getpid()));
        for (const char* part : {"rigs", "tests/corpus"}) {
            std::filesystem::create_directories((root / "project" / part).parent_path());
            std::filesystem::copy(std::filesystem::path(RIG_FUZZ_SOURCE_DIR) / part, root / "project" / part,
                                  std::filesystem::copy_options::recursive);
        }
        std::atexit([] {
            std::error_code ignored;
            std::filesystem::remove_all(sandbox().parent_path(), ignored);
        });
        return root / "project";
    }());
    return folder;
}

// A file name inside the folder: no separators, no "..", not empty.
bool plainName(std::string_view name)
{
    return !name.empty() && name != "." && name != ".." && name.find('/') == std::string_view::npos &&
           name.find('\0') == std::string_view::npos;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    if (size > 1 << 20) return 0;
    const std::vector<std::string_view> text = lines({reinterpret_cast<const char*>(data), size});
    if (text.empty()) return 0;
    bool known = false;
    for (const auto t : tools) known = known || text.front() == t;
    if (!known) return 0;

    std::vector<std::string> args{std::string(RIG_FUZZ_BIN_DIR) + "/" + std::string(text.front())};
    std::size_t i = 1;
    for (; i < text.size() && !text[i].starts_with("---"); ++i) {
        if (!staysInside(text[i])) return 0;
        args.push_back(std::string(text[i]));
    }
    static int run = 0;
    const std::filesystem::path dir = sandbox().parent_path() / ("run" + std::to_string(run++));
    std::filesystem::create_directories(dir);
    for (std::size_t a = 1; a < args.size(); ++a) args[a] = replaceDir(args[a], dir.string());
    while (i < text.size()) {
        const std::string_view name = text[i].substr(std::min<std::size_t>(4, text[i].size()));
        std::string content;
        for (++i; i < text.size() && !text[i].starts_with("---"); ++i) content.append(text[i]).push_back('\n');
        if (plainName(name)) std::ofstream(dir / std::string(name), std::ios::binary) << content;
    }

    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
    posix_spawn_file_actions_addopen(&actions, 1, "/dev/null", O_WRONLY, 0);
    posix_spawn_file_actions_addopen(&actions, 2, "/dev/null", O_WRONLY, 0);
    posix_spawn_file_actions_addchdir_np(&actions, sandbox().c_str());
    pid_t child = 0;
    const int spawned = posix_spawn(&child, argv.front(), &actions, nullptr, argv.data(), environ);
    posix_spawn_file_actions_destroy(&actions);
    if (spawned != 0) __builtin_trap();  // the tools are not built: scripts/fuzz.sh builds them

    int status = 0;
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
    bool timedOut = false;
    while (::waitpid(child, &status, WNOHANG) == 0) {
        if (std::chrono::steady_clock::now() > deadline) {
            ::kill(child, SIGKILL);
            ::waitpid(child, &status, 0);
            timedOut = true;
            break;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    std::error_code ignored;
    std::filesystem::remove_all(dir, ignored);
    const bool answered = !timedOut && WIFEXITED(status) &&
                          (WEXITSTATUS(status) == 0 || WEXITSTATUS(status) == 2 || WEXITSTATUS(status) == 3);
    if (!answered) __builtin_trap();
    return 0;
}
