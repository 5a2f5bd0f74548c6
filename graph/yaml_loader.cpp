#include "graph/yaml_loader.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <tuple>

#include <fmt/format.h>
#include <yaml-cpp/depthguard.h>
#include <yaml-cpp/eventhandler.h>
#include <yaml-cpp/yaml.h>

#include "core/error.h"
#include "graph/suggest.h"

namespace rig {
namespace {

std::string markText(const std::string& file, const YAML::Mark& mark)
{
    if (mark.line < 0) return file;
    return formatMark({file, mark.line + 1, mark.column + 1});
}

// Limits that keep damaged or hostile files from exhausting the stack or the memory
// (docs/robustness.md).
// (A rig file costs about a hundred times its size while it is parsed: yaml-cpp's nodes are heavy.)
constexpr std::uintmax_t maxRigFileBytes = std::uintmax_t{16} << 20;
constexpr std::size_t maxIncludeDepth = 64;
constexpr int maxIncludedFiles = 20'000;
// Rig text parsed in all, every include counted each time it is included: a small file that includes
// files that include files must not amplify into gigabytes (parsing costs about 100 times the text).
constexpr std::uintmax_t maxTotalRigBytes = std::uintmax_t{64} << 20;

// Counts what a YAML document holds, to tell an empty document from one with content.
class DocumentContent : public YAML::EventHandler {
public:
    bool content = false;
    YAML::Mark start;

