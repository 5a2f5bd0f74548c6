#include "graph/rig_file.h"

#include <fstream>

#include "graph/yaml_loader.h"

namespace rig {
namespace {

// The file's first bytes; none for what is not a regular file (a pipe would block: the YAML reader says what it is).
std::string firstBytes(const std::filesystem::path& file)
{
    std::error_code ec;
    if (!std::filesystem::is_regular_file(file, ec)) return {};
    std::ifstream in(file, std::ios::binary);
    std::string head(16, '\0');
    in.read(head.data(), static_cast<std::streamsize>(head.size()));
    head.resize(static_cast<std::size_t>(in.gcount()));
    return head;
}

}  // namespace

bool isMayaFile(const std::filesystem::path& file)
{
    const std::string head = firstBytes(file);
    return isMayaAscii(head) || isMayaBinary(head);
}

std::unique_ptr<Graph> loadRigFile(const std::filesystem::path& file, std::shared_ptr<NodeRegistry> registry,
                                   std::vector<std::filesystem::path>* filesRead, MayaSceneInfo* mayaInfo,
                                   const MayaLoadOptions& mayaOptions)
{
    if (isMayaFile(file)) return loadMayaFile(file, std::move(registry), filesRead, mayaInfo, mayaOptions);
    if (mayaInfo) *mayaInfo = MayaSceneInfo{};
    return loadGraphFile(file, std::move(registry), filesRead);
}

}  // namespace rig
