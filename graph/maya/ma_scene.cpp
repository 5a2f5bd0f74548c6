#include "graph/maya/ma_scene.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>

#include <fmt/format.h>

#include "core/error.h"

namespace rig::maya {
namespace {

// Maya's default nodes, first named by `select -ne` (a scene never creates them), whose type matters here.
std::string defaultNodeType(std::string_view name)
{
    if (name == "time1") return "time";
    return "unknown";
}

bool isFlag(const Word& w)
{
    return !w.quoted && w.text.size() >= 2 && w.text[0] == '-' && std::isalpha(static_cast<unsigned char>(w.text[1]));
}

// A statement's flags and its other words, in order. A flag takes the next word as its value unless that word is a
// flag itself or the flag is known to stand alone.
struct Parsed {
    std::vector<std::pair<std::string, const Word*>> flags;  // name without '-', value or null
    std::vector<const Word*> args;
    const Word* flag(std::string_view a, std::string_view b = {}) const
    {
        for (const auto& [name, value] : flags)
            if (name == a || (!b.empty() && name == b)) return value;
        return nullptr;
    }
    bool has(std::string_view a, std::string_view b = {}) const
    {
        for (const auto& f : flags)
            if (f.first == a || (!b.empty() && f.first == b)) return true;
        return false;
    }
};

bool isBoolWord(const Word& w)
{
    const std::string& t = w.text;
    return !w.quoted &&
           (t == "true" || t == "false" || t == "on" || t == "off" || t == "yes" || t == "no" || t == "0" || t == "1");
}

// `boolArgs`: a standalone flag may still be given a boolean (addAttr -s false).
Parsed parseWords(const Statement& s, std::initializer_list<std::string_view> standalone, bool boolArgs = false)
{
    Parsed p;
    const auto& w = s.words;
    for (std::size_t i = 1; i < w.size(); ++i) {
        if (!isFlag(w[i])) {
            p.args.push_back(&w[i]);
            continue;
        }
        const std::string name = w[i].text.substr(1);
        bool alone = false;
        for (std::string_view a : standalone) alone |= a == name;
        if ((!alone || (boolArgs && i + 1 < w.size() && isBoolWord(w[i + 1]))) && i + 1 < w.size() &&
            !isFlag(w[i + 1])) {
            p.flags.emplace_back(name, &w[i + 1]);
            ++i;
        } else {
            p.flags.emplace_back(name, nullptr);
        }
    }
    return p;
}

class Reader {
public:
    Reader(Scene& scene, int file, const std::string& nameSpace) : scene_(scene), file_(file), ns_(nameSpace) {}

    void run(const std::vector<Statement>& statements)
    {
        for (const Statement& s : statements) statement(s);
    }

private:
    [[noreturn]] void fail(const Word& at, const std::string& what) const
    {
        throw Error(fmt::format("{}: {}", formatWhere(scene_, where(at)), what));
    }
    Where where(const Word& w) const { return {file_, w.line, w.column}; }

    void statement(const Statement& s)
    {
        const std::string& c = s.command();
        if (c == "createNode") return createNode(s);
        if (c == "setAttr") return setAttr(s);
        if (c == "addAttr") return addAttr(s);
        if (c == "connectAttr") return connect(s, scene_.connections);
        if (c == "disconnectAttr") return connect(s, scene_.disconnections);
        if (c == "select") return select(s);
        if (c == "rename") return rename(s);
        if (c == "parent") return parent(s);
        if (c == "lockNode") return lockNode(s);
        if (c == "file") return file(s);
        if (c == "currentUnit") return currentUnit(s);
        if (c == "fileInfo") return fileInfo(s);
        if (c == "requires") return;
        ++scene_.skipped[c];
    }

