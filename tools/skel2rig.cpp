// skel2rig (also installed as bvh2rig): writes a forward-kinematics rig (YAML) for the skeleton of a BVH file or
// of any skeletal animation assimp reads (nodes/clips/bvh_rig.h, nodes/clips/assimp_clip.h). docs/bvh.md,
// docs/clips.md.
#include <filesystem>
#include <iostream>

#include <fmt/format.h>

#include "adapter/first_map.h"
#include "app/common/output_file.h"
#include "core/error.h"
#include "nodes/clips/assimp_clip.h"
#include "nodes/clips/bvh_rig.h"
#include "nodes/clips/target_clip.h"
#include "tools/cli_common.h"

namespace rig {
namespace {

struct Options {
    std::string clip;
    std::string output;
    BvhRigOptions rig;
    std::string mapFor;  // write a first map onto this rig instead of a rig
};

// --map-for: a first map from the clip's skeleton to the rig's joints (adapter/first_map.h).
int writeMap(const Options& options)
{
    app::checkOutputFile(options.output, "map.yaml");
    app::checkDistinctFiles({{"the clip", options.clip}, {"--map-for", options.mapFor}}, {{"-o", options.output}});
    const TargetClip clip = readTargetClip(options.clip, TargetMap{}, options.rig.take);
    const FirstMap map = firstMap({clip.joints, clip.restWorlds, clip.parents}, options.clip,
                                  rigFileSkeleton(options.mapFor), options.mapFor);
    app::writeFileAtomically(options.output, map.text);
    std::cout << fmt::format(
        "wrote {}: {} joints by the same name, {} by name, {} by hierarchy, {} left for a "
        "person; scale {:.10g}{}\n",
        options.output, map.sameName, map.byName, map.byHierarchy, map.unmatched.size(), map.scale,
        map.retarget ? "; retarget (the proportions or rest poses differ)" : "");
    return 0;
}

int run(Options options)
{
    if (!options.mapFor.empty()) return writeMap(options);
    // A bad -o is reported before the clip is read.
    app::checkOutputFile(options.output, "rig.yaml");
    app::checkDistinctFiles({{"the clip", options.clip}}, {{"-o", options.output}});
    const SkeletalClip skeleton = readSkeletalClip(options.clip, options.rig.take);
    const BvhClip& clip = skeleton.clip;
    for (const auto& w : clip.warnings) std::cerr << "warning: " << oneLine(w) << '\n';
    const bool bvh = skeleton.source.format == "BVH";
    options.rig.general = !bvh;
    if (!bvh) options.rig.source = skeleton.source.describe();
    const BvhRig rig = bvhRig(clip, options.clip, options.rig);
    app::writeFileAtomically(options.output, rig.text);
    std::cout << fmt::format(
        "wrote {}: {} joints ({} from {} joints, {} End Sites{}), {} parameters{}\n", options.output, rig.joints,
        clip.joints.size(), skeleton.source.format, rig.endSites,
        rig.helpers ? fmt::format(", {} helpers", rig.helpers) : "", clip.channelCount,
        rig.clipNode.empty() ? "" : fmt::format(", driven by {} '{}'", bvh ? "bvhClip" : "skeletonClip", rig.clipNode));
    if (!bvh) std::cout << fmt::format("source: {}\n", skeleton.source.describe());
    return 0;
}

}  // namespace
}  // namespace rig

int main(int argc, char** argv)
{
    rig::Options options;
    // Called as bvh2rig (the name it had when it read BVH only), it says so in its help.
    const std::string name = argc > 0 ? std::filesystem::path(argv[0]).filename().string() : "skel2rig";
    CLI::App app{
        fmt::format(
            "{}: write a forward-kinematics rig (YAML) for the skeleton of an animation file: BVH, or FBX, glTF,\n"
            "Collada, X, SMD, MD5 and the other formats assimp reads (read by content, in cm and Y up).\n\n"
            "Example:\n"
            "  {} walk.fbx -o walk.yaml --with-motion --take Run\n"
            "  graph-eval walk.yaml --frames 1:100 --get '*.worldMatrix'\n\n"
            "One joint per skeleton joint (translate = its offset, rotateOrder from the channel order), BVH End\n"
            "Sites as leaf joints <joint>_end. The rig's parameters are the rotate (and, for position channels,\n"
            "translate) plugs the channels set; the file's header comment lists them. See docs/bvh.md and\n"
            "docs/clips.md.\n\n"
            "With --map-for RIG.yaml it writes a map file instead (-o MAP.yaml): the clip's joints matched to the\n"
            "rig's by name and hierarchy, the scale from the bone lengths, retargeting when the proportions differ,\n"
            "with comments for a person to check (docs/retargeting.md).",
            name, name),
        name};
    app.add_option("clip", options.clip, "Animation file (BVH, FBX, glTF, Collada, X, ...)")->required();
    app.add_option("-o,--output", options.output, "Rig file to write (YAML)")->required();
    app.add_flag("--with-motion", options.rig.withMotion,
                 "Add a clip node reading the clip (by absolute path) and driving the joints: bvhClip for a BVH "
                 "file, skeletonClip for the others");
    app.add_option("--take", options.rig.take,
                   "The take (animation) whose skeleton and motion to use: a name or 0-based index (default: the "
                   "first)")
        ->check(rig::cli::nonEmpty("a take's name or 0-based index, or leave --take out for the first"));
    auto* prefix =
        app.add_option("--prefix", options.rig.prefix, "Put this before every node name (e.g. mocap_ or mocap:)");
    app.add_option("--map-for", options.mapFor,
                   "Write a first map file (-o MAP.yaml) from the clip's skeleton to this rig's joints instead of a "
                   "rig (docs/retargeting.md)")
        ->excludes(prefix)
        ->excludes(app.get_option("--with-motion"));
    return rig::cli::runMain(app, argc, argv, [&] { return rig::run(options); });
}
