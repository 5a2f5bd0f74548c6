#include "graph/maya/maya_references.h"

#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>

#include <fmt/format.h>

#include "core/error.h"

namespace rig::maya {
namespace {

// Limits of docs/robustness.md: a scene with its meshes may be large (but parsed words cost about 24 times their
// text: 256 MB is 6 GB at worst), and a loop of references must end.
constexpr std::uintmax_t maxSceneBytes = std::uintmax_t{256} << 20;
constexpr std::size_t maxReferences = 2000;

std::string readText(const std::filesystem::path& file)
{
    std::error_code ec;
    const auto size = std::filesystem::file_size(file, ec);
    if (ec) throw Error(fmt::format("{}: cannot read the scene ({})", file.string(), ec.message()));
    if (size > maxSceneBytes)
        throw Error(fmt::format("{}: a scene of {} bytes is larger than this reader takes ({})", file.string(), size,
                                maxSceneBytes));
    std::ifstream in(file, std::ios::binary);
    std::ostringstream text;
    text << in.rdbuf();
    if (!in && !in.eof()) throw Error(fmt::format("{}: cannot read the scene", file.string()));
    return text.str();
}

void checkHeader(std::string_view text, const std::string& fileName)
{
    if (text.starts_with("FOR4") || text.starts_with("FOR8"))
        throw Error(fmt::format("{}: a Maya binary scene (.mb) is not read; save it as Maya ASCII (.ma)", fileName));
    if (!text.starts_with("//Maya ASCII"))
        throw Error(fmt::format("{}:1:1: not a Maya ASCII scene (its first line is not '//Maya ASCII ...')", fileName));
}

// Where a reference's file is: as written (relative to the referencing scene's folder), then each suffix of the
// written path under that folder and its parents, then under the search path.
std::optional<std::filesystem::path> locate(const std::string& written, const std::filesystem::path& from,
                                            const std::vector<std::filesystem::path>& searchPath,
                                            std::vector<std::string>& looked)
{
    std::vector<std::string> parts;
    std::size_t start = 0;
    while (start <= written.size()) {
        const std::size_t sep = std::min(written.find_first_of("/\\", start), written.size());
        if (sep > start) parts.push_back(written.substr(start, sep - start));
        start = sep + 1;
    }
    std::error_code ec;
    const std::filesystem::path scene = std::filesystem::absolute(from, ec);
    std::vector<std::filesystem::path> candidates{scene.parent_path() / written};
    std::vector<std::filesystem::path> folders;
    for (auto folder = scene.parent_path(); !folder.empty(); folder = folder.parent_path()) {
        folders.push_back(folder);
        if (folder == folder.parent_path()) break;
    }
    folders.insert(folders.end(), searchPath.begin(), searchPath.end());
    for (const auto& folder : folders)
        for (std::size_t k = 0; k < parts.size(); ++k) {
            std::filesystem::path p = folder;
            for (std::size_t i = k; i < parts.size(); ++i) p /= parts[i];
            candidates.push_back(p);
        }
    for (const auto& c : candidates) {
        if (std::filesystem::is_regular_file(c, ec)) return std::filesystem::weakly_canonical(c, ec);
    }
    looked.push_back(scene.parent_path().string() + " and its parent folders");
    for (const auto& s : searchPath) looked.push_back(s.string());
    return std::nullopt;
}

class SceneReader {
public:
    SceneReader(Scene& scene, const std::vector<std::filesystem::path>& searchPath, std::vector<std::string>& warnings)
        : scene_(scene), searchPath_(searchPath), warnings_(warnings)
    {
    }

    ReadResult run(std::string_view text, const std::filesystem::path& file)
    {
        readOne(text, file.string(), "");
        ancestry_.push_back({});
        canonical_.push_back(file.empty() ? std::filesystem::path() : std::filesystem::weakly_canonical(file));
        result_.files.push_back(file);
        for (std::size_t r = 0; r < scene_.references.size(); ++r) {
            result_.referenceFiles.resize(scene_.references.size());
            readReference(r);
        }
        applyEdits();
        readPlaybackRange();
        return result_;
    }

private:
    void readOne(std::string_view text, const std::string& fileName, const std::string& nameSpace)
    {
        checkHeader(text, fileName);
        const int index = static_cast<int>(scene_.files.size());
        scene_.files.push_back(fileName);
        scene_.units.emplace_back();
        namespaces_.push_back(nameSpace);
        readStatements(scene_, parseStatements(text, fileName), index, nameSpace);
    }

