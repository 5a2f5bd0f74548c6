#include "app/common/output_file.h"

#include <charconv>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>

#include <fcntl.h>
#include <fmt/format.h>
#include <sys/stat.h>
#include <unistd.h>

#include "core/error.h"

namespace rig::app {

namespace {

std::filesystem::path folderOf(const std::filesystem::path& file)
{
    return file.has_parent_path() ? file.parent_path() : std::filesystem::path(".");
}

// The longest file name `folder` takes (255 bytes on Linux's file systems).
std::size_t longestName(const std::filesystem::path& folder)
{
    const long longest = ::pathconf(folder.c_str(), _PC_NAME_MAX);
    return longest > 0 ? static_cast<std::size_t>(longest) : 255;
}

// The start of `file`'s temporary names: ".NAME.", then "PID.XXXXXX.tmp". Where that would be longer than the
// folder allows (an output name of 235 bytes or more), NAME is cut and a checksum of the whole name follows
// it, so that any legal output name has legal temporary names, distinct from other outputs' in the folder.
std::string temporaryPrefix(const std::filesystem::path& file)
{
    const std::string name = file.filename().string();
    constexpr std::size_t rest = 2 + 10 + 1 + 6 + 4;  // the dots around NAME, PID (10 digits at most), .XXXXXX.tmp
    const std::size_t longest = longestName(folderOf(file));
    if (name.size() + rest <= longest) return "." + name + ".";
    std::uint32_t hash = 0x811c9dc5u;  // FNV-1a 32
    for (const char c : name) hash = (hash ^ static_cast<unsigned char>(c)) * 0x01000193u;
    const std::string tag = fmt::format("~{:08x}", hash);
    const std::size_t keep = longest > rest + tag.size() ? longest - rest - tag.size() : 0;
    // (fmt rather than "." + substr(): GCC 12 warns falsely on that concatenation, -Wrestrict, GCC bug 105329.)
    return fmt::format(".{}{}.", std::string_view(name).substr(0, keep), tag);
}

}  // namespace

std::filesystem::path outputTarget(const std::filesystem::path& file)
{
    // A chain of links ends at the file the user means; the links themselves are kept.
    std::filesystem::path target = file;
    std::error_code ec;
    for (int hops = 0; hops < 40 && std::filesystem::is_symlink(target, ec); ++hops) {
        const std::filesystem::path next = std::filesystem::read_symlink(target, ec);
        if (ec) break;
        target = next.is_absolute() ? next : folderOf(target) / next;
    }
    return target;
}

void checkOutputFile(const std::filesystem::path& file, std::string_view example, std::string_view flag)
{
    if (file.empty()) throw Error(fmt::format("the output file name is empty; give {} FILE", flag));
    std::error_code ec;
    if (std::filesystem::is_directory(file, ec) || !file.has_filename())
        throw Error(fmt::format("{}: is a folder; give a file name, e.g. {} {}", file.string(), flag,
                                (file / example).lexically_normal().string()));
    const std::filesystem::path target = outputTarget(file);
    struct stat st {};
    if (::stat(target.c_str(), &st) == 0) {
        // A FIFO or a device is written through, as a shell's > would; a socket cannot be.
        if (S_ISFIFO(st.st_mode) || S_ISCHR(st.st_mode) || S_ISBLK(st.st_mode)) return;
        if (S_ISSOCK(st.st_mode))
            throw Error(fmt::format("{}: is a socket, not a file; give a file name for {}", file.string(), flag));
        // Root may write anything: the file's own mode says whether its owner meant it to be kept.
        if (S_ISREG(st.st_mode) && (st.st_mode & 0222) == 0)
            throw Error(fmt::format("{}: is read-only; it is not replaced (make it writable, or choose another file)",
                                    file.string()));
    }
    const auto folder = folderOf(target);
    if (!std::filesystem::is_directory(folder, ec))
        throw Error(fmt::format("{}: cannot write here ({}); check the folder exists and is writable", file.string(),
                                std::filesystem::exists(folder, ec) ? "Not a directory" : "No such file or directory"));
    if (const std::size_t length = target.filename().string().size(), longest = longestName(folder); length > longest)
        throw Error(
            fmt::format("{}: the file name is {} bytes long, over the {} its folder's file system allows; "
                        "give a shorter name",
                        file.string(), length, longest));
    // A read-only folder is found now, not after the work (learning a rig can take minutes).
    if (::access(folder.c_str(), W_OK | X_OK) != 0)
        throw Error(fmt::format("{}: cannot write here ({}); check the folder exists and is writable", file.string(),
                                std::strerror(errno)));
}

namespace {

// Where a file is, for telling two names of one file apart: its device and inode when it exists, its
// resolved path when it does not yet.
struct FileIdentity {
    bool exists = false;
    dev_t device = 0;
    ino_t inode = 0;
    std::filesystem::path path;

