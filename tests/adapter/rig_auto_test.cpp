// rig-learn --params auto and --outputs auto (adapter/rig_auto.h, GraphRigOptions::autoParameters): the channels of a
// Maya scene's controls, the joints its skins bind, the time curves cut, the settings held, the spec that says so;
// on tests/corpus/maya/auto_controls.ma and, where ../shared/maya is present, on the public scenes.
#include <doctest/doctest.h>

#include <algorithm>
#include <filesystem>
#include <numbers>

#include "adapter/graph_rig_function.h"
#include "adapter/inversion_spec.h"
#include "adapter/rig_auto.h"
#include "graph/rig_file.h"
#include "nodes/builtin_nodes.h"
#include "test_support.h"

namespace {

using namespace rig;
namespace fs = std::filesystem;

const fs::path scene = test::sourceDir() / "tests/corpus/maya/auto_controls.ma";

GraphRigOptions autoOptions()
{
    GraphRigOptions options;
    options.autoParameters = true;
    options.autoOutputs = true;
    options.cutTimeCurves = true;
    return options;
}

std::vector<std::string> parameterNames(const GraphRigFunction& rig)
{
    std::vector<std::string> names;
    for (const RigParameter& p : rig.parameters()) names.push_back(p.name);
    return names;
}

std::vector<std::string> passedText(const AutoChoice& choice)
{
    std::vector<std::string> text;
    for (const PassedChannel& p : choice.passed) text.push_back(p.plug + ": " + p.why);
    return text;
}

}  // namespace

TEST_CASE("rig auto: the scene's controls and the joints its skin binds")
{
    MayaSceneInfo info;
    auto g = loadRigFile(scene, makeBuiltinRegistry(), nullptr, &info);
    // The shape that is an intermediate object adds nothing; a curve control that reaches no joint is a control.
    CHECK(info.controls == std::vector<std::string>{"arm_ctrl", "prop_ctrl"});
    const AutoOutputs outputs = autoOutputJoints(*g, info);
    CHECK(outputs.skins == 1);
    REQUIRE(outputs.joints.size() == 2);  // not the tip, which the skin does not bind
    CHECK(g->nodeName(outputs.joints[0]) == "shoulder");
    CHECK(g->nodeName(outputs.joints[1]) == "elbow");
    // A time curve keys elbow.rotateZ; a set-driven key, which the rig's twist drives, is no time curve.
    CHECK(timeCurveInput(*g, g->plug("elbow.rotateZ")) != nullptr);
    CHECK(timeCurveInput(*g, g->plug("elbow.rotateY")) == nullptr);
    CHECK(timeCurveInput(*g, g->plug("elbow.rotateX")) == nullptr);

    const ControlChannels channels = controlChannels(*g, info, outputs.joints);
    CHECK(channels.controls == std::vector<std::string>{"arm_ctrl", "elbow", "prop_ctrl"});
    REQUIRE(channels.settings.size() == 1);  // the one-name enum 'label' is no switch
    CHECK(g->plugName(channels.settings[0]) == "arm_ctrl.mode");
}