    void readReference(std::size_t r)
    {
        const Reference ref = scene_.references[r];
        const auto from = static_cast<std::size_t>(ref.where.file);
        std::vector<std::string> looked;
        const auto found = locate(ref.path, scene_.files[from], searchPath_, looked);
        if (!found) {
            std::string where;
            for (const auto& l : looked) where += (where.empty() ? "" : ", ") + l;
            warnings_.push_back(
                fmt::format("{}: reference '{}' not found (looked for it and each end of its path "
                            "under {}); the scene is read without it; give --search-path DIR",
                            formatWhere(scene_, ref.where), ref.path, where));
            result_.missingNamespaces.push_back(ref.nameSpace);
            return;
        }
        std::vector<std::filesystem::path> ancestry = ancestry_[from];
        ancestry.push_back(canonical_[from]);
        for (const auto& a : ancestry)
            if (a == *found)
                throw Error(
                    fmt::format("{}: the reference '{}' loops back to a scene that references it; a scene "
                                "cannot contain itself",
                                formatWhere(scene_, ref.where), ref.path));
        if (scene_.files.size() >= maxReferences)
            throw Error(fmt::format("{}: more than {} references", formatWhere(scene_, ref.where), maxReferences));
        readOne(readText(*found), found->string(), ref.nameSpace);
        result_.referenceFiles[r] = *found;
        ancestry_.push_back(std::move(ancestry));
        canonical_.push_back(*found);
        result_.files.push_back(*found);
    }

    // A name written in file `file`, with that file's namespace on each DAG component.
    std::string qualify(int file, std::string_view name) const
    {
        const std::string& ns = namespaces_[static_cast<std::size_t>(file)];
        if (ns.empty() || name.empty() || name[0] == ':') return std::string(name);
        std::string out;
        std::size_t start = 0;
        while (start <= name.size()) {
            const std::size_t bar = std::min(name.find('|', start), name.size());
            if (bar > start) out += ns + ":" + std::string(name.substr(start, bar - start));
            if (bar < name.size()) out += '|';
            start = bar + 1;
        }
        return out;
    }

    // A plug of an edit as the scene's connections write it (the node's DAG path), or "" for a node not read.
    std::string plug(int file, std::string_view text) const
    {
        const auto [node, attr] = splitPlug(text);
        const int n = scene_.find(qualify(file, node));
        return n < 0 ? std::string() : scene_.path(n) + "." + attr;
    }

    void applyEdits();
    bool applyEdit(int file, const std::vector<Word>& w, std::size_t& pos);
    void setEdit(int file, const std::string& node, const std::string& attr, const std::string& value, Where where);
    void readPlaybackRange();

