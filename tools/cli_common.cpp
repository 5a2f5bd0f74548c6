#include "tools/cli_common.h"

#include <charconv>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iostream>

#include <fmt/format.h>
#include <sys/stat.h>
#include <unistd.h>

#include "graph/error.h"

namespace rig::cli {

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
        std::cerr << "error: " << oneLine(e.what()) << '\n';
        return 2;
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

std::string temporaryPrefix(const std::filesystem::path& file) { return "." + file.filename().string() + "."; }

std::filesystem::path folderOf(const std::filesystem::path& file)
{
    return file.has_parent_path() ? file.parent_path() : std::filesystem::path(".");
}

}  // namespace

void checkOutputFile(const std::filesystem::path& file, std::string_view example, std::string_view flag)
{
    if (file.empty()) throw Error(fmt::format("the output file name is empty; give {} FILE", flag));
    std::error_code ec;
    if (std::filesystem::is_directory(file, ec) || !file.has_filename())
        throw Error(fmt::format("{}: is a folder; give a file name, e.g. {} {}", file.string(), flag,
                                (file / example).lexically_normal().string()));
    const auto folder = folderOf(file);
    if (!std::filesystem::is_directory(folder, ec))
        throw Error(fmt::format("{}: cannot write here ({}); check the folder exists and is writable", file.string(),
                                std::filesystem::exists(folder, ec) ? "Not a directory" : "No such file or directory"));
    // A read-only folder is found now, not after the work (learning a rig can take minutes).
    if (::access(folder.c_str(), W_OK | X_OK) != 0)
        throw Error(fmt::format("{}: cannot write here ({}); check the folder exists and is writable", file.string(),
                                std::strerror(errno)));
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
        if (err != std::errc() || pid <= 0 || pid > 0x7fffffff || rest.size() != static_cast<std::size_t>(end - rest.data()) + 11
            || *end != '.')
            continue;
        if (::kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH) stale.push_back(entry.path());
    }
    return stale;
}

void writeFileAtomically(const std::filesystem::path& file, std::string_view content)
{
    checkOutputFile(file);
    for (const auto& old : staleTemporaryFiles(file)) {
        std::error_code ec;
        std::filesystem::remove(old, ec);
    }
    std::string tmpl = (folderOf(file) / fmt::format("{}{}.XXXXXX.tmp", temporaryPrefix(file), ::getpid())).string();
    const int fd = mkstemps(tmpl.data(), 4);
    if (fd < 0) throw Error(fmt::format("{}: cannot write here ({}); check the folder exists and is writable",
                                        file.string(), std::strerror(errno)));
    bool ok = true;
    for (std::string_view rest = content; ok && !rest.empty();) {
        const ssize_t n = ::write(fd, rest.data(), rest.size());
        ok = n > 0;
        if (ok) rest.remove_prefix(static_cast<std::size_t>(n));
    }
    int error = ok ? 0 : errno;
    if (::fsync(fd) != 0 && ok) {
        ok = false;
        error = errno;
    }
    if (::close(fd) != 0 && ok) {
        ok = false;
        error = errno;
    }
    // mkstemps creates 0600; outputs are ordinary files.
    ::chmod(tmpl.c_str(), 0644);
    if (ok && std::rename(tmpl.c_str(), file.c_str()) != 0) {
        ok = false;
        error = errno;
    }
    if (!ok) {
        std::remove(tmpl.c_str());
        throw Error(fmt::format("{}: writing failed ({}); check the free space and the folder's permissions",
                                file.string(), std::strerror(error)));
    }
}

}  // namespace rig::cli