TEST_CASE("rig auto: parameters are the keyable, unlocked channels that move an output, time curves cut")
{
    const GraphRigFunction rig(scene, autoOptions());
    CHECK(parameterNames(rig) ==
          std::vector<std::string>{"arm_ctrl.translateY", "arm_ctrl.translateZ", "arm_ctrl.rotateX", "arm_ctrl.rotateY",
                                   "arm_ctrl.rotateZ", "arm_ctrl.scaleY", "arm_ctrl.scaleZ", "arm_ctrl.twist",
                                   "elbow.translateX", "elbow.translateY", "elbow.translateZ", "elbow.rotateX",
                                   "elbow.rotateZ", "elbow.scaleX", "elbow.scaleY", "elbow.scaleZ"});
    const AutoChoice& choice = rig.autoChoice();
    CHECK(passedText(choice) == std::vector<std::string>{"arm_ctrl.translateX: locked", "arm_ctrl.scaleX: not keyable",
                                                         "elbow.rotateY: driven by twist_sdk.output",
                                                         "arm_ctrl.bend: moves no output"});
    CHECK(choice.cutCurves == std::vector<std::string>{"elbow.rotateZ"});
    CHECK(choice.skins == 1);
    CHECK(choice.settings == std::vector<std::string>{"arm_ctrl.mode"});
    CHECK(choice.probeEvaluations > 0);
    REQUIRE(rig.held().size() == 1);
    CHECK(rig.held()[0].plug == "arm_ctrl.mode");
    CHECK(rig.held()[0].value == 1.0);
    // The joints the skin binds, then helpers (none here: nothing reads a transform's matrix).
    CHECK(rig.outputs() == std::vector<std::string>{"shoulder", "elbow"});
    // The cut channel starts at the curve's value at the saved time, and the learner sets it.
    const auto& params = rig.parameters();
    const std::vector<std::string> names = parameterNames(rig);
    const auto rz = static_cast<std::size_t>(std::find(names.begin(), names.end(), "elbow.rotateZ") - names.begin());
    REQUIRE(rz < names.size());
    CHECK(params[rz].defaultValue == doctest::Approx(30.0 * std::numbers::pi / 180.0));
    auto copy = rig.instance();
    std::vector<double> values;
    for (const RigParameter& p : params) values.push_back(p.defaultValue);
    std::vector<Eigen::Matrix4d> rest, bent;
    copy->evaluate(values, rest);
    values[rz] += 0.5;
    copy->evaluate(values, bent);
    CHECK((rest[1] - bent[1]).norm() > 0.1);
}

TEST_CASE("rig auto: globs and held plugs come first, auto adds the rest")
{
    GraphRigOptions options = autoOptions();
    options.parameterGlobs = {"elbow.rotateZ"};
    options.held = {{"arm_ctrl.twist", 5.0}};
    const GraphRigFunction rig(scene, options);
    const std::vector<std::string> names = parameterNames(rig);
    CHECK(names.front() == "elbow.rotateZ");
    CHECK(std::count(names.begin(), names.end(), "elbow.rotateZ") == 1);
    CHECK(std::count(names.begin(), names.end(), "arm_ctrl.twist") == 0);
    CHECK(rig.held().size() == 2);
    CHECK(rig.autoChoice().cutCurves == std::vector<std::string>{"elbow.rotateZ"});
}

TEST_CASE("rig auto: a time curve's channel is a parameter only where curves are cut")
{
    GraphRigOptions options;
    options.parameterGlobs = {"elbow.rotate?"};
    CHECK(parameterNames(GraphRigFunction(scene, options)) == std::vector<std::string>{"elbow.rotateX"});
    options.parameterGlobs = {"elbow.rotateZ"};
    CHECK(test::errorOf([&] { GraphRigFunction(scene, options); }) ==
          scene.string() +
              ": parameter 'elbow.rotateZ' is driven by elbow_rotateZ.output; parameters are animator controls that "
              "nothing drives");
    options.cutTimeCurves = true;
    options.parameterGlobs = {"elbow.rotate?"};
    CHECK(parameterNames(GraphRigFunction(scene, options)) ==
          std::vector<std::string>{"elbow.rotateX", "elbow.rotateZ"});
}

TEST_CASE("rig auto: a YAML rig has no controls to find, and its auto outputs are every joint")
{
    const fs::path arm = test::sourceDir() / "rigs/examples/arm.yaml";
    GraphRigOptions options;
    options.autoParameters = true;
    CHECK(test::errorOf([&] { GraphRigFunction(arm, options); }) ==
          arm.string() +
              ": parameters 'auto' are the keyable channels of a Maya scene's controls (transforms with a nurbsCurve "
              "shape), and this is a YAML rig; name its parameters with plug globs such as 'L_arm_*.rotate?'");
    options.autoParameters = false;
    options.autoOutputs = true;
    options.parameterGlobs = {"shoulder.rotateZ"};
    const GraphRigFunction rig(arm, options);
    CHECK(rig.outputs() == std::vector<std::string>{"shoulder", "elbow", "wrist"});
    CHECK(rig.autoChoice().skins == 0);
}