    Scene& scene_;
    const std::vector<std::filesystem::path>& searchPath_;
    std::vector<std::string>& warnings_;
    std::vector<std::string> namespaces_;                       // by file
    std::vector<std::vector<std::filesystem::path>> ancestry_;  // by file: the files that reference it
    std::vector<std::filesystem::path> canonical_;              // by file
    std::map<std::string, std::string> placeholders_;           // "|RN.placeHolderList[i]" -> plug
    ReadResult result_;
};

void SceneReader::setEdit(int file, const std::string& node, const std::string& attr, const std::string& value,
                          Where where)
{
    const int n = scene_.find(qualify(file, node));
    if (n < 0) {
        ++scene_.skipped["reference edit of a node not read"];
        return;
    }
    const auto statements = parseStatements("setAttr .x " + value + ";", scene_.files[static_cast<std::size_t>(file)]);
    if (statements.size() != 1) return;
    SetAttr set;
    set.plug = attr;
    set.where = where;
    const auto& words = statements.front().words;
    for (std::size_t i = 2; i < words.size(); ++i) {
        const Word& w = words[i];
        if (!w.quoted && (w.text == "-type" || w.text == "-s") && i + 1 < words.size()) {
            if (w.text == "-type") set.type = words[i + 1].text;
            ++i;
        } else if (!w.quoted && w.text.size() > 1 && w.text[0] == '-' &&
                   std::isalpha(static_cast<unsigned char>(w.text[1]))) {
            continue;  // -av, -k, -l: no value
        } else {
            set.values.push_back(w);
        }
    }
    if (!set.values.empty()) scene_.nodes[static_cast<std::size_t>(n)].sets.push_back(std::move(set));
}

// One edit record at w[pos]: code, then its strings. False when the record is not understood (the rest of the node's
// edits are skipped: their layout is not known).
bool SceneReader::applyEdit(int file, const std::vector<Word>& w, std::size_t& pos)
{
    if (pos >= w.size() || w[pos].quoted) return false;
    const int code = std::atoi(w[pos].text.c_str());
    const Where where{file, w[pos].line, w[pos].column};
    ++pos;
    int sub = -1;
    if (code == 5) {
        if (pos >= w.size() || w[pos].quoted) return false;
        sub = std::atoi(w[pos++].text.c_str());
    }
    const std::size_t strings = code == 5 ? 4 : 3;
    if (code < 0 || code > 5 || pos + strings > w.size()) return false;
    std::vector<std::string> s;
    for (std::size_t i = 0; i < strings; ++i, ++pos) {
        if (!w[pos].quoted) return false;
        s.push_back(w[pos].text);
    }
    if (code == 2) {
        setEdit(file, s[0], s[1], s[2], where);
    } else if (code == 3 || code == 4 || (code == 5 && sub == 0)) {
        const std::string src = plug(file, code == 5 ? s[1] : s[0]), dst = plug(file, code == 5 ? s[2] : s[1]);
        if (src.empty() || dst.empty()) ++scene_.skipped["reference edit of a node not read"];
        else (code == 4 ? scene_.disconnections : scene_.connections).push_back({src, dst, false, where});
    } else if (code == 0) {
        const int child = scene_.find(qualify(file, s[0]));
        const int parent = s[1].empty() ? -1 : scene_.find(qualify(file, s[1]));
        if (child >= 0 && (parent >= 0 || s[1].empty())) scene_.reparent(child, parent);
    } else if (code == 5) {
        const std::string target = plug(file, s[1]), holder = plug(file, s[2]);
        if (!target.empty() && !holder.empty()) placeholders_[holder] = target;
    } else {
        ++scene_.skipped[fmt::format("reference edit {}", code)];
    }
    return true;
}

void SceneReader::applyEdits()
{
    // Deeper files first: a scene's own edits of a nested reference come after those of the file between.
    for (int file = static_cast<int>(scene_.files.size()) - 1; file >= 0; --file)
        for (const Node& node : scene_.nodes) {
            if (node.type != "reference" || node.where.file != file) continue;
            for (const SetAttr& set : node.sets) {
                if (set.type != "dataReferenceEdits" || set.values.empty()) continue;
                const auto& w = set.values;
                std::size_t pos = 1;  // after the top reference node's name
                while (pos + 1 < w.size() && w[pos].quoted && !w[pos + 1].quoted) {
                    const int count = std::atoi(w[pos + 1].text.c_str());
                    pos += 2;
                    for (int e = 0; e < count; ++e)
                        if (!applyEdit(file, w, pos)) {
                            ++scene_.skipped["reference edits not understood"];
                            pos = w.size();
                            break;
                        }
                }
            }
        }
    auto substitute = [&](std::string& p) {
        const auto [node, attr] = splitPlug(p);
        const auto open = attr.find('[');
        if (open == std::string::npos) return true;
        const std::string name = attr.substr(0, open);
        if (name != "phl" && name != "placeHolderList") return true;
        const auto it = placeholders_.find(node + ".placeHolderList" + attr.substr(open));
        if (it == placeholders_.end()) return false;
        p = it->second;
        return true;
    };
    // The disconnections are applied by the loader, which knows each attribute's names (an edit spells "translateX"
    // what the file's connectAttr spelled "tx").
    std::vector<Connection> kept;
    for (Connection c : scene_.connections)
        if (substitute(c.source) && substitute(c.destination)) kept.push_back(std::move(c));
    scene_.connections = std::move(kept);
}

void SceneReader::readPlaybackRange()
{
    const int n = scene_.find("sceneConfigurationScriptNode");
    if (n < 0) return;
    for (const SetAttr& set : scene_.nodes[static_cast<std::size_t>(n)].sets) {
        if ((set.plug != "b" && set.plug != "before") || set.values.empty()) continue;
        std::istringstream words(set.values.front().text);
        std::string word;
        std::optional<double> min, max;
        while (words >> word) {
            std::string value;
            if ((word == "-min" || word == "-minTime") && words >> value) min = std::strtod(value.c_str(), nullptr);
            if ((word == "-max" || word == "-maxTime") && words >> value) max = std::strtod(value.c_str(), nullptr);
        }
        if (min && max && *min <= *max) scene_.playbackRange = std::pair{*min, *max};
    }
}

}  // namespace

ReadResult readSceneFile(Scene& scene, const std::filesystem::path& file,
                         const std::vector<std::filesystem::path>& searchPath, std::vector<std::string>& warnings)
{
    const std::string text = readText(file);
    return SceneReader(scene, searchPath, warnings).run(text, file);
}

ReadResult readSceneText(Scene& scene, std::string_view text, const std::string& fileName,
                         const std::vector<std::filesystem::path>& searchPath, std::vector<std::string>& warnings)
{
    return SceneReader(scene, searchPath, warnings).run(text, std::filesystem::path(fileName));
}

}  // namespace rig::maya