    void OnDocumentStart(const YAML::Mark& mark) override { start = mark; }
    void OnDocumentEnd() override {}
    void OnNull(const YAML::Mark&, YAML::anchor_t) override {}
    void OnAlias(const YAML::Mark&, YAML::anchor_t) override { content = true; }
    void OnScalar(const YAML::Mark&, const std::string&, YAML::anchor_t, const std::string&) override
    {
        content = true;
    }
    void OnSequenceStart(const YAML::Mark&, const std::string&, YAML::anchor_t, YAML::EmitterStyle::value) override
    {
        content = true;
    }
    void OnSequenceEnd() override {}
    void OnMapStart(const YAML::Mark&, const std::string&, YAML::anchor_t, YAML::EmitterStyle::value) override
    {
        content = true;
    }
    void OnMapEnd() override {}
};

std::string describe(const YAML::Node& node)
{
    if (node.IsScalar()) return fmt::format("'{}'", messageExcerpt(node.Scalar()));
    if (node.IsSequence()) return fmt::format("a list of {}", node.size());
    if (node.IsMap()) return "a map";
    return "nothing";
}

double parseNumber(const YAML::Node& node, const std::string& where)
{
    if (!node.IsScalar()) throw Error(fmt::format("{}: expected a number, got {}", where, describe(node)));
    double x = 0.0;
    if (!YAML::convert<double>::decode(node, x)) {
        // yaml-cpp refuses numbers out of a double's range: 1e400 is too large, 1e-400 is (about) 0.
        const std::string& text = node.Scalar();
        char* end = nullptr;
        errno = 0;
        const double y = std::strtod(text.c_str(), &end);
        if (text.empty() || end != text.c_str() + text.size() || errno != ERANGE)
            throw Error(fmt::format("{}: expected a number, got {}", where, describe(node)));
        if (std::isfinite(y)) return y;
        throw Error(fmt::format("{}: {} is not a finite number (too large for a double)", where, messageExcerpt(text)));
    }
    if (!std::isfinite(x))
        throw Error(fmt::format("{}: {} is not a finite number", where, messageExcerpt(node.Scalar())));
    return x;
}

// `count` numbers, as a list.
std::vector<double> parseNumbers(const YAML::Node& node, std::size_t count, const char* what, const std::string& where)
{
    if (!node.IsSequence() || node.size() != count)
        throw Error(fmt::format("{}: expected {}, got {}", where, what, describe(node)));
    std::vector<double> xs;
    for (std::size_t i = 0; i < count; ++i) xs.push_back(parseNumber(node[i], where));
    return xs;
}

int parseInt(const YAML::Node& node, const std::string& where)
{
    const double x = parseNumber(node, where);
    if (x != std::floor(x) || std::abs(x) > 2e9)
        throw Error(fmt::format("{}: expected a whole number, got {}", where, messageExcerpt(node.Scalar())));
    return static_cast<int>(x);
}

// An enum by name, or by index.
int parseEnum(const YAML::Node& node, const AttributeSpec& spec, const std::string& where)
{
    if (!node.IsScalar()) throw Error(fmt::format("{}: expected an enum name, got {}", where, describe(node)));
    for (std::size_t i = 0; i < spec.enumNames.size(); ++i)
        if (spec.enumNames[i] == node.Scalar()) return static_cast<int>(i);
    int index = -1;
    if (YAML::convert<int>::decode(node, index) && index >= 0 &&
        static_cast<std::size_t>(index) < spec.enumNames.size())
        return index;
    std::string names;
    for (const auto& n : spec.enumNames) names += (names.empty() ? "" : ", ") + n;
    throw Error(fmt::format("{}: '{}' is not one of {}{}", where, messageExcerpt(node.Scalar()), names,
                            didYouMean(node.Scalar(), spec.enumNames)));
}

// The factor from a number in a file to the stored value: files give angles in degrees, stored in radians.
double fileScale(const AttributeSpec& spec)
{
    return unitFactor(spec.unit == Unit::Angle ? Unit::None : spec.unit, spec.unit);
}

std::vector<double> parseDoubleArray(const YAML::Node& node, double scale, const std::string& where)
{
    if (!node.IsSequence()) throw Error(fmt::format("{}: expected a list of numbers, got {}", where, describe(node)));
    std::vector<double> xs;
    for (const auto& item : node) xs.push_back(parseNumber(item, where) * scale);
    return xs;
}

// A matrix as 16 numbers, row by row, or as four rows of four.
Eigen::Matrix4d parseMatrix(const YAML::Node& node, const AttributeSpec& spec, const std::string& where)
{
    Eigen::Matrix4d m;
    if (node.IsSequence() && node.size() == 16) {
        const auto xs = parseNumbers(node, 16, "16 numbers", where);
        for (int i = 0; i < 16; ++i) m(i / 4, i % 4) = xs[static_cast<std::size_t>(i)];
        return m;
    }
    if (!node.IsSequence() || node.size() != 4)
        throw Error(fmt::format("{}: expected a matrix as four rows [[...], [...], [...], [...]], got {}", where,
                                describe(node)));
    for (int r = 0; r < 4; ++r) {
        const auto xs = parseDoubleArray(node[static_cast<std::size_t>(r)], fileScale(spec), where);
        if (xs.size() != 4)
            throw Error(fmt::format("{}: matrix row {} has {} numbers, expected 4", where, r + 1, xs.size()));
        for (int c = 0; c < 4; ++c) m(r, c) = xs[static_cast<std::size_t>(c)];
    }
    return m;
}

Value parseOne(const YAML::Node& node, ValueType type, const AttributeSpec& spec, const std::string& where)
{
    const double scale = fileScale(spec);
    switch (type) {
        case ValueType::Double:
            return parseNumber(node, where) * scale;
        case ValueType::Int:
            return parseInt(node, where);
        case ValueType::Bool: {
            bool b = false;
            if (!node.IsScalar() || !YAML::convert<bool>::decode(node, b))
                throw Error(fmt::format("{}: expected true or false, got {}", where, describe(node)));
            return b;
        }
        case ValueType::Enum:
            return parseEnum(node, spec, where);
        case ValueType::String:
            if (!node.IsScalar()) throw Error(fmt::format("{}: expected a string, got {}", where, describe(node)));
            return node.Scalar();
        case ValueType::Vector3: {
            const auto xs = parseNumbers(node, 3, "[x, y, z]", where);
            return Eigen::Vector3d(xs[0] * scale, xs[1] * scale, xs[2] * scale);
        }
        case ValueType::Matrix4:
            return parseMatrix(node, spec, where);
        case ValueType::DoubleArray:
            return parseDoubleArray(node, scale, where);
        case ValueType::Matrix4Array: {
            if (!node.IsSequence())
                throw Error(fmt::format("{}: expected a list of matrices, got {}", where, describe(node)));
            Matrix4Array ms;
            for (const auto& item : node) ms.push_back(parseMatrix(item, spec, where));
            return ms;
        }
    }
    return zeroValue(type);
}

std::string readText(const std::filesystem::path& file, const std::string& what)
{
    std::error_code ec;
    const auto status = std::filesystem::status(file, ec);
    if (!std::filesystem::exists(status)) throw Error(fmt::format("{}: no such {}", file.string(), what));
    if (std::filesystem::is_directory(status))
        throw Error(fmt::format("{}: is a folder, not a rig file; give the path of a .yaml file", file.string()));
    // A device or a pipe (/dev/zero, /dev/stdin) could be endless.
    if (!std::filesystem::is_regular_file(status))
        throw Error(fmt::format("{}: is not a regular file (a device or a pipe?); give the path of a .yaml file",
                                file.string()));
    if (const auto size = std::filesystem::file_size(file, ec); !ec && size > maxRigFileBytes)
        throw Error(fmt::format("{}: {} MB is too large for a {} (the limit is {} MB); split it into included files",
                                file.string(), size >> 20, what, maxRigFileBytes >> 20));
    std::ifstream in(file, std::ios::binary);
    if (!in)
        throw Error(fmt::format("{}: cannot be read ({}); check its permissions", file.string(), std::strerror(errno)));
    std::ostringstream text;
    text << in.rdbuf();
    if (in.bad()) throw Error(fmt::format("{}: cannot be read (a read error); check the file", file.string()));
    return text.str();
}

// What the loaders of one graph share across included files.
struct LoadState {
    std::map<Plug, std::string> valueMarks;           // where each plug was given a value, for conflicts
    std::vector<std::filesystem::path> includeStack;  // files being loaded (canonical), to refuse include cycles
    std::vector<std::filesystem::path>* filesRead = nullptr;  // every file read, when asked for
    int includedFiles = 0;                                    // every file included so far, nested ones too
    std::uintmax_t bytesRead = 0;                             // rig text parsed so far, every include counted
    // Connector fields (NodeType::yamlConnectors), run once everything is loaded.
    struct Deferred {
        NodeId node;
        const YamlConnector* connector;
        YAML::Node value;
        std::function<std::string(const YAML::Node&)> where;
    };
    std::vector<Deferred> deferred;
};

// One file being loaded into a graph; an included file gets a loader of its own whose node names
// carry its namespace prefix ("hero:").
class Loader {
public:
    Loader(std::string file, Graph& graph, std::string prefix, LoadState& state)
        : file_(std::move(file)), graph_(graph), prefix_(std::move(prefix)), state_(state)
    {
    }