    // A name written in this file, qualified by the reference's namespace: each DAG path component gets it, except
    // in names of the root namespace (":time1") and of shared nodes the scene has already.
    int resolve(const Word& at, std::string_view name) const
    {
        if (ns_.empty() || (!name.empty() && name[0] == ':')) return scene_.find(name);
        std::string qualified;
        std::size_t start = 0;
        while (start <= name.size()) {
            const std::size_t bar = std::min(name.find('|', start), name.size());
            const std::string_view part = name.substr(start, bar - start);
            if (!part.empty()) qualified += ns_ + ":" + std::string(part);
            if (bar < name.size()) qualified += '|';
            start = bar + 1;
        }
        const int found = scene_.find(qualified);
        if (found >= 0) return found;
        const int shared = scene_.find(name);
        (void)at;
        return shared >= 0 && scene_.nodes[static_cast<std::size_t>(shared)].shared ? shared : -1;
    }

    int require(const Word& at, std::string_view name) const
    {
        const int node = resolve(at, name);
        if (node < 0) fail(at, fmt::format("no node named '{}' in the scene so far", messageExcerpt(name)));
        return node;
    }

    void createNode(const Statement& s)
    {
        const Parsed p = parseWords(s, {"s", "shared", "ss", "skipSelect"});
        if (p.args.empty()) fail(s.words.front(), "createNode without a node type");
        Node node;
        node.type = p.args.front()->text;
        node.shared = p.has("s", "shared");
        node.where = where(s.words.front());
        const Word* name = p.flag("n", "name");
        node.name = name ? name->text : node.type + "1";
        if (!node.name.empty() && node.name[0] == ':') node.name.erase(0, 1);
        if (const Word* parentName = p.flag("p", "parent")) node.parent = require(*parentName, parentName->text);
        if (node.shared) {
            // A referenced file's default nodes (persp, time1, ...) are the scene's own: Maya merges them.
            const int existing = scene_.find(node.name);
            if (existing >= 0) {
                current_ = existing;
                return;
            }
        } else if (!ns_.empty()) {
            node.name = ns_ + ":" + node.name;
        }
        try {
            current_ = scene_.add(std::move(node));
        }
        catch (const Error& e) {
            fail(s.words.front(), e.what());
        }
    }

    int currentNode(const Statement& s) const
    {
        if (current_ < 0) fail(s.words.front(), fmt::format("{} before any createNode or select", s.command()));
        return current_;
    }

    // A setAttr's node and the plug relative to it: ".t" on the current node, "node.t" on another.
    std::pair<int, std::string> target(const Statement& s, const Word& plug) const
    {
        if (!plug.text.empty() && plug.text[0] == '.') return {currentNode(s), plug.text.substr(1)};
        auto [node, attr] = splitPlug(plug.text);
        if (attr.empty()) fail(plug, fmt::format("'{}' names no attribute", messageExcerpt(plug.text)));
        return {require(plug, node), attr};
    }

    static std::optional<bool> onOff(const Parsed& p, std::string_view a, std::string_view b, const Reader& r)
    {
        if (!p.has(a, b)) return std::nullopt;
        const Word* v = p.flag(a, b);
        if (!v) return true;
        const std::string& t = v->text;
        if (t == "on" || t == "yes" || t == "true" || t == "1") return true;
        if (t == "off" || t == "no" || t == "false" || t == "0") return false;
        r.fail(*v, fmt::format("-{} takes on or off, not '{}'", a, messageExcerpt(t)));
    }

    void setAttr(const Statement& s)
    {
        const Parsed p = parseWords(s, {"av", "alteredValue", "c", "clamp", "ca", "caching"});
        if (p.args.empty()) fail(s.words.front(), "setAttr without an attribute");
        auto [node, plug] = target(s, *p.args.front());
        SetAttr set;
        set.plug = std::move(plug);
        set.where = where(*p.args.front());
        set.values.reserve(p.args.size() - 1);
        for (std::size_t i = 1; i < p.args.size(); ++i) set.values.push_back(*p.args[i]);
        if (const Word* type = p.flag("type", "typ")) set.type = type->text;
        if (const Word* size = p.flag("s", "size")) set.size = std::atoi(size->text.c_str());
        set.keyable = onOff(p, "k", "keyable", *this);
        set.locked = onOff(p, "l", "lock", *this);
        set.channelBox = onOff(p, "cb", "channelBox", *this);
        scene_.nodes[static_cast<std::size_t>(node)].sets.push_back(std::move(set));
    }

