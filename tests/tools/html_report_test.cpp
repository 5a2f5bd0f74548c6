// rig-invert --html in a real browser: Debian's chromium, headless, opens the page from a file (no network)
// and must run it without a script error, draw the skeletons (the page's own read-back of its 3D view, and a
// screenshot whose 3D view is not one flat colour), and show as many frames as the clip has. graph-eval
// --html, a crowd's page: its data are graph-eval's values (characters, frames, the lookAt target), and the
// browser draws it from above and for one character.
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

// The page as chromium's --dump-dom gives it, once its script ran.
std::string pageDom(const fs::path& dir, const fs::path& page, const std::string& window)
{
    const auto dom = test::run(chromium(dir / "profile", "--dump-dom " + window, page));
    INFO(dom.err.substr(0, 2000));
    REQUIRE(dom.exitCode == 0);
    return dom.out;
}

// The #status the page wrote, in its dumped DOM.
YAML::Node statusOf(const std::string& dom)
{
    const auto start = dom.find("<pre id=\"status\">");
    REQUIRE(start != std::string::npos);
    const auto end = dom.find("</pre>", start);
    return YAML::Load(dom.substr(start + 17, end - start - 17));
}

YAML::Node pageStatus(const fs::path& dir, const fs::path& page, const std::string& window)
{
    return statusOf(pageDom(dir, page, window));
}

// The page's data, as the page reads it (script#report-data).
YAML::Node pageData(const std::string& html)
{
    const std::string open = "<script id=\"report-data\" type=\"application/json\">\n";
    const auto start = html.find(open);
    REQUIRE(start != std::string::npos);
    const auto end = html.find("\n</script>", start);
    return YAML::Load(html.substr(start + open.size(), end - start - open.size()));
}

bool haveCmuClip()
{
    if (fs::exists(test::cmuClip)) return true;
    MESSAGE("[skipped] " << test::cmuClip << " is not installed (Debian package assimp-testmodels)");
    return false;
}

bool haveChromium()
{
    if (test::run("command -v chromium").exitCode != 0) {
        MESSAGE("[skipped] chromium is not installed (scripts/setup.sh installs it)");
        return false;
    }
    return true;
}

}  // namespace