    void load(std::string_view text)
    {
        YAML::Node root;
        std::optional<std::pair<int, int>> second;
        try {
            const std::string copy(text);
            root = YAML::Load(copy);
            second = secondYamlDocument(copy);
        }
        catch (const YAML::DeepRecursion& e) {
            throw Error(
                fmt::format("{}: YAML lists and maps nested more than {} levels deep; a rig file nests a few "
                            "levels, so the file is damaged or not a rig file",
                            markText(file_, e.mark), e.depth() - 1));
        }
        catch (const YAML::ParserException& e) {
            throw Error(fmt::format("{}: YAML syntax error: {}", markText(file_, e.mark), e.msg));
        }
        // Only the first document would be read: a second one ('---' then more) is a mistake.
        if (second)
            throw Error(
                fmt::format("{}: '---' starts a second YAML document; a rig file is one document: remove "
                            "this line, or make the second part a file of its own and include it",
                            formatMark({file_, second->first + 1, second->second + 1})));
        if (root.IsNull()) {
            // Empty, or only comments; but yaml-cpp also reads nothing from some garbage (",a st").
            int number = 0;
            for (std::size_t start = 0; start < text.size();) {
                const std::size_t end = std::min(text.find('\n', start), text.size());
                std::string_view line = text.substr(start, end - start);
                ++number;
                start = end + 1;
                const auto first = line.find_first_not_of(" \t\r");
                if (first == std::string_view::npos) continue;
                line.remove_prefix(first);
                if (line.starts_with('#') || line.starts_with("---") || line.starts_with("...")) continue;
                throw Error(
                    fmt::format("{}: expected a map with 'nodes:' (and 'plugins:', 'connections:'), got "
                                "nothing YAML can read; is this a rig file?",
                                formatMark({file_, number, static_cast<int>(first) + 1})));
            }
            throw Error(fmt::format("{}: the file is empty; a rig file has a 'nodes:' list", file_));
        }
        if (!root.IsMap())
            throw Error(fmt::format("{}: expected a map with 'nodes:' (and 'plugins:', 'connections:'), got {}",
                                    at(root), describe(root)));
        checkKeys(root, {"include", "plugins", "nodes", "connections"}, "top level");
        if (const auto plugins = root["plugins"]) loadPlugins(plugins);
        if (const auto includes = root["include"]) loadIncludes(includes);
        const auto nodes = root["nodes"];
        if (!nodes && root["include"]) return;
        if (!nodes) throw Error(fmt::format("{}: no 'nodes:' list; a rig file needs at least one node", at(root)));
        if (!nodes.IsSequence())
            throw Error(fmt::format("{}: 'nodes' must be a list, got {}", at(nodes), describe(nodes)));
        for (const auto& n : nodes) createNode(n);
        for (const auto& n : nodes) fillNode(n);
        // Parents and connections come after every value, so a plug given both is reported as such.
        for (const auto& n : nodes)
            if (const auto parent = n["parent"]) setParent(graph_.findNode(prefix_ + n["name"].Scalar()), parent);
        if (const auto connections = root["connections"]; connections && !connections.IsNull()) {
            if (!connections.IsSequence())
                throw Error(
                    fmt::format("{}: 'connections' must be a list, got {}", at(connections), describe(connections)));
            for (const auto& c : connections) addConnection(c);
        }
    }

private:
    std::string at(const YAML::Node& node) const { return markText(file_, node.Mark()); }