    std::optional<double> number(const Parsed& p, std::string_view a, std::string_view b) const
    {
        const Word* w = p.flag(a, b);
        if (!w) return std::nullopt;
        char* end = nullptr;
        errno = 0;
        const double x = std::strtod(w->text.c_str(), &end);
        if (end != w->text.c_str() + w->text.size() || !std::isfinite(x) || errno == ERANGE)
            fail(*w, fmt::format("-{} takes a finite number, not '{}'", a, messageExcerpt(w->text)));
        return x;
    }

    void addAttr(const Statement& s)
    {
        const Parsed p = parseWords(s, {"m", "multi", "uac", "usedAsColor", "im", "r", "w", "s"}, true);
        AddAttr a;
        a.where = where(s.words.front());
        if (const Word* w = p.flag("ln", "longName")) a.longName = w->text;
        if (const Word* w = p.flag("sn", "shortName")) a.shortName = w->text;
        if (a.longName.empty()) a.longName = a.shortName;
        if (a.longName.empty()) fail(s.words.front(), "addAttr without -ln or -sn");
        if (const Word* w = p.flag("at", "attributeType")) a.attributeType = w->text;
        if (const Word* w = p.flag("dt", "dataType")) a.dataType = w->text;
        if (const Word* w = p.flag("p", "parent")) a.parent = w->text;
        if (const Word* w = p.flag("en", "enumName")) a.enumNames = w->text;
        a.defaultValue = number(p, "dv", "defaultValue");
        a.min = number(p, "min", "minValue");
        a.max = number(p, "max", "maxValue");
        a.softMin = number(p, "smn", "softMinValue");
        a.softMax = number(p, "smx", "softMaxValue");
        a.keyable = onOff(p, "k", "keyable", *this).value_or(false);
        a.hidden = onOff(p, "h", "hidden", *this).value_or(false);
        a.multi = p.has("m", "multi");
        const int node = p.args.empty() ? currentNode(s) : require(*p.args.back(), p.args.back()->text);
        scene_.nodes[static_cast<std::size_t>(node)].adds.push_back(std::move(a));
    }

    // A plug written in this file, its node part qualified by the namespace.
    std::string qualifyPlug(const Word& w) const
    {
        auto [node, attr] = splitPlug(w.text);
        if (attr.empty()) fail(w, fmt::format("'{}' names no attribute (node.attribute)", messageExcerpt(w.text)));
        const int n = resolve(w, node);
        if (n < 0) return w.text;  // reported where the graph is built, with the place
        return scene_.path(n) + "." + attr;
    }

    void connect(const Statement& s, std::vector<Connection>& into)
    {
        const Parsed p = parseWords(s, {"f", "force", "na", "nextAvailable", "rd"});
        if (p.args.size() != 2) fail(s.words.front(), fmt::format("{} takes two plugs", s.command()));
        Connection c;
        c.source = qualifyPlug(*p.args[0]);
        c.destination = qualifyPlug(*p.args[1]);
        c.nextAvailable = p.has("na", "nextAvailable");
        c.where = where(*p.args[0]);
        into.push_back(std::move(c));
    }

    void select(const Statement& s)
    {
        const Parsed p = parseWords(s, {"ne", "noExpand", "r", "add", "cl"});
        if (p.args.empty()) return;
        const Word& name = *p.args.front();
        const int found = resolve(name, name.text);
        if (found >= 0) {
            current_ = found;
            return;
        }
        std::string leaf = name.text;
        if (!leaf.empty() && leaf[0] == ':') leaf.erase(0, 1);
        if (leaf.empty() || leaf.find('|') != std::string::npos) fail(name, "select names no node");
        Node node;
        node.name = leaf;
        node.type = defaultNodeType(leaf);
        node.shared = true;
        node.where = where(name);
        current_ = scene_.add(std::move(node));
    }

    void rename(const Statement& s)
    {
        const Parsed p = parseWords(s, {"ignoreShape", "is"});
        if (p.has("uid") || p.args.empty()) return;  // Maya's unique ids say nothing about evaluation
        if (p.args.size() == 1) {
            scene_.rename(currentNode(s), (ns_.empty() ? "" : ns_ + ":") + p.args[0]->text);
            return;
        }
        const int node = require(*p.args[0], p.args[0]->text);
        scene_.rename(node, (ns_.empty() ? "" : ns_ + ":") + p.args[1]->text);
    }

