#include "nodes/clips/clip_isolation.h"

#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <memory>
#include <new>

#include <fcntl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fmt/format.h>

#include "core/error.h"

namespace rig {
namespace {

// The clip as bytes: numbers raw (the child is this very program), strings with their length.
class Writer {
public:
    template <class T>
    void number(T value)
    {
        out_.append(reinterpret_cast<const char*>(&value), sizeof value);
    }
    void text(const std::string& s)
    {
        number<std::uint64_t>(s.size());
        out_ += s;
    }
    std::string& bytes() { return out_; }

private:
    std::string out_;
};

// A reply cut short or malformed: the child died while writing it.
struct CutShort {};

class Reader {
public:
    explicit Reader(const std::string& in) : in_(in) {}
    template <class T>
    T number()
    {
        T value{};
        take(&value, sizeof value);
        return value;
    }
    std::string text()
    {
        const auto size = number<std::uint64_t>();
        if (size > in_.size() - at_) throw CutShort{};
        std::string s = in_.substr(at_, size);
        at_ += size;
        return s;
    }
    bool done() const { return at_ == in_.size(); }

private:
    void take(void* to, std::size_t size)
    {
        if (size > in_.size() - at_) throw CutShort{};
        std::memcpy(to, in_.data() + at_, size);
        at_ += size;
    }
    const std::string& in_;
    std::size_t at_ = 0;
};

enum class Outcome : std::uint8_t { clip, error };

void writeClip(Writer& w, const SkeletalClip& s)
{
    w.number(Outcome::clip);
    w.text(s.source.format);
    w.number(s.source.unitsToCm);
    w.text(s.source.units);
    w.text(s.source.upAxis);
    w.text(s.source.take);
    w.number(s.source.takeIndex);
    w.number(s.source.takeCount);
    w.number(s.source.framesPerSecond);
    const BvhClip& c = s.clip;
    w.text(c.file);
    w.number<std::uint64_t>(c.joints.size());
    for (const BvhJoint& j : c.joints) {
        w.text(j.name);
        w.number(j.parent);
        w.number(j.depth);
        for (int k = 0; k < 3; ++k) w.number(j.offset[k]);
        w.number<std::uint64_t>(j.channels.size());
        for (const BvhChannel channel : j.channels) w.number(channel);
        w.number(j.firstChannel);
        w.number(j.endSite.has_value());
        for (int k = 0; k < 3; ++k) w.number(j.endSite ? (*j.endSite)[k] : 0.0);
        w.number(j.positionReplacesOffset);
        w.number(j.line);
    }
    w.number(c.channelCount);
    w.number(c.frameCount);
    w.number(c.frameTime);
    w.number<std::uint64_t>(c.values.size());
    w.bytes().append(reinterpret_cast<const char*>(c.values.data()), c.values.size() * sizeof(double));
    w.number<std::uint64_t>(c.warnings.size());
    for (const auto& warning : c.warnings) w.text(warning);
}

SkeletalClip readClip(Reader& r)
{
    SkeletalClip s;
    s.source.format = r.text();
    s.source.unitsToCm = r.number<double>();
    s.source.units = r.text();
    s.source.upAxis = r.text();
    s.source.take = r.text();
    s.source.takeIndex = r.number<int>();
    s.source.takeCount = r.number<int>();
    s.source.framesPerSecond = r.number<double>();
    BvhClip& c = s.clip;
    c.file = r.text();
    const auto joints = r.number<std::uint64_t>();
    if (joints > static_cast<std::uint64_t>(bvhMaxJoints)) throw CutShort{};
    for (std::uint64_t i = 0; i < joints; ++i) {
        BvhJoint& j = c.joints.emplace_back();
        j.name = r.text();
        j.parent = r.number<int>();
        j.depth = r.number<int>();
        for (int k = 0; k < 3; ++k) j.offset[k] = r.number<double>();
        const auto channels = r.number<std::uint64_t>();
        if (channels > static_cast<std::uint64_t>(bvhMaxChannelsPerJoint)) throw CutShort{};
        for (std::uint64_t k = 0; k < channels; ++k) j.channels.push_back(r.number<BvhChannel>());
        j.firstChannel = r.number<int>();
        const bool endSite = r.number<bool>();
        Eigen::Vector3d end;
        for (int k = 0; k < 3; ++k) end[k] = r.number<double>();
        if (endSite) j.endSite = end;
        j.positionReplacesOffset = r.number<bool>();
        j.line = r.number<int>();
    }
    c.channelCount = r.number<int>();
    c.frameCount = r.number<int>();
    c.frameTime = r.number<double>();
    const auto values = r.number<std::uint64_t>();
    if (values != static_cast<std::uint64_t>(c.channelCount) * static_cast<std::uint64_t>(c.frameCount))
        throw CutShort{};
    c.values.resize(values);
    for (double& v : c.values) v = r.number<double>();
    const auto warnings = r.number<std::uint64_t>();
    for (std::uint64_t i = 0; i < warnings && i < 1000; ++i) c.warnings.push_back(r.text());
    return s;
}

void writeAll(int fd, const std::string& bytes)
{
    std::size_t done = 0;
    while (done < bytes.size()) {
        const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) return;
        done += static_cast<std::size_t>(n);
    }
}

std::string readAll(int fd)
{
    std::string bytes;
    char buffer[1 << 16];
    for (;;) {
        const ssize_t n = ::read(fd, buffer, sizeof buffer);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) return bytes;
        bytes.append(buffer, static_cast<std::size_t>(n));
    }
}

