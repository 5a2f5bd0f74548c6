// A program built against the installed package: loads a rig file and prints plugs' values over frames as
// graph-eval's CSV (frame, then each plug's numbers), through rig::app as graph-eval itself does.
// Usage: evaluate_rig RIG.yaml FIRST LAST PATTERN...
#include <iostream>
#include <string>
#include <vector>

#include <fmt/format.h>

#include <rig/app/common/value_output.h>
#include <rig/app/eval/eval_run.h>
#include <rig/core/error.h>
#include <rig/graph/yaml_loader.h>

namespace {

std::string csvLine(const std::vector<std::string>& cells)
{
    std::string line;
    for (const auto& cell : cells) line += (line.empty() ? "" : ",") + cell;
    return line + "\n";
}

}  // namespace

int main(int argc, char** argv)
{
    if (argc < 5) {
        std::cerr << "error: usage: evaluate_rig RIG.yaml FIRST LAST PATTERN...\n";
        return 2;
    }
    try {
        const std::string file = argv[1];
        const double first = std::stod(argv[2]);
        const double last = std::stod(argv[3]);
        const std::vector<std::string> patterns(argv + 4, argv + argc);
        auto graph = rig::loadGraphFile(file, rig::app::nodeRegistry({}));
        const auto plugs = rig::app::selectPlugs(*graph, file, patterns, first);
        for (double frame = first; frame <= last; frame += 1.0) {
            const auto values = rig::app::evaluateFrame(*graph, file, frame, true, plugs);
            if (frame == first) {
                std::vector<std::string> header{"frame"};
                for (std::size_t i = 0; i < plugs.size(); ++i)
                    for (const auto& column : rig::app::csvColumns(*graph, plugs[i], values[i]))
                        header.push_back(column);
                std::cout << csvLine(header);
            }
            std::vector<std::string> row{fmt::format("{}", frame)};
            for (std::size_t i = 0; i < plugs.size(); ++i)
                for (const auto& field : rig::app::csvFields(*graph, plugs[i], values[i])) row.push_back(field);
            std::cout << csvLine(row);
        }
    }
    catch (const rig::Error& e) {
        std::cerr << "error: " << e.what() << "\n";
        return 2;
    }
    return 0;
}
