#include "app/batch/batch_backend.h"

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstring>
#include <fstream>
#include <iostream>
#include <mutex>
#include <sstream>
#include <thread>

#include <fcntl.h>
#include <pwd.h>
#include <spawn.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fmt/format.h>

#include "app/common/output_file.h"
#include "core/error.h"

extern "C" char** environ;

namespace rig::app {
namespace {

// The variable of the local tasks' environment that holds the driver's process id (dieWithDriver).
constexpr const char* driverVariable = "RIG_BATCH_DRIVER";

// How a process is started beyond its arguments and log.
struct SpawnOptions {
    bool search = false;  // args[0] a name looked up on PATH
    pid_t group = -1;     // -1: rig-batch's process group; 0: a new one; otherwise that group
    int inherit = -1;     // a descriptor the process keeps open (-1: none)
    bool task = false;    // a local task: told the driver's process id (dieWithDriver)
};

// Starts `args` (args[0] a path, or a name looked up on PATH) with standard input from /dev/null and
// standard output and error into `log`. The signals rig-batch blocks (stopTasksOnSignals) are unblocked and
// at their default actions in the process, whatever rig-batch's own were.
pid_t spawn(const std::vector<std::string>& args, const std::filesystem::path& log, const SpawnOptions& options = {})
{
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
    posix_spawn_file_actions_addopen(&actions, 1, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_adddup2(&actions, 1, 2);
    // dup2 onto itself clears close-on-exec in the child only (glibc 2.29 on; POSIX.1-2024).
    if (options.inherit > 2) posix_spawn_file_actions_adddup2(&actions, options.inherit, options.inherit);
    posix_spawnattr_t attributes;
    posix_spawnattr_init(&attributes);
    sigset_t none, stopping;
    sigemptyset(&none);
    sigemptyset(&stopping);
    for (const int signal : {SIGINT, SIGTERM, SIGHUP}) sigaddset(&stopping, signal);
    posix_spawnattr_setsigmask(&attributes, &none);
    posix_spawnattr_setsigdefault(&attributes, &stopping);
    short flags = POSIX_SPAWN_SETSIGMASK | POSIX_SPAWN_SETSIGDEF;
    if (options.group >= 0) {
        posix_spawnattr_setpgroup(&attributes, options.group);
        flags |= POSIX_SPAWN_SETPGROUP;
    }
    posix_spawnattr_setflags(&attributes, flags);
    const std::string driver = fmt::format("{}=", driverVariable);
    std::vector<std::string> environment;
    for (char** e = environ; *e; ++e)
        if (!std::string_view(*e).starts_with(driver)) environment.emplace_back(*e);
    if (options.task) environment.push_back(driver + std::to_string(::getpid()));
    std::vector<char*> argv, envp;
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    for (const auto& e : environment) envp.push_back(const_cast<char*>(e.c_str()));
    envp.push_back(nullptr);
    pid_t pid = 0;
    const int err = options.search ? posix_spawnp(&pid, argv[0], &actions, &attributes, argv.data(), envp.data())
                                   : posix_spawn(&pid, argv[0], &actions, &attributes, argv.data(), envp.data());
    posix_spawn_file_actions_destroy(&actions);
    posix_spawnattr_destroy(&attributes);
    if (err != 0)
        throw Error(
            fmt::format("cannot start {}: {}; check that it is installed and runnable", args[0], std::strerror(err)));
    return pid;
}

// What the signal thread and the backends share: the work to stop when rig-batch is stopped.
struct Stopping {
    std::mutex mutex;
    int signal = 0;             // the signal that stops rig-batch; 0 while it runs
    pid_t localGroup = 0;       // the local tasks' process group; 0 when none runs
    std::string slurmJobs;      // the name of the Slurm jobs submitted; "" when none
    std::vector<pid_t> sbatch;  // the sbatch --wait processes
};

Stopping& stopping()
{
    static Stopping s;
    return s;
}

// scancel --name=NAME --user=ME, waited for up to 10 s; false (with why) when it cannot.
bool cancelSlurmJobs(const std::string& name, std::string& why)
{
    const passwd* user = ::getpwuid(::getuid());
    const std::string me = user ? user->pw_name : std::to_string(::getuid());
    try {
        const pid_t pid = spawn({"scancel", "--name=" + name, "--user=" + me}, "/dev/null", {.search = true});
        for (int i = 0; i < 200; ++i) {
            int status = 0;
            if (::waitpid(pid, &status, WNOHANG) == pid) {
                why = fmt::format("scancel exited with code {}", WEXITSTATUS(status));
                return WIFEXITED(status) && WEXITSTATUS(status) == 0;
            }
            std::this_thread::sleep_for(std::chrono::milliseconds(50));
        }
        why = "scancel did not answer in 10 s";
    }
    catch (const Error& e) {
        why = e.what();
    }
    return false;
}

// The signal thread: stops the work, then exits (or leaves the exit to runLocal once its tasks are gone).
void stopOnSignal(sigset_t signals)
{
    int received = 0;
    sigwait(&signals, &received);
    Stopping& s = stopping();
    std::unique_lock lock(s.mutex);
    s.signal = received;
    const pid_t group = s.localGroup;
    if (group > 0) ::kill(-group, SIGTERM);
    if (!s.slurmJobs.empty()) {
        if (std::string why; !cancelSlurmJobs(s.slurmJobs, why))
            std::cerr << oneLine(fmt::format("warning: the Slurm jobs {} could not be cancelled ({}); cancel them "
                                             "(squeue --me, scancel --name={})",
                                             s.slurmJobs, why, s.slurmJobs))
                      << std::endl;
        for (const pid_t pid : s.sbatch) ::kill(pid, SIGTERM);
    }
    lock.unlock();
    if (group == 0) std::_Exit(128 + received);
    // runLocal exits once it has reaped its last task; a task that outlives SIGTERM is killed.
    std::this_thread::sleep_for(std::chrono::seconds(10));
    lock.lock();
    if (s.localGroup > 0) ::kill(-s.localGroup, SIGKILL);
}

std::string endNote(int status, const std::filesystem::path& log)
{
    if (WIFSIGNALED(status))
        return fmt::format("killed by signal {} ({}); its output: {}", WTERMSIG(status), strsignal(WTERMSIG(status)),
                           log.string());
    return fmt::format("exited with code {} without a status; its output: {}", WEXITSTATUS(status), log.string());
}

std::string lastLine(const std::filesystem::path& file)
{
    std::ifstream in(file);
    std::string line, last;
    while (std::getline(in, line))
        if (!line.empty()) last = line;
    return last;
}

}  // namespace

std::string shellQuote(const std::string& word)
{
    std::string out = "'";
    for (const char c : word) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
    return out + "'";
}

void stopTasksOnSignals()
{
    sigset_t signals;
    sigemptyset(&signals);
    for (const int signal : {SIGINT, SIGTERM, SIGHUP}) sigaddset(&signals, signal);
    // Before any other thread starts: they inherit the mask, so only the signal thread takes these signals.
    pthread_sigmask(SIG_BLOCK, &signals, nullptr);
    std::thread(stopOnSignal, signals).detach();
}

void dieWithDriver()
{
    const char* driver = std::getenv(driverVariable);
    if (!driver) return;
    ::prctl(PR_SET_PDEATHSIG, SIGKILL);
    // The driver may have died before the request: then this task's parent is another process already.
    if (std::to_string(::getppid()) != driver) ::raise(SIGKILL);
}

bool onPath(const std::string& program)
{
    const char* path = std::getenv("PATH");
    std::stringstream folders(path ? path : "");
    std::string folder;
    while (std::getline(folders, folder, ':'))
        if (!folder.empty() && ::access((std::filesystem::path(folder) / program).c_str(), X_OK) == 0) return true;
    return false;
}

ProcessNotes runLocal(const BackendRun& run)
{
    ProcessNotes notes;
    std::map<pid_t, std::size_t> running;  // pid -> entry of run.shards
    std::size_t next = 0;
    const std::size_t jobs = static_cast<std::size_t>(std::max(1, run.jobs));
    Stopping& s = stopping();
    for (;;) {
        {
            // Started and recorded under the lock: the signal thread stops every task started, or none starts.
            std::lock_guard lock(s.mutex);
            if (running.empty()) {
                s.localGroup = 0;  // the group ended with its last task
                if (s.signal != 0) std::_Exit(128 + s.signal);
                if (next == run.shards.size()) break;
            }
            while (s.signal == 0 && next < run.shards.size() && running.size() < jobs) {
                const auto log = run.folder / "logs" / (run.keys[next] + ".log");
                const pid_t pid = spawn(
                    {run.program.string(), "--out", run.folder.string(), "--task", std::to_string(run.shards[next])},
                    log, {.group = s.localGroup, .inherit = run.lockFd, .task = true});
                if (s.localGroup == 0) s.localGroup = pid;
                running[pid] = next;
                ++next;
            }
        }
        int status = 0;
        const pid_t pid = ::waitpid(-1, &status, 0);
        if (pid < 0) {
            if (errno == EINTR) continue;
            throw Error(fmt::format("waiting for the shards' processes: {}", std::strerror(errno)));
        }
        const auto found = running.find(pid);
        if (found == running.end()) continue;
        if (!WIFEXITED(status) || WEXITSTATUS(status) != 0)
            notes[run.shards[found->second]] =
                endNote(status, run.folder / "logs" / (run.keys[found->second] + ".log"));
        running.erase(found);
        if (run.poll) run.poll();
    }
    return notes;
}

namespace {

// The sbatch options of a task of `run`: resources and the options given.
std::vector<std::string> taskOptions(const BackendRun& run)
{
    std::vector<std::string> args{"--job-name=" + run.jobName, fmt::format("--cpus-per-task={}", run.cpusPerTask)};
    if (!run.memory.empty()) args.push_back("--mem=" + run.memory);
    if (!run.time.empty()) args.push_back("--time=" + run.time);
    args.insert(args.end(), run.sbatchArgs.begin(), run.sbatchArgs.end());
    return args;
}

// One sbatch --wait call: an array of up to slurmArrayTasks shards.
struct Submission {
    std::size_t begin = 0, end = 0;  // entries of run.shards
    std::filesystem::path log;       // sbatch's output: the job id, or its error
    pid_t pid = 0;
    bool done = false;
};

// Writes the task list and script of the array of shards from `begin`, and starts sbatch on them.
Submission submitArray(const BackendRun& run, std::size_t begin, const std::string& name)
{
    const auto slurm = run.folder / "slurm";
    Submission s;
    s.begin = begin;
    s.end = std::min(begin + slurmArrayTasks, run.shards.size());
    // Array task i runs the shard on line i + 1 of the task list.
    std::string tasks;
    for (std::size_t i = s.begin; i < s.end; ++i) tasks += std::to_string(run.shards[i]) + "\n";
    const auto taskList = slurm / (name + ".tasks");
    writeFileAtomically(taskList, tasks);
    const auto script = slurm / (name + ".sh");
    writeFileAtomically(script, fmt::format("#!/bin/sh\n"
                                            "# rig-batch: array task i runs the shard on line i + 1 of {}\n"
                                            "shard=$(sed -n \"$((SLURM_ARRAY_TASK_ID + 1))p\" {})\n"
                                            "exec {} --out {} --task \"$shard\"\n",
                                            taskList.filename().string(), shellQuote(taskList.string()),
                                            shellQuote(run.program.string()), shellQuote(run.folder.string())));
    const int count = static_cast<int>(s.end - s.begin);
    std::vector<std::string> args{"sbatch",
                                  "--parsable",
                                  "--wait",
                                  fmt::format("--array=0-{}%{}", count - 1, std::clamp(run.jobs, 1, count)),
                                  "--chdir=" + run.folder.string(),
                                  "--output=" + (run.folder / "logs" / "slurm-%A_%a.out").string()};
    for (auto& option : taskOptions(run)) args.push_back(std::move(option));
    args.push_back(script.string());
    s.log = slurm / (name + ".sbatch.log");
    // Submitted and recorded under the lock: the signal thread cancels every job submitted, or none is.
    Stopping& stop = stopping();
    std::lock_guard lock(stop.mutex);
    if (stop.signal != 0) std::_Exit(128 + stop.signal);
    s.pid = spawn(args, s.log, {.search = true});
    stop.slurmJobs = run.jobName;
    stop.sbatch.push_back(s.pid);
    return s;
}

// Waits for every sbatch --wait, which returns when every task of its array has ended; one whose shards have
// all reported is stopped instead.
void waitForArrays(const BackendRun& run, std::vector<Submission>& submissions)
{
    for (std::size_t waiting = submissions.size(); waiting > 0;) {
        for (Submission& s : submissions) {
            if (s.done) continue;
            bool all = static_cast<bool>(run.reported);
            for (std::size_t i = s.begin; i < s.end && all; ++i) all = run.reported(run.shards[i]);
            if (all) ::kill(s.pid, SIGTERM);
            int status = 0;
            if (::waitpid(s.pid, &status, all ? 0 : WNOHANG) == s.pid) {
                s.done = true;
                --waiting;
            }
        }
        if (run.poll) run.poll();
        if (waiting > 0) std::this_thread::sleep_for(std::chrono::milliseconds(500));
    }
    Stopping& stop = stopping();
    std::lock_guard lock(stop.mutex);
    stop.slurmJobs.clear();
    stop.sbatch.clear();
}

// The job id in sbatch's log; --parsable writes it alone on its line (";cluster" after it on a federation),
// warnings may come first.
std::string jobIdOf(const Submission& s)
{
    std::ifstream in(s.log);
    std::string line, job;
    while (job.empty() && std::getline(in, line)) {
        const std::string word = line.substr(0, line.find(';'));
        if (!word.empty() && word.find_first_not_of("0123456789") == std::string::npos) job = word;
    }
    if (job.empty())
        throw Error(
            fmt::format("sbatch did not take the job ({}); check the cluster (sinfo) and the options "
                        "given with --slurm-arg, then run rig-batch again: finished shards are kept",
                        lastLine(s.log)));
    return job;
}

}  // namespace

void checkSlurm(const BackendRun& run)
{
    std::string command = "sbatch --test-only";
    for (const auto& option : taskOptions(run)) {
        command += ' ';
        command += shellQuote(option);
    }
    command += " --wrap=true 2>&1";
    FILE* pipe = ::popen(command.c_str(), "r");
    if (!pipe) throw Error(fmt::format("--backend slurm: cannot run sbatch ({})", std::strerror(errno)));
    std::string output, last;
    char buffer[4096];
    while (std::fgets(buffer, sizeof(buffer), pipe)) output += buffer;
    const int status = ::pclose(pipe);
    std::stringstream lines(output);
    for (std::string line; std::getline(lines, line);)
        if (!line.empty()) last = line;
    if (status != 0)
        throw Error(
            fmt::format("--backend slurm: sbatch would not take the shards' tasks ({}); check the cluster "
                        "(sinfo) and the --slurm-* options",
                        last.empty() ? "no reason given" : last));
}

ProcessNotes runSlurm(const BackendRun& run)
{
    std::filesystem::create_directories(run.folder / "slurm");
    std::vector<Submission> submissions;
    for (std::size_t begin = 0; begin < run.shards.size(); begin += slurmArrayTasks)
        submissions.push_back(submitArray(run, begin, fmt::format("round-{}-{}", run.round, submissions.size())));
    waitForArrays(run, submissions);
    // What a shard's note says when its task ends without a status.
    ProcessNotes notes;
    for (const Submission& s : submissions) {
        const std::string job = jobIdOf(s);
        for (std::size_t i = s.begin; i < s.end; ++i)
            notes[run.shards[i]] = fmt::format(
                "the Slurm task (job {}, array index {}) ended without a status: killed, out of memory or over its "
                "time limit; its output: {}",
                job, i - s.begin, (run.folder / "logs" / fmt::format("slurm-{}_{}.out", job, i - s.begin)).string());
    }
    return notes;
}

}  // namespace rig::app