    // Runs a graph call, putting this place in the file in front of its message.
    template <class F>
    auto located(const YAML::Node& where, F&& f)
    {
        try {
            return f();
        }
        catch (const Error& e) {
            throw Error(fmt::format("{}: {}", at(where), e.what()));
        }
    }

    void checkKeys(const YAML::Node& map, const std::vector<std::string>& allowed, const std::string& what) const
    {
        std::set<std::string> seen;
        for (const auto& entry : map) {
            requireScalarKey(entry.first, what);
            const auto key = entry.first.Scalar();
            if (!seen.insert(key).second)
                throw Error(fmt::format("{}: '{}' appears twice in {}", at(entry.first), key, what));
            if (std::find(allowed.begin(), allowed.end(), key) == allowed.end())
                throw Error(
                    fmt::format("{}: unknown key '{}' at {}{}", at(entry.first), key, what, didYouMean(key, allowed)));
        }
    }

    // A map key that is a list or a map ({[a, b]: 1}) has no name to check.
    void requireScalarKey(const YAML::Node& key, const std::string& what) const
    {
        if (!key.IsScalar())
            throw Error(fmt::format("{}: a key in {} must be a name, got {}", at(key), what, describe(key)));
    }

    void loadIncludes(const YAML::Node& includes)
    {
        if (!includes.IsSequence())
            throw Error(fmt::format("{}: 'include' is a list of {{file: rig.yaml, namespace: name}}, got {}",
                                    at(includes), describe(includes)));
        for (const auto& entry : includes) {
            if (!entry.IsMap())
                throw Error(fmt::format("{}: an include is {{file: rig.yaml, namespace: name}}, got {}", at(entry),
                                        describe(entry)));
            checkKeys(entry, {"file", "namespace"}, "include");
            const std::string file = requireString(entry, "file");
            std::string ns;
            if (const auto n = entry["namespace"]) {
                ns = n.Scalar();
                if (ns.empty() || ns.find_first_of(".[]: \t") != std::string::npos)
                    throw Error(fmt::format("{}: namespace '{}' must be a plain name (letters, digits, _)", at(n), ns));
            }
            const auto path = (std::filesystem::path(file_).parent_path() / file).lexically_normal();
            const std::string name = path.string();
            std::error_code ec;
            const auto canonical = std::filesystem::weakly_canonical(path, ec);
            for (const auto& open : state_.includeStack)
                if (open == canonical)
                    throw Error(fmt::format("{}: include cycle: {} is already being loaded; remove this include",
                                            at(entry["file"]), name));
            if (state_.includeStack.size() > maxIncludeDepth)
                throw Error(
                    fmt::format("{}: includes nested more than {} files deep; check for a chain of files "
                                "including each other",
                                at(entry["file"]), maxIncludeDepth));
            if (++state_.includedFiles > maxIncludedFiles)
                throw Error(
                    fmt::format("{}: more than {} included files in all; check for files that include the "
                                "same file several times at every level",
                                at(entry["file"]), maxIncludedFiles));
            std::error_code sizeError;
            const std::uintmax_t size = std::filesystem::file_size(path, sizeError);
            if (!sizeError && state_.bytesRead + size > maxTotalRigBytes)
                throw Error(
                    fmt::format("{}: the included files add up to more than {} MB of rig text ({} files so far); "
                                "check for files that include the same file several times at every level",
                                at(entry["file"]), maxTotalRigBytes >> 20, state_.includedFiles));
            const std::string text = located(entry["file"], [&] { return readText(path, "included rig file"); });
            state_.bytesRead += text.size();
            if (state_.filesRead) state_.filesRead->push_back(path);
            const bool fromMainFile = state_.includeStack.size() == 1;
            state_.includeStack.push_back(canonical);
            try {
                Loader(name, graph_, ns.empty() ? prefix_ : fmt::format("{}{}:", prefix_, ns), state_).load(text);
            }
            catch (const Error& e) {
                // The error's place is in the included file; the main file's include that led there is
                // added (once, by the main file's loader, not at every level).
                if (!fromMainFile) throw;
                throw Error(fmt::format("{} (included from {})", e.what(), at(entry["file"])));
            }
            state_.includeStack.pop_back();
        }
    }