    void parent(const Statement& s)
    {
        const Parsed p = parseWords(s, {"s", "shape", "nc", "noConnections", "r", "relative", "a", "absolute", "add",
                                        "addObject", "w", "world", "rm", "removeObject"});
        if (p.has("add", "addObject") || p.has("rm", "removeObject")) {
            ++scene_.skipped["parent -add (instances)"];
            return;
        }
        const bool world = p.has("w", "world");
        if (p.args.size() < (world ? 1u : 2u)) fail(s.words.front(), "parent needs a child and a parent");
        const int newParent = world ? -1 : require(*p.args.back(), p.args.back()->text);
        const std::size_t children = world ? p.args.size() : p.args.size() - 1;
        for (std::size_t i = 0; i < children; ++i) scene_.reparent(require(*p.args[i], p.args[i]->text), newParent);
    }

    void lockNode(const Statement& s)
    {
        const Parsed p = parseWords(s, {});
        const Word* lock = p.flag("l", "lock");
        const bool on = !lock || lock->text == "1" || lock->text == "true" || lock->text == "on";
        const int node = p.args.empty() ? currentNode(s) : require(*p.args.front(), p.args.front()->text);
        scene_.nodes[static_cast<std::size_t>(node)].locked = on;
    }

    void file(const Statement& s)
    {
        const Parsed p = parseWords(s, {"r", "reference", "dns", "iv", "ignoreVersion", "f", "force"});
        if (!p.has("r", "reference")) return;  // -rdi: the same reference, declared for Maya's loader
        if (p.args.empty()) fail(s.words.front(), "file -r without a path");
        Reference r;
        r.path = p.args.back()->text;
        if (const Word* ns = p.flag("ns", "namespace")) r.nameSpace = ns->text;
        if (const Word* rfn = p.flag("rfn", "referenceNode")) r.node = (ns_.empty() ? "" : ns_ + ":") + rfn->text;
        if (!ns_.empty()) r.nameSpace = ns_ + ":" + r.nameSpace;
        r.where = where(s.words.front());
        scene_.references.push_back(std::move(r));
    }

    void currentUnit(const Statement& s);

    void fileInfo(const Statement& s)
    {
        if (file_ != 0 || s.words.size() < 3) return;
        scene_.fileInfo[s.words[1].text] = s.words[2].text;
    }

