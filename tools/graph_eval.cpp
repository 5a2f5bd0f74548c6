// graph-eval: evaluates a rig graph file, setting and reading plugs, over a frame range.
#include <chrono>
#include <filesystem>
#include <iostream>
#include <optional>
#include <set>

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include "app/common/frame_range.h"
#include "app/common/output_file.h"
#include "app/common/value_output.h"
#include "app/eval/crowd_report.h"
#include "app/eval/eval_run.h"
#include "app/report/report_page.h"
#include "core/error.h"
#include "core/table.h"
#include "graph/dot_writer.h"
#include "graph/rig_file.h"
#include "graph/type_reference.h"
#include "graph/yaml_loader.h"
#include "tools/cli_common.h"

namespace rig {
namespace {

struct Options {
    std::string rig;
    std::vector<std::string> sets;
    std::vector<std::string> gets;
    std::string frames;
    bool framesGiven = false;  // --frames given, possibly empty
    std::string format = "json";
    std::string output;
    bool outputGiven = false;  // -o given, possibly with an empty name
    std::vector<std::string> plugins;
    std::string anim;  // a Maya .anim file whose curves drive the rig's plugs
    bool dot = false;
    bool types = false;
    int threads = 1;
    bool stats = false;
    bool check = false;
    std::string html;  // the crowd's report page
    bool htmlGiven = false;
    std::string character;  // the character the page opens on
    bool characterGiven = false;
    std::vector<std::filesystem::path> searchPath;  // where a Maya scene's references are also looked for
};

void applySet(Graph& graph, const std::string& assignment)
{
    const auto eq = assignment.find('=');
    if (eq == std::string::npos)
        throw Error(fmt::format("--set '{}': expected node.attr=VALUE, e.g. --set elbow.rotateZ=45", assignment));
    const std::string name = assignment.substr(0, eq);
    const Plug plug = app::settablePlug(graph, name);
    YAML::Node value;
    bool valid = true;
    try {
        value = YAML::Load(assignment.substr(eq + 1));
        valid = !secondYamlDocument(assignment.substr(eq + 1));
    }
    catch (const YAML::Exception&) {
        valid = false;
    }
    if (!valid)
        throw Error(fmt::format("--set {}: '{}' is not a value; numbers, true/false, names, [x, y, z]", name,
                                assignment.substr(eq + 1)));
    app::setPlug(graph, plug, name, value);
}

std::string joinCsv(const std::vector<std::vector<std::string>>& rows)
{
    std::string out;
    for (const auto& row : rows) {
        for (std::size_t i = 0; i < row.size(); ++i) out += (i ? "," : "") + row[i];
        out += "\n";
    }
    return out;
}

std::string render(Graph& graph, const std::vector<Plug>& plugs, const std::vector<double>& frames, bool useTime,
                   const Options& options, app::CrowdReport* crowd)
{
    std::string out;
    std::vector<std::vector<std::string>> table;
    std::size_t tableBytes = 0;
    bool firstRow = true;
    auto checkSize = [&](std::size_t bytes, std::size_t framesDone) {
        // After the first frame, the size of the whole output is estimated; later the real size is checked.
        const double estimate = framesDone == 1 ? static_cast<double>(bytes) * static_cast<double>(frames.size())
                                                : static_cast<double>(bytes);
        app::checkOutputSize(estimate, frames.size(), plugs.size());
    };
    std::size_t framesDone = 0;
    for (double frame : frames) {
        const std::vector<Value> values = app::evaluateFrame(graph, options.rig, frame, useTime, plugs, options.check);
        if (crowd) crowd->record(graph, frame);
        if (options.format == "json") {
            std::vector<std::pair<std::string, app::Json>> named;
            for (std::size_t i = 0; i < plugs.size(); ++i)
                named.emplace_back(graph.plugName(plugs[i]), app::valueToJson(graph, plugs[i], values[i]));
            out += (firstRow ? "[\n" : ",\n") + app::frameJson(frame, named);
        } else {
            if (firstRow) {
                std::vector<std::string> header{"frame"};
                for (std::size_t i = 0; i < plugs.size(); ++i)
                    for (const auto& column : app::csvColumns(graph, plugs[i], values[i])) header.push_back(column);
                table.push_back(header);
            }
            std::vector<std::string> row{fmt::format("{}", frame)};
            const int digits = options.format == "table" ? 6 : 0;
            for (std::size_t i = 0; i < plugs.size(); ++i)
                for (const auto& field : app::csvFields(graph, plugs[i], values[i], digits)) row.push_back(field);
            table.push_back(row);
            for (const auto& cell : row) tableBytes += cell.size() + 2;
            // CSV rows are joined as they come; only the table needs every row to align its columns.
            if (options.format == "csv") {
                out += joinCsv(table);
                table.clear();
            }
        }
        firstRow = false;
        checkSize(options.format == "table" ? tableBytes : out.size(), ++framesDone);
    }
    if (options.format == "json") return out + "\n]\n";
    return options.format == "csv" ? out : alignTable(table);
}

// The flags --html and --character need, and the files they write, checked before any work.
void checkPageFlags(const Options& options, app::OutputFiles& files)
{
    if (options.characterGiven && !options.htmlGiven)
        throw Error(
            fmt::format("--character {}: it chooses the character the crowd page opens on; give --html FILE too",
                        options.character));
    if (options.htmlGiven && (options.dot || options.types))
        throw Error(fmt::format("--html: the crowd page plays the graph; it is not written with {}",
                                options.dot ? "--dot" : "--types"));
    if (options.htmlGiven) files.add(options.html, "crowd.html", "--html");
}

int run(const Options& options)
{
    // A bad -o or --html is reported before any work.
    app::OutputFiles files;
    checkPageFlags(options, files);
    const std::vector<app::NamedFile> outputs{{"-o", options.outputGiven ? options.output : ""},
                                              {"--html", options.html}};
    if (options.outputGiven) files.add(options.output);
    app::checkDistinctFiles({{"the rig file", options.rig}, {"--anim", options.anim}}, outputs);
    const std::string threeJs = options.htmlGiven ? app::readThreeJs() : std::string();
    const auto registry = options.types ? app::typesRegistry(options.plugins) : app::nodeRegistry(options.plugins);
    // The files the rig includes are inputs too: -o must not be one of them.
    MayaSceneInfo maya;
    auto load = [&] {
        std::vector<std::filesystem::path> read;
        auto graph = loadRigFile(options.rig, registry, &read, &maya, {options.searchPath});
        for (const std::string& warning : maya.warnings) std::cerr << "warning: " << warning << "\n";
        std::vector<app::NamedFile> inputs;
        for (const auto& file : read) inputs.push_back({"a file the rig reads", file});
        app::checkDistinctFiles(inputs, outputs);
        return graph;
    };
    std::string text, page;
    if (options.types) text = nodeTypeReference(*registry);
    else if (options.rig.empty()) throw Error("no rig file given; usage: graph-eval RIG.yaml [options], or --help");
    else if (options.dot) text = toDot(*load());
    else {
        auto graph = load();
        graph->setThreads(options.threads);
        if (!options.anim.empty()) app::applyAnimFile(*graph, options.anim);
        for (const auto& s : options.sets) applySet(*graph, s);
        std::optional<app::FrameRange> range;
        if (options.framesGiven && options.frames.empty() && maya.playbackRange)
            range = app::FrameRange{maya.playbackRange->first, maya.playbackRange->second, 1.0};
        else if (options.framesGiven) range = app::parseFrameRange(options.frames, "--frames");
        std::vector<Plug> plugs =
            app::selectPlugs(*graph, options.rig, options.gets, range ? std::optional(range->first) : std::nullopt);
        app::settleLargeGraph(*graph);
        const std::set<Plug> seen(plugs.begin(), plugs.end());
        // CSV and table columns of a vector are its components: a component also selected whole
        // ('--get node.rotate*' matches rotate and rotateX) would be a second column of the same name.
        if (options.format != "json")
            std::erase_if(plugs, [&](const Plug& p) {
                return p.child >= 0 && seen.contains({p.node, p.attr, p.index, -1});
            });
        std::optional<app::CrowdReport> crowd;
        if (options.htmlGiven) crowd.emplace(*graph, options.rig);
        if (options.characterGiven) crowd->open(options.character);
        const auto computesBefore = graph->computeCount();
        const auto start = std::chrono::steady_clock::now();
        const std::vector<double> frames = range ? range->frames() : std::vector<double>{graph->time()};
        text = render(*graph, plugs, frames, range.has_value(), options, crowd ? &*crowd : nullptr);
        if (crowd) page = crowd->page(std::filesystem::path(options.rig).filename().string(), threeJs);
        const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        if (options.stats)
            std::cerr << fmt::format(
                "stats: {} nodes, {} connections, {} threads, {} frames, {} node computations, "
                "{:.3f} ms per frame\n",
                graph->nodeCount(), graph->connections().size(), graph->threads(), frames.size(),
                graph->computeCount() - computesBefore, 1e3 * seconds / static_cast<double>(frames.size()));
        if (options.stats && isMayaFile(options.rig)) std::cerr << mayaStatsText(maya);
    }
    if (!options.outputGiven) std::cout << text;
    else files.set(options.output, std::move(text));
    if (options.htmlGiven) files.set(options.html, std::move(page));
    files.commit();
    return 0;
}

}  // namespace
}  // namespace rig