    void loadPlugins(const YAML::Node& plugins)
    {
        if (!plugins.IsSequence())
            throw Error(
                fmt::format("{}: 'plugins' must be a list of plugin names, got {}", at(plugins), describe(plugins)));
        const auto folder = std::filesystem::path(file_).parent_path();
        for (const auto& p : plugins) {
            if (!p.IsScalar()) throw Error(fmt::format("{}: a plugin name is a string, got {}", at(p), describe(p)));
            located(p, [&] { return graph_.registry().loadPlugin(p.Scalar(), {folder.empty() ? "." : folder}); });
        }
    }

    std::string requireString(const YAML::Node& node, const char* key) const
    {
        const auto v = node[key];
        if (!v) throw Error(fmt::format("{}: node without '{}:'", at(node), key));
        if (!v.IsScalar() || v.Scalar().empty())
            throw Error(fmt::format("{}: '{}' must be a name, got {}", at(v), key, describe(v)));
        return v.Scalar();
    }

    void createNode(const YAML::Node& n)
    {
        if (!n.IsMap())
            throw Error(
                fmt::format("{}: a node is a map like {{name: elbow, type: joint}}, got {}", at(n), describe(n)));
        const std::string name = prefix_ + requireString(n, "name");
        const std::string type = requireString(n, "type");
        located(n["type"], [&] { return graph_.registry().get(type); });
        located(n["name"], [&] { return graph_.addNode(type, name); });
    }

