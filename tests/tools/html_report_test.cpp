// rig-invert --html in a real browser: Debian's chromium, headless, opens the page from a file (no network)
// and must run it without a script error, draw the skeletons (the page's own read-back of its 3D view, and a
// screenshot whose 3D view is not one flat colour), and show as many frames as the clip has.
#include <doctest/doctest.h>

#include <png.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include "learned_fixtures.h"
#include "test_support.h"

namespace fs = std::filesystem;
using namespace rig;

namespace {

// Chromium as root needs --no-sandbox; its own profile folder keeps parallel runs apart; swiftshader is
// WebGL without a GPU.
std::string chromium(const fs::path& profile, const std::string& flags, const fs::path& page)
{
    return fmt::format(
        "timeout 120 chromium --headless --no-sandbox --disable-gpu --enable-unsafe-swiftshader "
        "--no-first-run --user-data-dir={} {} file://{}",
        profile.string(), flags, fs::absolute(page).string());
}

struct Image {
    int width = 0;
    int height = 0;
    std::vector<unsigned char> rgba;
};

Image readPng(const fs::path& file)
{
    Image image;
    png_image png{};
    png.version = PNG_IMAGE_VERSION;
    if (!png_image_begin_read_from_file(&png, file.c_str())) return image;
    png.format = PNG_FORMAT_RGBA;
    image.rgba.resize(PNG_IMAGE_SIZE(png));
    if (!png_image_finish_read(&png, nullptr, image.rgba.data(), 0, nullptr)) return {};
    image.width = static_cast<int>(png.width);
    image.height = static_cast<int>(png.height);
    return image;
}

// The variance of the pixels' brightness inside a rectangle.
double variance(const Image& image, int x, int y, int width, int height)
{
    double sum = 0.0, squares = 0.0;
    int n = 0;
    for (int row = std::max(0, y); row < std::min(image.height, y + height); ++row)
        for (int column = std::max(0, x); column < std::min(image.width, x + width); ++column) {
            const unsigned char* p = &image.rgba[4 * (static_cast<std::size_t>(row) * image.width + column)];
            const double v = (p[0] + p[1] + p[2]) / 3.0;
            sum += v;
            squares += v * v;
            ++n;
        }
    return n > 0 ? squares / n - (sum / n) * (sum / n) : 0.0;
}

}  // namespace

TEST_CASE("html report: chromium runs the page without a script error, draws it and shows every frame")
{
    if (!fs::exists(test::cmuClip)) {
        MESSAGE("[skipped] " << test::cmuClip << " is not installed (Debian package assimp-testmodels)");
        return;
    }
    if (test::run("command -v chromium").exitCode != 0) {
        MESSAGE("[skipped] chromium is not installed (scripts/setup.sh installs it)");
        return;
    }
    const auto dir = test::scratchDir("html_report");
    const fs::path page = dir / "report.html";
    const auto r = test::run(fmt::format(
        "{} {} --rig rigs/biped.yaml --map rigs/maps/cmu_to_biped.yaml --clip {} --frames 30:53 --key-tolerance 0.1 "
        "--contacts auto -o {} --html {} --report-json {}",
        test::tool("rig-invert"), test::bipedApproximation().string(), test::cmuClip.string(),
        (dir / "curves.anim").string(), page.string(), (dir / "report.json").string()));
    INFO(r.err);
    REQUIRE(r.exitCode == 0);
    CHECK(r.out.find(fmt::format("report page       {}\n", page.string())) != std::string::npos);
    const std::string html = test::readFile(page);
    // One file: nothing fetched.
    CHECK(html.find("<script src") == std::string::npos);
    CHECK(html.find("<link") == std::string::npos);
    CHECK(html.find("THREE") != std::string::npos);

    // The same window for both runs, so that the view the page reports is where the screenshot has it.
    const std::string window = "--window-size=1200,800";
    const auto dom = test::run(chromium(dir / "profile", "--dump-dom " + window, page));
    INFO(dom.err.substr(0, 2000));
    REQUIRE(dom.exitCode == 0);
    const auto start = dom.out.find("<pre id=\"status\">");
    REQUIRE(start != std::string::npos);
    const auto end = dom.out.find("</pre>", start);
    const std::string text = dom.out.substr(start + 17, end - start - 17);
    INFO(text);
    const YAML::Node status = YAML::Load(text);
    CHECK(status["errors"].size() == 0);
    CHECK(status["ok"].as<bool>());
    CHECK(status["drawn"].as<bool>());
    CHECK(status["frames"].as<int>() == 24);
    CHECK(status["pixels"].as<int>() > 500);
    // The contacts the report has, and their slide in the summary line.
    const int contacts = YAML::LoadFile((dir / "report.json").string())["contacts"]["count"].as<int>();
    CHECK(contacts >= 1);
    CHECK(status["contacts"].as<int>() == contacts);
    CHECK(dom.out.find(fmt::format("; contacts: {}, foot slide on the real rig worst", contacts)) != std::string::npos);

    const fs::path shot = dir / "shot.png";
    const auto screenshot =
        test::run(chromium(dir / "profile", fmt::format("--screenshot={} {}", shot.string(), window), page));
    REQUIRE(screenshot.exitCode == 0);
    const Image image = readPng(shot);
    REQUIRE(image.width == 1200);
    REQUIRE(image.height == 800);
    const auto view = status["view"];
    const double inView = variance(image, view[0].as<int>(), view[1].as<int>(), view[2].as<int>(), view[3].as<int>());
    INFO("3D view brightness variance " << inView);
    CHECK(inView > 5.0);
}
