#include "tools/cli_common.h"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iostream>

#include <fmt/format.h>
#include <sys/stat.h>
#include <unistd.h>

#include "graph/error.h"

namespace rig::cli {

int runMain(CLI::App& app, int argc, char** argv, const std::function<int()>& body)
{
    try {
        app.parse(argc, argv);
    }
    catch (const CLI::CallForHelp& e) {
        return app.exit(e);
    }
    catch (const CLI::ParseError& e) {
        std::cerr << fmt::format("error: {}; run '{} --help' for usage\n", e.what(), app.get_name());
        return 2;
    }
    try {
        return body();
    }
    catch (const Error& e) {
        std::cerr << "error: " << e.what() << '\n';
        return 2;
    }
    catch (const std::exception& e) {
        std::cerr << "internal error: " << e.what() << '\n';
        return 1;
    }
}

std::vector<double> FrameRange::frames() const
{
    std::vector<double> out;
    const auto count = static_cast<long long>(std::floor((last - first) / step + 1e-9));
    // Rounded to 1e-9 frames so 1:2:0.1 gives 1.7, not 1.7000000000000002.
    for (long long i = 0; i <= count; ++i) out.push_back(std::round((first + static_cast<double>(i) * step) * 1e9) / 1e9);
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

void writeFileAtomically(const std::filesystem::path& file, std::string_view content)
{
    const auto folder = file.has_parent_path() ? file.parent_path() : std::filesystem::path(".");
    std::string tmpl = (folder / ("." + file.filename().string() + ".XXXXXX")).string();
    const int fd = mkstemp(tmpl.data());
    if (fd < 0) throw Error(fmt::format("{}: cannot write here ({}); check the folder exists and is writable",
                                        file.string(), std::strerror(errno)));
    bool ok = true;
    for (std::string_view rest = content; ok && !rest.empty();) {
        const ssize_t n = ::write(fd, rest.data(), rest.size());
        ok = n > 0;
        if (ok) rest.remove_prefix(static_cast<std::size_t>(n));
    }
    ok = ::fsync(fd) == 0 && ok;
    ok = ::close(fd) == 0 && ok;
    // mkstemp creates 0600; outputs are ordinary files.
    ::chmod(tmpl.c_str(), 0644);
    if (!ok || std::rename(tmpl.c_str(), file.c_str()) != 0) {
        std::remove(tmpl.c_str());
        throw Error(fmt::format("{}: writing failed ({})", file.string(), std::strerror(errno)));
    }
}

}  // namespace rig::cli
