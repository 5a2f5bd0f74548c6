// rig-bench's maya_scenes row (bench/bench_maya.h) on an animated scene of our own: tests/corpus/maya/arm_keyed.ma, a
// rig whose controls its own time curves key, learned with auto parameters and inverted on its own animation. The
// public scenes' rows are rig-bench's run (docs/maya.md).
#include <doctest/doctest.h>

#include <filesystem>

#include "bench/bench_maya.h"
#include "test_support.h"

using namespace rig;

TEST_CASE("rig-bench maya_scenes: a keyed scene of our own is learned as it comes, reached, and OUT.ma replays it")
{
    const auto dir = test::scratchDir("maya_scenes_row");
    std::filesystem::copy_file(test::sourceDir() / "tests/corpus/maya/arm_keyed.ma", dir / "arm_keyed.ma");
    const bench::Json row =
        bench::mayaScenesJson(dir, dir, {}, {{"arm_keyed.ma", "arm_keyed.ma"}, {"absent.ma", "absent.ma"}});
    REQUIRE(row.at("scenes").size() == 1);  // a scene absent from the folder is left out
    const bench::Json& scene = row.at("scenes")[0];
    INFO(scene.dump());
    CHECK(scene.at("clip") == "arm_keyed.ma");
    CHECK(scene.at("joints") == 3);
    CHECK(scene.at("parameters_found") == 13);
    CHECK(scene.at("unmodelled_outputs") == 0);
    CHECK(scene.at("within_epsilon") == true);
    CHECK(scene.at("worst_relative_error_cm").get<double>() <= 1e-3);
    CHECK(scene.at("training_evaluations").get<int>() > 0);
    CHECK(scene.at("frames") == 20);
    CHECK(scene.at("reached") == 20);
    CHECK(scene.at("status_frames").at("reached") == 20);
    // OUT.ma plays in the rig what rig-invert measured: every frame reached, within round-off of the clip.
    CHECK(scene.at("real_rig_worst_cm").get<double>() < 1e-3);
    CHECK(scene.at("replay_worst_cm").get<double>() == doctest::Approx(scene.at("real_rig_worst_cm").get<double>()));
    CHECK(scene.at("replay_worst_reached_cm").get<double>() < 1e-3);
    CHECK(std::filesystem::exists(dir / "arm_keyed.out.ma"));
    // Per joint, against the FK biped's per joint in the same run (rig-bench passes its figures).
    const double perFrame = scene.at("cpu_ms_per_frame").get<double>();
    CHECK(perFrame > 0.0);
    CHECK(scene.at("setup_cpu_ms").get<double>() > 0.0);  // the solver's plan, built before the first frame
    CHECK(scene.at("cpu_ms_per_joint").get<double>() == doctest::Approx(perFrame / 3));
    bench::Json compared = row;
    bench::compareWithBiped(compared, 0.062, 31);
    CHECK(compared.at("fk_biped_cpu_ms_per_joint").get<double>() == doctest::Approx(0.002));
    CHECK(compared.at("scenes")[0].at("times_fk_biped_per_joint").get<double>() ==
          doctest::Approx(perFrame / 3 / 0.002));
    // No folder, no row.
    CHECK(bench::mayaScenesJson(dir / "absent", dir, {}).is_null());
}

TEST_CASE("rig-bench maya_scenes: a scene that failed has no per-joint figure to compare")
{
    bench::Json scenes{{"scenes", bench::Json::array({bench::Json{{"clip", "broken.ma"}, {"error", "no rig"}}})}};
    bench::compareWithBiped(scenes, 0.06, 30);
    CHECK(scenes.at("fk_biped_cpu_ms_per_joint").get<double>() == doctest::Approx(0.002));
    CHECK_FALSE(scenes.at("scenes")[0].contains("times_fk_biped_per_joint"));
}