    void fillNode(const YAML::Node& n)
    {
        const std::string name = prefix_ + n["name"].Scalar();
        const NodeId id = graph_.findNode(name);
        const NodeType& type = graph_.nodeType(id);
        const std::string who = fmt::format("node '{}' ({})", name, type.name());

        std::set<std::string> seen;
        for (const auto& entry : n)
            if (requireScalarKey(entry.first, who); !seen.insert(entry.first.Scalar()).second)
                throw Error(fmt::format("{}: {}: '{}' appears twice", at(entry.first), who, entry.first.Scalar()));
        if (const auto added = n["addAttr"]) addAttributes(id, added, who);

        for (const auto& entry : n) {
            const std::string key = entry.first.Scalar();
            if (key == "name" || key == "type" || key == "addAttr" || key == "parent") continue;
            if (const auto field = type.yamlFields().find(key); field != type.yamlFields().end()) {
                YamlFieldContext context{[&](const YAML::Node& y) { return fmt::format("{}: {}", at(y), who); }};
                for (auto& [attr, value] : field->second(entry.second, context)) {
                    const Plug p{id, attr, -1, -1};
                    const Value& v = value;  // (clang 14 cannot capture a structured binding)
                    noteValue(p, entry.second);
                    located(entry.second, [&] { graph_.setValue(p, v); });
                }
                continue;
            }
            if (const auto connector = type.yamlConnectors().find(key); connector != type.yamlConnectors().end()) {
                state_.deferred.push_back(
                    {id, &connector->second, entry.second, [file = file_, who](const YAML::Node& y) {
                         return fmt::format("{}: {}", markText(file, y.Mark()), who);
                     }});
                continue;
            }
            Plug p;
            try {
                p = graph_.plug(name + "." + key);
            }
            catch (const Error&) {
                std::vector<std::string> names{"name", "type", "parent", "addAttr"};
                for (const auto& a : graph_.attributes(id)) {
                    names.push_back(a.name);
                    if (a.type == ValueType::Vector3)
                        names.insert(names.end(), a.childNames.begin(), a.childNames.end());
                }
                for (const auto& f : type.yamlFields()) names.push_back(f.first);
                for (const auto& f : type.yamlConnectors()) names.push_back(f.first);
                throw Error(
                    fmt::format("{}: {} has no attribute '{}'{}", at(entry.first), who, key, didYouMean(key, names)));
            }
            setFromYaml(p, entry.second);
        }
    }

    void setFromYaml(Plug p, const YAML::Node& value)
    {
        const AttributeSpec& spec = graph_.spec(p);
        const std::string where = fmt::format("{}: {}", at(value), graph_.plugName(p));
        if (spec.array && p.index < 0) {
            // A list sets elements 0, 1, ...; a map {index: value} sets the elements it names.
            if (!value.IsSequence() && !value.IsMap())
                throw Error(
                    fmt::format("{} is an array attribute: give a list of values or a map {{index: value}}", where));
            Plug element = p;
            if (value.IsSequence()) {
                for (std::size_t i = 0; i < value.size(); ++i) {
                    element.index = static_cast<int>(i);
                    setFromYaml(element, value[i]);
                }
                return;
            }
            for (const auto& item : value) {
                if (!item.first.IsScalar() || !YAML::convert<int>::decode(item.first, element.index) ||
                    element.index < 0 || element.index > GraphModel::maxArrayIndex)
                    throw Error(fmt::format("{}: {}: array index {} must be a whole number from 0 to {}",
                                            at(item.first), graph_.plugName(p), describe(item.first),
                                            GraphModel::maxArrayIndex));
                setFromYaml(element, item.second);
            }
            return;
        }
        Value parsed = parseYamlValue(value, graph_, p, where);
        // A file named in a rig file is found next to it, as an include is, whatever the current folder.
        if (spec.filePath)
            if (const auto* text = std::get_if<std::string>(&parsed); text && !text->empty())
                if (const std::filesystem::path named(*text); named.is_relative())
                    parsed = (std::filesystem::path(file_).parent_path() / named).lexically_normal().string();
        noteValue(p, value);
        located(value, [&] { graph_.setValue(p, parsed); });
    }

    // A plug given two values (keys: and keyTime:, say) is a mistake: the later one would win silently.
    void noteValue(const Plug& p, const YAML::Node& where)
    {
        const auto [it, added] = state_.valueMarks.emplace(p, at(where));
        if (!added)
            throw Error(fmt::format("{}: {} is given a value twice (first at {}); keep one", at(where),
                                    graph_.plugName(p), it->second));
    }