constexpr std::size_t megabyte = std::size_t{1} << 20;

// The address space the child has from its parent (fork copies it): the memory limit comes on top of it.
std::size_t inheritedBytes()
{
    std::ifstream statm("/proc/self/statm");
    std::size_t pages = 0;
    statm >> pages;
    return pages * static_cast<std::size_t>(::sysconf(_SC_PAGESIZE));
}

void limitChild(const ChildLimits& limits)
{
    const rlimit memory{inheritedBytes() + limits.memoryBytes, inheritedBytes() + limits.memoryBytes};
    ::setrlimit(RLIMIT_AS, &memory);
    // SIGXCPU at the soft limit ends the child; the hard limit one second later is SIGKILL's backstop.
    const rlimit cpu{static_cast<rlim_t>(limits.cpuSeconds), static_cast<rlim_t>(limits.cpuSeconds) + 1};
    ::setrlimit(RLIMIT_CPU, &cpu);
}

void writeError(Writer& w, ErrorKind kind, const std::string& message)
{
    w.bytes().clear();
    w.number(Outcome::error);
    w.number(kind);
    w.text(message);
}

// The child: the reader's clip or its error, as bytes on `fd`; never returns.
[[noreturn]] void runChild(const std::function<SkeletalClip()>& read, const std::string& file,
                           const ChildLimits& limits, int fd, int output)
{
    // What assimp prints (its failed assertions) goes to the parent's file, not the user's terminal.
    ::dup2(output, STDOUT_FILENO);
    ::dup2(output, STDERR_FILENO);
    limitChild(limits);
    Writer w;
    try {
        writeClip(w, read());
    }
    catch (const std::bad_alloc&) {
        writeError(w, ErrorKind::userInput,
                   fmt::format("{}: assimp needed more than its {} MB to read it; the file is damaged or declares "
                               "more than it holds",
                               file, limits.memoryBytes / megabyte));
    }
    catch (const Error& e) {
        writeError(w, e.kind(), e.what());
    }
    catch (const std::exception& e) {
        writeError(w, ErrorKind::userInput, fmt::format("assimp failed: {}", oneLine(e.what(), 200)));
    }
    writeAll(fd, w.bytes());
    ::_exit(0);
}

// Why the child stopped, for a user: the first line it printed (assimp's failed assertion), else the signal.
std::string childFailure(int status, std::FILE* output, const ChildLimits& limits)
{
    if (WIFSIGNALED(status) && WTERMSIG(status) == SIGXCPU)
        return fmt::format("past its limit of {} s of CPU time", limits.cpuSeconds);
    std::string printed;
    std::rewind(output);
    for (int c = std::fgetc(output); c != EOF && c != '\n' && printed.size() < 300; c = std::fgetc(output))
        printed += static_cast<char>(c);
    if (!printed.empty()) return oneLine(printed, 300);
    if (WIFSIGNALED(status))
        return fmt::format("killed by signal {}, {}", WTERMSIG(status), strsignal(WTERMSIG(status)));
    return fmt::format("exit code {}", WIFEXITED(status) ? WEXITSTATUS(status) : -1);
}

}  // namespace

ChildLimits childLimitsFor(std::size_t bytes)
{
    constexpr std::size_t baseMemory = std::size_t{2} << 30;
    return {baseMemory + 32 * bytes, 60 + static_cast<int>(bytes / megabyte)};
}

SkeletalClip readClipIsolated(const std::function<SkeletalClip()>& read, const std::string& file,
                              const ChildLimits& limits)
{
    const std::unique_ptr<std::FILE, int (*)(std::FILE*)> output(std::tmpfile(), &std::fclose);
    int fds[2];
    if (!output || ::pipe2(fds, O_CLOEXEC) != 0)
        throw Error(fmt::format("{}: cannot start the reader's process ({}); check the system's limits", file,
                                std::strerror(errno)));
    const pid_t pid = ::fork();
    if (pid < 0) {
        ::close(fds[0]);
        ::close(fds[1]);
        throw Error(fmt::format("{}: cannot start the reader's process ({}); check the system's limits", file,
                                std::strerror(errno)));
    }
    if (pid == 0) runChild(read, file, limits, fds[1], ::fileno(output.get()));
    ::close(fds[1]);
    const std::string bytes = readAll(fds[0]);
    ::close(fds[0]);
    int status = 0;
    while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
    }
    if (WIFEXITED(status) && WEXITSTATUS(status) == 0 && !bytes.empty()) {
        try {
            Reader r(bytes);
            if (r.number<Outcome>() == Outcome::error) {
                const auto kind = r.number<ErrorKind>();
                throw Error(r.text(), kind);
            }
            SkeletalClip clip = readClip(r);
            if (r.done()) return clip;
        }
        catch (const CutShort&) {
        }
    }
    throw Error(fmt::format("{}: assimp stopped while reading it ({}); the file is damaged, or assimp cannot read it",
                            file, childFailure(status, output.get(), limits)));
}

}  // namespace rig