    explicit FileIdentity(const std::filesystem::path& file)
    {
        struct stat st {};
        if (::stat(file.c_str(), &st) == 0) {
            exists = true;
            device = st.st_dev;
            inode = st.st_ino;
        }
        std::error_code ec;
        path = std::filesystem::weakly_canonical(std::filesystem::absolute(outputTarget(file), ec), ec);
        if (ec) path = std::filesystem::absolute(file, ec).lexically_normal();
    }
    bool same(const FileIdentity& other) const
    {
        return exists && other.exists ? device == other.device && inode == other.inode : path == other.path;
    }
};

}  // namespace

void checkDistinctFiles(const std::vector<NamedFile>& inputs, const std::vector<NamedFile>& outputs)
{
    std::vector<FileIdentity> outputIds;
    for (const NamedFile& out : outputs) {
        if (out.path.empty()) continue;
        const FileIdentity id(out.path);
        // Devices (/dev/null, a terminal) may take several outputs and may be named as inputs too.
        struct stat st {};
        const bool device = ::stat(out.path.c_str(), &st) == 0 && (S_ISCHR(st.st_mode) || S_ISBLK(st.st_mode));
        if (device) continue;
        for (const NamedFile& in : inputs)
            if (!in.path.empty() && id.same(FileIdentity(in.path)))
                throw Error(
                    fmt::format("{} {}: is {} ({}); writing it would destroy an input, choose another output file",
                                out.role, out.path.string(), in.role, in.path.string()));
        for (std::size_t o = 0; o < outputIds.size(); ++o)
            if (id.same(outputIds[o]))
                throw Error(fmt::format("{} {}: is also {} ({}); give each output a file of its own", out.role,
                                        out.path.string(), outputs[o].role, outputs[o].path.string()));
        outputIds.push_back(id);
    }
}

std::vector<std::filesystem::path> staleTemporaryFiles(const std::filesystem::path& file)
{
    std::vector<std::filesystem::path> stale;
    const std::string prefix = temporaryPrefix(file);
    std::error_code ec;
    for (const auto& entry : std::filesystem::directory_iterator(folderOf(file), ec)) {
        const std::string name = entry.path().filename().string();
        if (!name.starts_with(prefix) || !name.ends_with(".tmp")) continue;
        // PID.XXXXXX.tmp after the prefix.
        const std::string_view rest = std::string_view(name).substr(prefix.size());
        long long pid = 0;
        const auto [end, err] = std::from_chars(rest.data(), rest.data() + rest.size(), pid);
        if (err != std::errc() || pid <= 0 || pid > 0x7fffffff ||
            rest.size() != static_cast<std::size_t>(end - rest.data()) + 11 || *end != '.')
            continue;
        if (::kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH) stale.push_back(entry.path());
    }
    return stale;
}

namespace {

// Writes all of `content` to a descriptor; false (errno set) when it cannot.
bool writeAll(int fd, std::string_view content)
{
    for (std::string_view rest = content; !rest.empty();) {
        const ssize_t n = ::write(fd, rest.data(), rest.size());
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) return false;
        rest.remove_prefix(static_cast<std::size_t>(n));
    }
    return true;
}

}  // namespace

