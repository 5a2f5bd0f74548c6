// bvh2rig: writes a forward-kinematics rig (YAML) for a BVH motion file (nodes/clips/bvh_rig.h). docs/bvh.md.
#include <iostream>

#include <fmt/format.h>

#include "app/output_file.h"
#include "core/error.h"
#include "nodes/clips/bvh_rig.h"
#include "tools/cli_common.h"

namespace rig {
namespace {

struct Options {
    std::string clip;
    std::string output;
    BvhRigOptions rig;
};

int run(const Options& options)
{
    // A bad -o is reported before the clip is read.
    app::checkOutputFile(options.output, "rig.yaml");
    app::checkDistinctFiles({{"the clip", options.clip}}, {{"-o", options.output}});
    const BvhClip clip = readBvhFile(options.clip);
    for (const auto& w : clip.warnings) std::cerr << "warning: " << oneLine(w) << '\n';
    const BvhRig rig = bvhRig(clip, options.clip, options.rig);
    app::writeFileAtomically(options.output, rig.text);
    std::cout << fmt::format("wrote {}: {} joints ({} from BVH joints, {} End Sites{}), {} parameters{}\n",
                             options.output, rig.joints, clip.joints.size(), rig.endSites,
                             rig.helpers ? fmt::format(", {} helpers", rig.helpers) : "", clip.channelCount,
                             rig.clipNode.empty() ? "" : fmt::format(", driven by bvhClip '{}'", rig.clipNode));
    return 0;
}

}  // namespace
}  // namespace rig

int main(int argc, char** argv)
{
    rig::Options options;
    CLI::App app{
        "bvh2rig: write a forward-kinematics rig (YAML) for a BVH motion file.\n\n"
        "Example:\n"
        "  bvh2rig walk.bvh -o walk.yaml --with-motion\n"
        "  graph-eval walk.yaml --frames 1:100 --get '*.worldMatrix'\n\n"
        "One joint per BVH joint (translate = OFFSET, rotateOrder from the channel order), End Sites as\n"
        "leaf joints <joint>_end. The rig's parameters are the rotate (and, for position channels,\n"
        "translate) plugs the channels set; the file's header comment lists them. See docs/bvh.md.",
        "bvh2rig"};
    app.add_option("clip", options.clip, "BVH file")->required();
    app.add_option("-o,--output", options.output, "Rig file to write (YAML)")->required();
    app.add_flag("--with-motion", options.rig.withMotion,
                 "Add a bvhClip node reading the clip (by absolute path) and driving the joints");
    app.add_option("--prefix", options.rig.prefix, "Put this before every node name (e.g. mocap_ or mocap:)");
    return rig::cli::runMain(app, argc, argv, [&] { return rig::run(options); });
}