int main(int argc, char** argv)
{
    rig::Options options;
    CLI::App app{
        "graph-eval: evaluate a rig graph (YAML) and print plug values.\n\n"
        "Example:\n"
        "  graph-eval rigs/examples/arm.yaml --frames 1:24 --get 'wrist.worldMatrix' --get '*.rotateZ'\n"
        "  graph-eval rigs/examples/arm.yaml --set shoulder.rotateZ=30 --get wrist_world.outputTranslate --format "
        "csv\n\n"
        "Angles are degrees, distances centimetres, times frames. JSON output is a list with one object\n"
        "per frame: {\"frame\": F, \"node.attr\": value, ...}; matrices are four rows (translation in\n"
        "the last column). See docs/graph-eval.md.",
        "graph-eval"};
    app.add_option("rig", options.rig, "Rig graph file (YAML)");
    // Repeatable flags take one value each: '--get a.b rig.yaml' must not read the rig as a second --get.
    app.add_option("--set", options.sets, "Set a plug before evaluating: node.attr=VALUE (repeatable)")
        ->allow_extra_args(false);
    app.add_option("--get", options.gets, "Plugs to print, by name or glob (repeatable; default: every output)")
        ->allow_extra_args(false);
    app.add_option("--frames", options.frames,
                   "Frame range A:B[:STEP], inclusive (default: the current time: 0, or a Maya scene's saved time); "
                   "--frames '' on a Maya scene: its playback range");
    app.add_option("--search-path", options.searchPath,
                   "A folder where a Maya scene's references are looked for, after the scene's own folders "
                   "(repeatable; docs/maya.md)")
        ->allow_extra_args(false);
    app.add_option("--format", options.format, "Output format: json (default), csv, or table (aligned, 6 digits)")
        ->check(CLI::IsMember({"json", "csv", "table"}));
    app.add_option("-o,--output", options.output, "Write to this file instead of standard output");
    app.add_option("--anim", options.anim,
                   "A Maya .anim file: its curves drive the rig's plugs they name (docs/keys-anim-report.md)");
    app.add_option("--plugin", options.plugins, "Load a node plugin before reading the rig (repeatable)")
        ->allow_extra_args(false);
    app.add_flag(
        "--types", options.types,
        "Print the reference of every node type, built-in, rigInversion's and --plugin's (Markdown), and exit");
    app.add_flag("--dot", options.dot, "Print the graph in Graphviz dot format instead of evaluating");
    app.add_option("--threads", options.threads, "Evaluation threads: 1 serial, N parallel, 0 all cores")
        ->check(rig::cli::threadCount());
    app.add_flag(
        "--stats", options.stats,
        "Print node, connection and computation counts and timing to stderr (a Maya scene: also what was not read)");
    app.add_option("--html", options.html,
                   "Write the crowd's report page: each rigInversion node's character, its targets and the crowd "
                   "from above (docs/crowds.md)");
    app.add_option("--character", options.character,
                   "The character the --html page opens on (its namespace, e.g. c0001); default: the crowd");
    app.add_flag("--check", options.check,
                 "Checked mode: after each frame recompute everything from scratch and fail on any difference");
    return rig::cli::runMain(app, argc, argv, [&] {
        options.outputGiven = app.count("--output") > 0;
        options.framesGiven = app.count("--frames") > 0;
        options.htmlGiven = app.count("--html") > 0;
        options.characterGiven = app.count("--character") > 0;
        return rig::run(options);
    });
}