TEST_CASE("html report: chromium runs the page without a script error, draws it and shows every frame")
{
    if (!haveCmuClip() || !haveChromium()) return;
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
    const std::string dom = pageDom(dir, page, window);
    const YAML::Node status = statusOf(dom);
    INFO(YAML::Dump(status));
    CHECK(status["errors"].size() == 0);
    CHECK(status["ok"].as<bool>());
    CHECK(status["drawn"].as<bool>());
    CHECK(status["frames"].as<int>() == 24);
    CHECK(status["pixels"].as<int>() > 500);
    // The contacts the report has, and their slide in the summary line.
    const int contacts = YAML::LoadFile((dir / "report.json").string())["contacts"]["count"].as<int>();
    CHECK(contacts >= 1);
    CHECK(status["contacts"].as<int>() == contacts);
    CHECK(dom.find(fmt::format("; contacts: {}, foot slide on the real rig worst", contacts)) != std::string::npos);

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

TEST_CASE("graph-eval --html: the crowd's page holds graph-eval's values and chromium draws it both ways")
{
    if (!haveCmuClip()) return;
    const auto dir = test::scratchDir("html_report_crowd");
    const fs::path crowd = test::writeCrowd(dir, 2), page = dir / "crowd.html", values = dir / "values.json";
    const auto r =
        test::run(fmt::format("{} {} --frames 1:6 --threads 2 --get camera.worldMatrix --get "
                              "'c*:inverter.status' --get 'c*:inverter.worstErrorCm' -o {} --html {}",
                              test::tool("graph-eval"), crowd.string(), values.string(), page.string()));
    INFO(r.err);
    REQUIRE(r.exitCode == 0);
    const std::string html = test::readFile(page);
    CHECK(html.find("<script src") == std::string::npos);
    // 64 characters over 120 frames make about 11 MB (docs/keys-anim-report.md): two over six, under 1 MB of
    // data beside three.js.
    CHECK(html.size() < test::readFile("/usr/share/javascript/three/three.min.js").size() + 1000000);

    const YAML::Node data = pageData(html), played = YAML::LoadFile(values.string());
    REQUIRE(data["frames"].size() == 6);
    REQUIRE(played.size() == 6);
    CHECK(data["open"].as<int>() == -1);
    REQUIRE(data["characters"].size() == 2);
    REQUIRE(data["markers"].size() == 1);
    CHECK(data["markers"][0]["name"].as<std::string>() == "camera.translate");
    CHECK(data["markers"][0]["scale"].as<double>() == 5.644444444444445);  // rigs/maps/cmu_to_biped.yaml
    const auto statusNames = data["status_names"];
    for (int c = 0; c < 2; ++c) {
        const YAML::Node character = data["characters"][c];
        const std::string name = fmt::format("c000{}", c);
        CAPTURE(name);
        CHECK(character["name"].as<std::string>() == name);
        CHECK(character["inverter"].as<std::string>() == name + ":inverter");
        CHECK(character["joints"].size() == 31);
        CHECK(character["joints"][16].as<std::string>() == "Head");
        CHECK(character["parents"][16].as<int>() == 15);  // Neck1
        CHECK(character["marker"].as<int>() == 0);
        int frames = 0;
        for (const auto& count : character["status_counts"]) frames += count.second.as<int>();
        CHECK(frames == 6);
        for (std::size_t f = 0; f < 6; ++f) {
            CAPTURE(f);
            CHECK(statusNames[character["status"][f].as<int>()].as<std::string>() ==
                  played[f][name + ":inverter.status"].as<std::string>());
            CHECK(std::abs(character["worst_cm"][f].as<double>() -
                           played[f][name + ":inverter.worstErrorCm"].as<double>()) <= 0.0005);
            CHECK(character["rig"][f].size() == 93);
            CHECK(character["target"][f].size() == 93);
        }
    }
    // The marker is where graph-eval puts the camera, bit for bit.
    for (std::size_t f = 0; f < 6; ++f) {
        CAPTURE(f);
        CHECK(data["frames"][f].as<double>() == played[f]["frame"].as<double>());
        for (int i = 0; i < 3; ++i)
            CHECK(data["markers"][0]["positions"][f][i].as<double>() ==
                  played[f]["camera.worldMatrix"][i][3].as<double>());
    }

    const auto unknown = test::run(fmt::format("{} {} --html {} --character c0002", test::tool("graph-eval"),
                                               crowd.string(), (dir / "other.html").string()));
    CHECK(unknown.exitCode == 2);
    CHECK(unknown.err ==
          "error: --character 'c0002': the crowd has no such character (did you mean 'c0000'?); its characters "
          "are c0000, c0001\n");
    CHECK(!fs::exists(dir / "other.html"));

    if (!haveChromium()) return;
    const std::string window = "--window-size=1200,800";
    YAML::Node status = pageStatus(dir, page, window);
    INFO(YAML::Dump(status));
    CHECK(status["errors"].size() == 0);
    CHECK(status["ok"].as<bool>());
    CHECK(status["frames"].as<int>() == 6);
    CHECK(status["characters"].as<int>() == 2);
    CHECK(status["mode"].as<std::string>() == "crowd");
    MESSAGE("crowd from above: " << status["pixels"].as<int>() << " pixels");
    CHECK(status["pixels"].as<int>() > 200);

    // --character: the page opens on that character's view.
    const auto one =
        test::run(fmt::format("{} {} --frames 1:6 --get camera.translate -o {} --html {} --character c0001",
                              test::tool("graph-eval"), crowd.string(), values.string(), page.string()));
    REQUIRE(one.exitCode == 0);
    CHECK(pageData(test::readFile(page))["open"].as<int>() == 1);
    status = pageStatus(dir, page, window);
    CHECK(status["ok"].as<bool>());
    CHECK(status["mode"].as<std::string>() == "character");
    CHECK(status["character"].as<std::string>() == "c0001");
    CHECK(status["pixels"].as<int>() > 500);
}