TEST_CASE("rig auto: a spec written reads back the same, names with Maya's ':' and '|' and a quote")
{
    InversionSpec spec;
    spec.params = {"hero:L_arm|ctrl.rotateX", "it's.bend"};
    spec.outputs = {"hero:L_arm_jnt"};
    spec.autoHelpers = true;
    spec.set = {{"hero:settings.ikFk", 1}, {"a.b", 0.1}};
    spec.ranges = {{"*.bend", -2.5, 7}};
    const fs::path file = test::scratchDir("rig-auto-spec") / "spec.yaml";
    test::writeFile(file, inversionSpecYaml(spec, {"a comment", ""}));
    CHECK(
        test::readFile(file).starts_with("# a comment\n#\nparams:\n  - 'hero:L_arm|ctrl.rotateX'\n  - 'it''s.bend'\n"));
    const InversionSpec back = readInversionSpec(file);
    CHECK(back.params == spec.params);
    CHECK(back.outputs == spec.outputs);
    CHECK(back.autoHelpers);
    REQUIRE(back.set.size() == 2);
    CHECK(back.set[1].plug == "a.b");
    CHECK(back.set[1].value == 0.1);
    REQUIRE(back.ranges.size() == 1);
    CHECK(back.ranges[0].min == -2.5);
    // 'auto' written for a list auto chose, and read back as auto.
    spec.autoParams = true;
    spec.autoOutputs = true;
    spec.outputs.clear();
    test::writeFile(file, inversionSpecYaml(spec));
    const InversionSpec automatic = readInversionSpec(file);
    CHECK(automatic.autoParams);
    CHECK(automatic.params == spec.params);
    CHECK(automatic.autoOutputs);
    CHECK(automatic.outputs.empty());
    CHECK(test::readFile(file).find("outputs: auto\n") != std::string::npos);
}

TEST_CASE("rig auto: the public Maya scenes' controls and joints, where ../shared/maya is present")
{
    const fs::path folder = test::sourceDir() / "../shared/maya";
    if (!fs::is_directory(folder)) {
        MESSAGE("[skipped] ../shared/maya is absent");
        return;
    }
    struct Expected {
        const char* scene;
        std::size_t parameters, joints, held, cut;
    };
    // Measured (docs/rig-learn.md): parameters, output joints, settings held, time curves cut.
    const Expected expected[] = {
        {"I-LoveBees__Maya/mimic_RigTestAnim.ma", 32, 6, 0, 8},
        {"samuelmoores__Infinity/InfinityMaya/Scenes/Grunt_Rig.ma", 77, 52, 1, 0},
        {"samuelmoores__Infinity/InfinityMaya/Scenes/Grunt_Run.ma", 77, 52, 0, 77},
        {"sweet4lorie__MonsterRobotRunner/ART/C_Robot/C_Robot_Rig.ma", 102, 33, 0, 0},
        {"sweet4lorie__MonsterRobotRunner/ART/C_Robot/C_Robot_Run.ma", 102, 33, 0, 102},
        {"Squamashii__UVUFall2008/Rigging/SpiderBot/Spencer_SpiderBot_Anim_001.ma", 87, 43, 0, 87},
        {"Autodesk__maya-usd/test/lib/usd/translators/UsdExportSkeletonTest/UsdExportSkeleton.ma", 225, 25, 0, 222},
    };
    for (const Expected& e : expected) {
        CAPTURE(e.scene);
        const GraphRigFunction rig(folder / e.scene, autoOptions());
        const std::vector<char> helper = rig.helperOutputs();
        CHECK(rig.parameters().size() == e.parameters);
        CHECK(static_cast<std::size_t>(std::count(helper.begin(), helper.end(), 0)) == e.joints);
        CHECK(rig.held().size() == e.held);
        CHECK(rig.autoChoice().cutCurves.size() == e.cut);
    }
}
