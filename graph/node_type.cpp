#include "graph/node_type.h"

#include <algorithm>
#include <set>

#include <fmt/format.h>

#include "core/error.h"

namespace rig {
namespace {

std::string lowerAscii(std::string text)
{
    for (char& ch : text)
        if (ch >= 'A' && ch <= 'Z') ch = static_cast<char>(ch - 'A' + 'a');
    return text;
}

}  // namespace

AttrId NodeType::findAttribute(std::string_view name) const
{
    for (std::size_t i = 0; i < attributes_.size(); ++i)
        if (attributes_[i].name == name) return static_cast<AttrId>(i);
    return -1;
}

AttrId NodeType::findMayaAttribute(std::string_view name) const
{
    for (std::size_t i = 0; i < attributes_.size(); ++i) {
        const AttributeSpec& a = attributes_[i];
        if (a.mayaCompound.empty() && (a.name == name || a.shortName == name)) return static_cast<AttrId>(i);
    }
    return -1;
}

std::vector<AttrId> NodeType::mayaCompoundChildren(std::string_view compound) const
{
    std::vector<AttrId> children;
    for (std::size_t i = 0; i < attributes_.size(); ++i) {
        const AttributeSpec& a = attributes_[i];
        if (!a.mayaCompound.empty() && (a.mayaCompound == compound || a.mayaCompoundShort == compound))
            children.push_back(static_cast<AttrId>(i));
    }
    return children;
}

AttributeSpec& AttributeBuilder::spec() { return owner_.type_.attributes_[static_cast<std::size_t>(id_)]; }

AttributeBuilder& AttributeBuilder::defaultValue(Value value)
{
    spec().defaultValue = std::move(value);
    return *this;
}

AttributeBuilder& AttributeBuilder::unit(Unit unit)
{
    spec().unit = unit;
    return *this;
}

AttributeBuilder& AttributeBuilder::keyable(bool on)
{
    spec().keyable = on;
    return *this;
}

AttributeBuilder& AttributeBuilder::array(bool on)
{
    spec().array = on;
    return *this;
}

AttributeBuilder& AttributeBuilder::range(double min, double max)
{
    spec().min = min;
    spec().max = max;
    return *this;
}

AttributeBuilder& AttributeBuilder::min(double min)
{
    spec().min = min;
    return *this;
}

AttributeBuilder& AttributeBuilder::max(double max)
{
    spec().max = max;
    return *this;
}

AttributeBuilder& AttributeBuilder::enumNames(std::vector<std::string> names)
{
    spec().enumNames = std::move(names);
    return *this;
}

AttributeBuilder& AttributeBuilder::children(std::string x, std::string y, std::string z)
{
    spec().childNames = {std::move(x), std::move(y), std::move(z)};
    return *this;
}

AttributeBuilder& AttributeBuilder::filePath(bool on)
{
    spec().filePath = on;
    return *this;
}

AttributeBuilder& AttributeBuilder::sceneTime(bool on)
{
    spec().sceneTime = on;
    return *this;
}

AttributeBuilder& AttributeBuilder::doc(std::string description)
{
    spec().description = std::move(description);
    return *this;
}

AttributeBuilder& AttributeBuilder::shortName(std::string name)
{
    spec().shortName = std::move(name);
    return *this;
}

AttributeBuilder& AttributeBuilder::childShortNames(std::string x, std::string y, std::string z)
{
    spec().childShortNames = {std::move(x), std::move(y), std::move(z)};
    return *this;
}

AttributeBuilder& AttributeBuilder::mayaCompound(std::string longName, std::string shortName)
{
    spec().mayaCompound = std::move(longName);
    spec().mayaCompoundShort = std::move(shortName);
    return *this;
}

NodeTypeBuilder::NodeTypeBuilder(std::string typeName) { type_.name_ = std::move(typeName); }

AttributeBuilder NodeTypeBuilder::add(AttrId id, std::string name, ValueType type, bool input)
{
    if (static_cast<std::size_t>(id) != type_.attributes_.size())
        throw internalError(fmt::format("node type '{}': attribute '{}' declared with id {} but is number {}",
                                        type_.name_, name, id, type_.attributes_.size()));
    AttributeSpec spec;
    spec.childNames = {name + "X", name + "Y", name + "Z"};
    spec.name = std::move(name);
    spec.type = type;
    spec.input = input;
    spec.defaultValue = zeroValue(type);
    type_.attributes_.push_back(std::move(spec));
    type_.affects_.emplace_back();
    return AttributeBuilder(*this, id);
}

AttributeBuilder NodeTypeBuilder::input(AttrId id, std::string name, ValueType type)
{
    return add(id, std::move(name), type, true);
}

AttributeBuilder NodeTypeBuilder::output(AttrId id, std::string name, ValueType type)
{
    return add(id, std::move(name), type, false);
}

NodeTypeBuilder& NodeTypeBuilder::affects(AttrId input, std::initializer_list<AttrId> outputs)
{
    auto& list = type_.affects_.at(static_cast<std::size_t>(input));
    for (AttrId o : outputs)
        if (std::find(list.begin(), list.end(), o) == list.end()) list.push_back(o);
    return *this;
}

NodeTypeBuilder& NodeTypeBuilder::affectsAll()
{
    for (std::size_t i = 0; i < type_.attributes_.size(); ++i) {
        if (!type_.attributes_[i].input) continue;
        type_.affects_[i].clear();
        for (std::size_t o = 0; o < type_.attributes_.size(); ++o)
            if (!type_.attributes_[o].input) type_.affects_[i].push_back(static_cast<AttrId>(o));
    }
    return *this;
}

NodeTypeBuilder& NodeTypeBuilder::description(std::string text)
{
    type_.description_ = std::move(text);
    return *this;
}

NodeTypeBuilder& NodeTypeBuilder::stateful(bool on)
{
    type_.stateful_ = on;
    return *this;
}

NodeTypeBuilder& NodeTypeBuilder::yamlField(std::string field, YamlFieldParser parser)
{
    type_.yamlFields_[std::move(field)] = std::move(parser);
    return *this;
}

NodeTypeBuilder& NodeTypeBuilder::yamlConnector(std::string field, YamlConnector connector)
{
    type_.yamlConnectors_[std::move(field)] = std::move(connector);
    return *this;
}

NodeTypeBuilder& NodeTypeBuilder::mayaType(std::string name)
{
    type_.mayaType_ = std::move(name);
    return *this;
}

NodeTypeBuilder& NodeTypeBuilder::notMaya()
{
    type_.readsMaya_ = false;
    return *this;
}

NodeTypeBuilder& NodeTypeBuilder::mayaField(std::string longName, std::string shortName, MayaFieldParser parser)
{
    type_.mayaFields_[std::move(longName)] = parser;
    type_.mayaFields_[std::move(shortName)] = std::move(parser);
    return *this;
}

NodeTypeBuilder& NodeTypeBuilder::mayaCheck(MayaCheck check)
{
    type_.mayaCheck_ = std::move(check);
    return *this;
}

NodeTypeBuilder& NodeTypeBuilder::factory(std::function<std::unique_ptr<Node>()> make)
{
    type_.factory_ = std::move(make);
    return *this;
}

std::shared_ptr<const NodeType> NodeTypeBuilder::build()
{
    const std::string& typeName = type_.name_;
    auto fail = [&](const std::string& what) {
        throw internalError(fmt::format("node type '{}': {}", typeName, what));
    };
    if (!type_.factory_) fail("no factory");
    std::set<std::string, std::less<>> names;
    for (std::size_t i = 0; i < type_.attributes_.size(); ++i) {
        const AttributeSpec& a = type_.attributes_[i];
        if (!names.insert(a.name).second) fail(fmt::format("attribute '{}' declared twice", a.name));
        if (type_.yamlFields_.count(a.name) || type_.yamlConnectors_.count(a.name))
            fail(fmt::format("'{}' is both an attribute and a YAML field", a.name));
        if (zeroValue(a.type).index() != a.defaultValue.index())
            fail(fmt::format("attribute '{}': default is not a {}", a.name, valueTypeName(a.type)));
        if (a.type == ValueType::Enum && a.enumNames.empty()) fail(fmt::format("enum '{}' has no names", a.name));
        if (a.min && a.max && *a.min > *a.max) fail(fmt::format("attribute '{}': min > max", a.name));
        if (!a.input && !type_.affects_[i].empty()) fail(fmt::format("output '{}' cannot affect anything", a.name));
        for (AttrId o : type_.affects_[i]) {
            if (o < 0 || static_cast<std::size_t>(o) >= type_.attributes_.size() || type_.attributes_[o].input)
                fail(fmt::format("input '{}' affects {} which is not an output", a.name, o));
        }
        if (a.type == ValueType::Vector3)
            for (const std::string& child : a.childNames)
                if (!names.insert(child).second) fail(fmt::format("child name '{}' used twice", child));
    }
    std::set<std::string, std::less<>> mayaNames;  // one Maya name, one attribute
    for (AttributeSpec& a : type_.attributes_) {
        // A vector3's children's short names: the short name plus each child's suffix (tx, shxy).
        if (a.type == ValueType::Vector3 && !a.shortName.empty())
            for (std::size_t i = 0; i < 3; ++i)
                if (a.childShortNames[i].empty() && a.childNames[i].starts_with(a.name))
                    a.childShortNames[i] = a.shortName + lowerAscii(a.childNames[i].substr(a.name.size()));
        const std::string group = a.mayaCompound.empty() ? std::string() : a.mayaCompound + ".";
        if (!a.shortName.empty() && a.shortName != a.name && !mayaNames.insert(group + a.shortName).second)
            fail(fmt::format("Maya short name '{}' used twice", a.shortName));
        if (!mayaNames.insert(group + a.name).second && !a.mayaCompound.empty())
            fail(fmt::format("attribute '{}' declared twice in Maya compound '{}'", a.name, a.mayaCompound));
    }
    type_.outputs_.clear();
    for (std::size_t i = 0; i < type_.attributes_.size(); ++i)
        if (!type_.attributes_[i].input) type_.outputs_.push_back(static_cast<AttrId>(i));
    return std::make_shared<const NodeType>(std::move(type_));
}

}  // namespace rig