    void addAttributes(NodeId id, const YAML::Node& list, const std::string& who)
    {
        if (!list.IsSequence())
            throw Error(fmt::format("{}: {}: 'addAttr' is a list of {{name: ..., type: double, ...}}", at(list), who));
        static const std::map<std::string, ValueType> types{{"double", ValueType::Double},
                                                            {"int", ValueType::Int},
                                                            {"bool", ValueType::Bool},
                                                            {"enum", ValueType::Enum},
                                                            {"string", ValueType::String},
                                                            {"vector3", ValueType::Vector3},
                                                            {"matrix4", ValueType::Matrix4},
                                                            {"doubleArray", ValueType::DoubleArray},
                                                            {"matrix4Array", ValueType::Matrix4Array}};
        for (const auto& a : list) {
            if (!a.IsMap())
                throw Error(fmt::format("{}: {}: an added attribute is a map, got {}", at(a), who, describe(a)));
            checkKeys(a, {"name", "type", "default", "min", "max", "keyable", "unit", "enum", "array"}, "addAttr");
            AttributeSpec spec;
            spec.name = requireString(a, "name");
            const std::string typeName = a["type"] ? a["type"].Scalar() : "double";
            const auto t = types.find(typeName);
            if (t == types.end()) {
                std::vector<std::string> names;
                for (const auto& entry : types) names.push_back(entry.first);
                throw Error(fmt::format("{}: {}: unknown attribute type '{}'{}", at(a["type"]), who, typeName,
                                        didYouMean(typeName, names)));
            }
            spec.type = t->second;
            if (const auto u = a["unit"]) {
                if (u.Scalar() == "angle") spec.unit = Unit::Angle;
                else if (u.Scalar() == "distance") spec.unit = Unit::Distance;
                else if (u.Scalar() != "none")
                    throw Error(
                        fmt::format("{}: {}: unit '{}' is not one of none, angle, distance", at(u), who, u.Scalar()));
            }
            if (const auto e = a["enum"]) {
                if (!e.IsSequence()) throw Error(fmt::format("{}: {}: 'enum' is a list of names", at(e), who));
                for (const auto& name : e) {
                    if (!name.IsScalar())
                        throw Error(
                            fmt::format("{}: {}: an enum name is a plain name, got {}", at(name), who, describe(name)));
                    spec.enumNames.push_back(name.Scalar());
                }
            }
            if (spec.type == ValueType::Enum && spec.enumNames.empty())
                throw Error(fmt::format("{}: {}: an enum attribute needs 'enum: [names...]'", at(a), who));
            const double scale = unitFactor(Unit::None, spec.unit);
            auto limit = [&](const YAML::Node& v, const char* key) {
                return parseNumber(v, fmt::format("{}: {}: {} of '{}'", at(v), who, key, spec.name)) * scale;
            };
            if (const auto v = a["min"]) spec.min = limit(v, "min");
            if (const auto v = a["max"]) spec.max = limit(v, "max");
            if (spec.min && spec.max && *spec.min > *spec.max)
                throw Error(fmt::format("{}: {}: min is above max", at(a), who));
            if (spec.type == ValueType::Int)
                for (const char* key : {"min", "max"})
                    if (const auto v = a[key]; v && std::floor(limit(v, key)) != limit(v, key))
                        throw Error(fmt::format("{}: {}: {} of '{}' is {}; an int attribute's limits are whole numbers",
                                                at(v), who, key, spec.name, v.Scalar()));
            if (const auto v = a["keyable"]) spec.keyable = std::get<bool>(parseOne(v, ValueType::Bool, spec, at(v)));
            if (const auto v = a["array"]) spec.array = std::get<bool>(parseOne(v, ValueType::Bool, spec, at(v)));
            spec.defaultValue = zeroValue(spec.type);
            // Without a default, a number starts at 0, or at the nearest limit when 0 is outside them (as
            // Maya's addAttr does): a value outside its own limits could never be set back.
            if ((spec.type == ValueType::Double || spec.type == ValueType::Int) && !a["default"]) {
                double start = 0.0;
                if (spec.min && start < *spec.min) start = *spec.min;
                if (spec.max && start > *spec.max) start = *spec.max;
                if (start != 0.0) {
                    if (spec.type == ValueType::Int) spec.defaultValue = static_cast<int>(start);
                    else spec.defaultValue = start;
                }
            }
            const AttrId attr = located(a, [&] { return graph_.addAttribute(id, spec); });
            if (const auto v = a["default"]) {
                if (spec.array) throw Error(fmt::format("{}: {}: an array attribute has no default", at(v), who));
                setFromYaml({id, attr, -1, -1}, v);
            }
        }
    }

