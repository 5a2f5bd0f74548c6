#include "app/output_file.h"

#include <charconv>
#include <cmath>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iostream>

#include <fcntl.h>
#include <fmt/format.h>
#include <sys/stat.h>
#include <unistd.h>

#include "core/error.h"

namespace rig::app {

namespace {

// CLI11 says "Could not convert: --frames = abc" when a value is not of its option's type; say what the
// option takes instead (every typed option of the tools is a number or a list of numbers).
std::string conversionMessage(const CLI::App& app, const std::string& what)
{
    constexpr std::string_view prefix = "Could not convert: ";
    const auto equals = what.find(" = ");
    if (!what.starts_with(prefix) || equals == std::string::npos) return what;
    const std::string name = what.substr(prefix.size(), equals - prefix.size());
    const std::string value = what.substr(equals + 3);
    const CLI::Option* option = app.get_option_no_throw(name);
    const std::string type = option ? option->get_type_name() : std::string();
    const std::string_view kind = type.find("FLOAT") != std::string::npos ? "a number"
                                  : type.find("INT") != std::string::npos ? "a whole number in range"
                                                                          : "a value this option takes";
    return fmt::format("{}: '{}' is not {}", name, messageExcerpt(value), kind);
}

}  // namespace

int runMain(CLI::App& app, int argc, char** argv, const std::function<int()>& body)
{
    try {
        app.parse(argc, argv);
    }
    catch (const CLI::CallForHelp& e) {
        return app.exit(e);
    }
    catch (const CLI::ConversionError& e) {
        std::cerr << fmt::format("error: {}; run '{} --help' for usage\n", oneLine(conversionMessage(app, e.what())),
                                 app.get_name());
        return 2;
    }
    catch (const CLI::ParseError& e) {
        std::cerr << fmt::format("error: {}; run '{} --help' for usage\n", oneLine(e.what()), app.get_name());
        return 2;
    }
    // Messages quote what the user wrote (a name with a newline in it, a 10 MB line): oneLine keeps
    // them one printable line of bounded length.
    try {
        return body();
    }
    catch (const Error& e) {
        switch (e.kind()) {
            case ErrorKind::userInput:
                std::cerr << "error: " << oneLine(e.what()) << '\n';
                return 2;
            case ErrorKind::numerical:
                std::cerr << "error: " << oneLine(e.what()) << '\n';
                return 3;
            case ErrorKind::internal:
                break;
        }
        std::cerr << "internal error: " << oneLine(e.what()) << '\n';
        return 1;
    }
    catch (const std::bad_alloc&) {
        std::cerr << "error: out of memory; the input is too large for this machine (see docs/robustness.md for "
                     "the limits)\n";
        return 2;
    }
    catch (const std::exception& e) {
        std::cerr << "internal error: " << oneLine(e.what()) << '\n';
        return 1;
    }
}

CLI::Validator threadCount()
{
    return CLI::Validator(
        [](std::string& text) {
            int n = -1;
            const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), n);
            if (ec != std::errc() || end != text.data() + text.size() || n < 0 || n > 1024)
                return fmt::format("'{}' is not a thread count; give a whole number from 0 (all cores) to 1024", text);
            return std::string();
        },
        "0..1024");
}

std::vector<double> FrameRange::frames() const
{
    std::vector<double> out;
    const auto count = static_cast<long long>(std::floor((last - first) / step + 1e-9));
    // Rounded to 1e-9 frames so 1:2:0.1 gives 1.7, not 1.7000000000000002.
    for (long long i = 0; i <= count; ++i) {
        const double frame = first + static_cast<double>(i) * step;
        // (Far from 0 the rounding would overflow, and a double has no 1e-9 digits there anyway.)
        out.push_back(std::abs(frame) < 1e6 ? std::round(frame * 1e9) / 1e9 : frame);
    }
    return out;
}

FrameRange parseFrameRange(std::string_view text, std::string_view flag)
{
    auto bad = [&](std::string_view why) {
        return Error(fmt::format("{} '{}': {}; expected A:B[:STEP], e.g. 1:240 or 1:240:2", flag, text, why));
    };
    std::vector<double> parts;
    std::string_view rest = text;
    while (true) {
        const auto colon = rest.find(':');
        const std::string_view piece = rest.substr(0, colon);
        double x = 0.0;
        const auto [end, ec] = std::from_chars(piece.data(), piece.data() + piece.size(), x);
        if (piece.empty() || ec != std::errc() || end != piece.data() + piece.size() || !std::isfinite(x))
            throw bad(fmt::format("'{}' is not a number", piece));
        parts.push_back(x);
        if (colon == std::string_view::npos) break;
        rest.remove_prefix(colon + 1);
    }
    if (parts.size() < 2 || parts.size() > 3) throw bad("give two or three numbers");
    FrameRange range{parts[0], parts[1], parts.size() == 3 ? parts[2] : 1.0};
    if (range.step <= 0) throw bad("the step must be positive");
    if (range.last < range.first) throw bad("the last frame is before the first");
    if ((range.last - range.first) / range.step > 1e7) throw bad("more than ten million frames");
    return range;
}

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
    return "." + name.substr(0, keep) + tag + ".";
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

void writeFileAtomically(const std::filesystem::path& file, std::string_view content)
{
    checkOutputFile(file);
    // A link is followed: the file it names is replaced, the link stays a link.
    const std::filesystem::path target = outputTarget(file);
    struct stat st {};
    const bool exists = ::stat(target.c_str(), &st) == 0;
    if (exists && (S_ISFIFO(st.st_mode) || S_ISCHR(st.st_mode) || S_ISBLK(st.st_mode))) {
        // Streamed: renaming over a FIFO or a device (/dev/null) would replace it with a plain file.
        const int fd = ::open(target.c_str(), O_WRONLY | O_CLOEXEC);
        if (fd < 0 || !writeAll(fd, content)) {
            const int error = errno;
            if (fd >= 0) ::close(fd);
            throw Error(fmt::format("{}: writing failed ({})", file.string(), std::strerror(error)));
        }
        ::close(fd);
        return;
    }
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
    if (ok && std::rename(tmpl.c_str(), target.c_str()) != 0) {
        ok = false;
        error = errno;
    }
    if (!ok) {
        std::remove(tmpl.c_str());
        throw Error(fmt::format("{}: writing failed ({}); check the free space and the folder's permissions",
                                file.string(), std::strerror(error)));
    }
}

}  // namespace rig::app