    Scene& scene_;
    int file_;
    std::string ns_;
    int current_ = -1;
};

struct UnitName {
    std::string_view shortName, longName;
    double factor;
};

constexpr UnitName linearUnits[] = {{"mm", "millimeter", 0.1}, {"cm", "centimeter", 1.0}, {"m", "meter", 100.0},
                                    {"km", "kilometer", 1e5},  {"in", "inch", 2.54},      {"ft", "foot", 30.48},
                                    {"yd", "yard", 91.44},     {"mi", "mile", 160934.4}};
constexpr UnitName angleUnits[] = {{"deg", "degree", 1.0},
                                   {"rad", "radian", 57.295779513082320876798},
                                   {"min", "angMinute", 1.0 / 60.0},
                                   {"sec", "angSecond", 1.0 / 3600.0}};
constexpr UnitName timeUnits[] = {{"game", "game", 15.0},   {"film", "film", 24.0}, {"pal", "pal", 25.0},
                                  {"ntsc", "ntsc", 30.0},   {"show", "show", 48.0}, {"palf", "palf", 50.0},
                                  {"ntscf", "ntscf", 60.0}, {"sec", "second", 1.0}, {"ms", "millisecond", 1000.0}};

template <std::size_t N>
std::optional<double> unitFactor(const UnitName (&table)[N], std::string_view name)
{
    for (const UnitName& u : table)
        if (u.shortName == name || u.longName == name) return u.factor;
    return std::nullopt;
}

void Reader::currentUnit(const Statement& s)
{
    const Parsed p = parseWords(s, {});
    Units& u = scene_.units.at(static_cast<std::size_t>(file_));
    if (const Word* w = p.flag("l", "linear")) {
        const auto f = unitFactor(linearUnits, w->text);
        if (!f) fail(*w, fmt::format("unknown linear unit '{}'", messageExcerpt(w->text)));
        u.linearToCm = *f;
        u.linear = w->text;
    }
    if (const Word* w = p.flag("a", "angle")) {
        const auto f = unitFactor(angleUnits, w->text);
        if (!f) fail(*w, fmt::format("unknown angular unit '{}'", messageExcerpt(w->text)));
        u.angleToDegrees = *f;
        u.angle = w->text;
    }
    if (const Word* w = p.flag("t", "time")) {
        auto f = unitFactor(timeUnits, w->text);
        if (!f && w->text.ends_with("fps")) f = std::strtod(w->text.c_str(), nullptr);  // "23.976fps"
        if (!f || !(*f > 0)) fail(*w, fmt::format("unknown time unit '{}'", messageExcerpt(w->text)));
        u.framesPerSecond = *f;
        u.time = w->text;
    }
}

}  // namespace

std::pair<std::string, std::string> splitPlug(std::string_view plug)
{
    // The node part ends at the first '.' after the last '|' (names hold no '.').
    const std::size_t bar = plug.rfind('|');
    const std::size_t dot = plug.find('.', bar == std::string_view::npos ? 0 : bar);
    if (dot == std::string_view::npos) return {std::string(plug), {}};
    return {std::string(plug.substr(0, dot)), std::string(plug.substr(dot + 1))};
}

int Scene::find(std::string_view name) const
{
    if (!name.empty() && name[0] == ':') name.remove_prefix(1);
    if (name.empty()) return -1;
    const bool absolute = name[0] == '|';
    const std::size_t bar = name.rfind('|');
    const std::string leaf(bar == std::string_view::npos ? name : name.substr(bar + 1));
    const auto [first, last] = byLeaf_.equal_range(leaf);
    int found = -1;
    int count = 0;
    for (auto it = first; it != last; ++it) {
        if (bar != std::string_view::npos) {
            const std::string p = path(it->second);
            const bool match = absolute ? p == name : (p.ends_with(name) && p[p.size() - name.size() - 1] == '|');
            if (!match) continue;
        }
        found = it->second;
        ++count;
    }
    if (count > 1)
        throw Error(
            fmt::format("'{}' names {} nodes; write its DAG path (|parent|{})", messageExcerpt(name), count, leaf));
    return found;
}

std::string Scene::path(int node) const
{
    std::string p;
    for (int n = node; n >= 0; n = nodes[static_cast<std::size_t>(n)].parent)
        p = "|" + nodes[static_cast<std::size_t>(n)].name + p;
    return p;
}

int Scene::add(Node node)
{
    const auto [first, last] = byLeaf_.equal_range(node.name);
    for (auto it = first; it != last; ++it)
        if (nodes[static_cast<std::size_t>(it->second)].parent == node.parent)
            throw Error(fmt::format("a node named '{}' exists already under the same parent", node.name));
    const int index = static_cast<int>(nodes.size());
    byLeaf_.emplace(node.name, index);
    nodes.push_back(std::move(node));
    return index;
}

void Scene::rename(int node, std::string newName)
{
    auto [first, last] = byLeaf_.equal_range(nodes[static_cast<std::size_t>(node)].name);
    for (auto it = first; it != last; ++it)
        if (it->second == node) {
            byLeaf_.erase(it);
            break;
        }
    nodes[static_cast<std::size_t>(node)].name = newName;
    byLeaf_.emplace(std::move(newName), node);
}

std::string formatWhere(const Scene& scene, const Where& where)
{
    return formatMark({scene.files.at(static_cast<std::size_t>(where.file)), where.line, where.column});
}

void readStatements(Scene& scene, const std::vector<Statement>& statements, int fileIndex, const std::string& nameSpace)
{
    Reader(scene, fileIndex, nameSpace).run(statements);
}

}  // namespace rig::maya