    void setParent(NodeId child, const YAML::Node& value)
    {
        if (!value.IsScalar())
            throw Error(fmt::format("{}: 'parent' is a node name, got {}", at(value), describe(value)));
        const auto [parent, world, parentMatrix] = located(value, [&] {
            const NodeId p = graph_.node(prefix_ + value.Scalar());
            return std::tuple(p, graph_.plug(graph_.nodeName(p) + ".worldMatrix"),
                              graph_.plug(graph_.nodeName(child) + ".parentMatrix"));
        });
        connectAt(value, world, parentMatrix);
        // Maya connects a parent joint's scale into its child joint's inverseScale, and only between
        // joints: a transform's scale scales the joints below it.
        if (graph_.nodeType(parent).name() == "joint" && graph_.nodeType(child).findAttribute("inverseScale") >= 0)
            connectAt(value, graph_.plug(graph_.nodeName(parent) + ".scale"),
                      graph_.plug(graph_.nodeName(child) + ".inverseScale"));
    }

    void connectAt(const YAML::Node& where, const Plug& source, const Plug& destination)
    {
        if (const auto it = state_.valueMarks.find(destination); it != state_.valueMarks.end())
            throw Error(fmt::format("{}: {} is given a value at {} and a connection; remove one of them", at(where),
                                    graph_.plugName(destination), it->second));
        located(where, [&] { graph_.connect(source, destination); });
    }

    void addConnection(const YAML::Node& c)
    {
        static constexpr std::string_view arrow = "->";
        if (!c.IsScalar() || c.Scalar().find(arrow) == std::string::npos)
            throw Error(
                fmt::format("{}: a connection is written 'node.attr -> node.attr', got {}", at(c), describe(c)));
        const std::string& text = c.Scalar();
        const auto pos = text.find(arrow);
        auto trim = [](std::string s) {
            const auto b = s.find_first_not_of(" \t");
            const auto e = s.find_last_not_of(" \t");
            return b == std::string::npos ? std::string() : s.substr(b, e - b + 1);
        };
        const std::string from = trim(text.substr(0, pos));
        const std::string to = trim(text.substr(pos + arrow.size()));
        const auto [source, destination] =
            located(c, [&] { return std::pair(graph_.plug(prefix_ + from), graph_.plug(prefix_ + to)); });
        connectAt(c, source, destination);
    }

    std::string file_;
    Graph& graph_;
    std::string prefix_;
    LoadState& state_;
};

}  // namespace

std::optional<std::pair<int, int>> secondYamlDocument(const std::string& text)
{
    // Not YAML::LoadAll: yaml-cpp 0.7 returns empty documents without end on some malformed text
    // (",a st\ning", found by fuzz/rig_loader_fuzzer) until the memory runs out. Two documents at most.
    std::istringstream in(text);
    YAML::Parser parser(in);
    DocumentContent first;
    if (!parser.HandleNextDocument(first)) return std::nullopt;
    DocumentContent next;
    if (!parser.HandleNextDocument(next) || !next.content) return std::nullopt;
    return std::pair(next.start.line, next.start.column);
}

Value parseYamlValue(const YAML::Node& node, const Graph& graph, const Plug& plug, const std::string& where)
{
    return parseOne(node, graph.plugType(plug), graph.spec(plug), where);
}

namespace {

std::unique_ptr<Graph> loadGraph(std::string_view text, const std::string& fileName,
                                 std::shared_ptr<NodeRegistry> registry, std::vector<std::filesystem::path>* filesRead)
{
    auto graph = std::make_unique<Graph>(std::move(registry));
    std::error_code ec;
    LoadState state{{}, {std::filesystem::weakly_canonical(fileName, ec)}, filesRead, 0, text.size(), {}};
    Loader(fileName, *graph, "", state).load(text);
    for (const auto& d : state.deferred) (*d.connector)(*graph, d.node, d.value, YamlFieldContext{d.where});
    graph->compact();
    return graph;
}

}  // namespace

std::unique_ptr<Graph> loadGraphText(std::string_view text, const std::string& fileName,
                                     std::shared_ptr<NodeRegistry> registry)
{
    return loadGraph(text, fileName, std::move(registry), nullptr);
}

std::unique_ptr<Graph> loadGraphFile(const std::filesystem::path& file, std::shared_ptr<NodeRegistry> registry,
                                     std::vector<std::filesystem::path>* filesRead)
{
    std::string text = readText(file, "rig file");
    if (filesRead) {
        filesRead->clear();
        filesRead->push_back(file);
    }
    return loadGraph(text, file.string(), std::move(registry), filesRead);
}

}  // namespace rig