namespace {

// A FIFO or a device, opened for writing before the work. A FIFO is opened without waiting: when no process
// reads it, open() fails with ENXIO and the output is refused now rather than block the run at its end.
int openStream(const std::filesystem::path& file, const std::filesystem::path& target, bool fifo, std::string_view flag)
{
    const int fd = ::open(target.c_str(), O_WRONLY | O_CLOEXEC | (fifo ? O_NONBLOCK : 0));
    if (fd < 0 && fifo && errno == ENXIO)
        throw Error(fmt::format("{}: is a FIFO that no process reads; start its reader first, or give a file for {}",
                                file.string(), flag));
    if (fd < 0)
        throw Error(fmt::format("{}: cannot write here ({}); check the folder exists and is writable", file.string(),
                                std::strerror(errno)));
    // Once open, a slow reader is waited for, as a shell's > would.
    if (fifo) ::fcntl(fd, F_SETFL, ::fcntl(fd, F_GETFL) & ~O_NONBLOCK);
    return fd;
}

Error writingFailed(const std::filesystem::path& file, int error)
{
    return Error(fmt::format("{}: writing failed ({}); check the free space and the folder's permissions",
                             file.string(), std::strerror(error)));
}

// Writes `content` to a new temporary file beside `target`, with the mode the output will have, and returns
// its name; throws (nothing left behind) when it cannot.
std::string stage(const std::filesystem::path& file, const std::filesystem::path& target, std::string_view content)
{
    struct stat st {};
    const bool exists = ::stat(target.c_str(), &st) == 0;
    for (const auto& old : staleTemporaryFiles(target)) {
        std::error_code ec;
        std::filesystem::remove(old, ec);
    }
    std::string tmpl =
        (folderOf(target) / fmt::format("{}{}.XXXXXX.tmp", temporaryPrefix(target), ::getpid())).string();
    const int fd = mkstemps(tmpl.data(), 4);
    if (fd < 0)
        throw Error(fmt::format("{}: cannot write here ({}); check the folder exists and is writable", file.string(),
                                std::strerror(errno)));
    bool ok = writeAll(fd, content);
    int error = ok ? 0 : errno;
    if (::fsync(fd) != 0 && ok) {
        ok = false;
        error = errno;
    }
    // mkstemps creates 0600: an existing file keeps its mode, a new one gets what the umask allows.
    mode_t mode = 0666;
    if (exists) mode = st.st_mode & 07777;
    else {
        const mode_t mask = ::umask(0);
        ::umask(mask);
        mode &= ~mask;
    }
    if (::fchmod(fd, mode) != 0 && ok) {
        ok = false;
        error = errno;
    }
    if (::close(fd) != 0 && ok) {
        ok = false;
        error = errno;
    }
    if (!ok) {
        std::remove(tmpl.c_str());
        throw writingFailed(file, error);
    }
    return tmpl;
}

}  // namespace

OutputFiles::~OutputFiles()
{
    removeTemporaries();
    for (const Output& o : outputs_)
        if (o.stream >= 0) ::close(o.stream);
}

void OutputFiles::add(const std::filesystem::path& file, std::string_view example, std::string_view flag)
{
    checkOutputFile(file, example, flag);
    Output out;
    out.file = file;
    // A link is followed: the file it names is replaced, the link stays a link.
    out.target = outputTarget(file);
    struct stat st {};
    if (::stat(out.target.c_str(), &st) == 0 && (S_ISFIFO(st.st_mode) || S_ISCHR(st.st_mode) || S_ISBLK(st.st_mode)))
        out.stream = openStream(file, out.target, S_ISFIFO(st.st_mode), flag);
    outputs_.push_back(std::move(out));
}

OutputFiles::Output& OutputFiles::find(const std::filesystem::path& file)
{
    for (Output& o : outputs_)
        if (o.file == file) return o;
    throw Error(fmt::format("{}: written without being checked first", file.string()), ErrorKind::internal);
}

void OutputFiles::set(const std::filesystem::path& file, std::string content)
{
    Output& o = find(file);
    o.content = std::move(content);
    o.given = true;
}

void OutputFiles::removeTemporaries()
{
    for (Output& o : outputs_)
        if (!o.temporary.empty()) {
            std::remove(o.temporary.c_str());
            o.temporary.clear();
        }
}

void OutputFiles::commit()
{
    try {
        for (Output& o : outputs_)
            if (o.given && o.stream < 0) o.temporary = stage(o.file, o.target, o.content);
        // Renaming over a FIFO or a device (/dev/null) would replace it with a plain file: they are streamed.
        for (const Output& o : outputs_)
            if (o.given && o.stream >= 0 && !writeAll(o.stream, o.content)) throw writingFailed(o.file, errno);
        for (Output& o : outputs_) {
            if (o.temporary.empty()) continue;
            if (std::rename(o.temporary.c_str(), o.target.c_str()) != 0) throw writingFailed(o.file, errno);
            o.temporary.clear();
        }
    }
    catch (...) {
        removeTemporaries();
        throw;
    }
}

void writeFileAtomically(const std::filesystem::path& file, std::string_view content)
{
    OutputFiles out;
    out.add(file);
    out.set(file, std::string(content));
    out.commit();
}

}  // namespace rig::app
