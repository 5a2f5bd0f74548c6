#pragma once
// Node types are data (Maya's MPxNode::initialize): attributes, the affects table, a factory.
// A NodeTypeBuilder declares them; build() checks the declaration and freezes it.

#include <functional>
#include <initializer_list>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "graph/attribute.h"
#include "graph/node.h"
#include "graph/plug.h"

namespace YAML {
class Node;
}

namespace rig {

class Graph;

// A rig-file field that is not one attribute (an animation curve's `keys: [[0, 0], [10, 90]]`):
// it turns the YAML value into attribute values. It throws rig::Error; `where(n)` gives the
// "file:line:col" of a YAML node for the message.
struct YamlFieldContext {
    std::function<std::string(const YAML::Node&)> where;
};
using YamlFieldParser =
    std::function<std::vector<std::pair<AttrId, Value>>(const YAML::Node& value, const YamlFieldContext& context)>;
// A rig-file field that wires its node into the graph (rigInversion's `connect: {targets: clip}`): it runs
// once every node, value and connection of the file and of its includes exists, in file order, and may
// read plugs and connect them. It throws rig::Error.
using YamlConnector =
    std::function<void(Graph& graph, NodeId node, const YAML::Node& value, const YamlFieldContext& context)>;

// A Maya attribute that is not one attribute here (an animation curve's ".ktv[0:5]", key times and values stored
// as two arrays): a setAttr of it, for elements `first` to `last` (-1, -1 without an element), with its value words
// as Maya wrote them, turns into attribute values. `current` reads the node's value of an attribute as set so far (a
// curve's keys come in several setAttr statements). It throws rig::Error with the message only; the loader adds where.
struct MayaFieldInput {
    int first = -1;
    int last = -1;
    std::vector<std::string> words;
    std::function<Value(AttrId)> current;
    // The scene's units, as factors to cm, degrees and frames (a curve's keys are in the scene's units).
    double linearToCm = 1.0;
    double angleToDegrees = 1.0;
};
using MayaFieldParser = std::function<std::vector<std::pair<AttrId, Value>>(const MayaFieldInput& input)>;
// Whether a node of a type, with the values a Maya scene gave it (read through `value`), can be evaluated: the reason
// it cannot (an expression that calls MEL commands), or nothing. The loader refuses such a node where it drives a
// joint.
using MayaCheck = std::function<std::optional<std::string>(const std::function<Value(AttrId)>& value)>;

class NodeType {
public:
    const std::string& name() const { return name_; }
    const std::string& description() const { return description_; }
    const std::vector<AttributeSpec>& attributes() const { return attributes_; }
    const AttributeSpec& attribute(AttrId a) const { return attributes_[static_cast<std::size_t>(a)]; }
    // The attribute's index, or -1.
    AttrId findAttribute(std::string_view name) const;
    // Outputs whose value depends on input `a` (Maya's attributeAffects).
    const std::vector<AttrId>& affects(AttrId a) const { return affects_[static_cast<std::size_t>(a)]; }
    // The outputs, in order: a node's dynamic attributes are inputs, so these are every node's outputs.
    const std::vector<AttrId>& outputs() const { return outputs_; }
    // History-dependent nodes give different results when recomputed; checked mode skips them.
    bool stateful() const { return stateful_; }
    const std::map<std::string, YamlFieldParser, std::less<>>& yamlFields() const { return yamlFields_; }
    const std::map<std::string, YamlConnector, std::less<>>& yamlConnectors() const { return yamlConnectors_; }
    std::unique_ptr<Node> create() const { return factory_(); }

    // --- Maya (docs/maya.md) ---
    // The Maya node type this type stands for when a Maya scene is read ("ikHandle" for mayaIkHandle); empty: the
    // type's own name, when it is one of Maya's.
    const std::string& mayaType() const { return mayaType_; }
    // False for a type of this project whose name Maya uses for another node (our lookAt, spring): a Maya scene's
    // node of that name is not made one.
    bool readsMaya() const { return readsMaya_; }
    // The attribute a Maya scene names `name` (long or short, Maya's spelling), or -1. A vector3 child's name
    // (".tx") is found by mayaChildIndex on the parent's spec.
    AttrId findMayaAttribute(std::string_view name) const;
    // The attributes flattened from Maya's compound multi attribute `compound` (long or short name), in declaration
    // order (a setAttr of several elements gives each element's children in this order).
    std::vector<AttrId> mayaCompoundChildren(std::string_view compound) const;
    const std::map<std::string, MayaFieldParser, std::less<>>& mayaFields() const { return mayaFields_; }
    const MayaCheck& mayaCheck() const { return mayaCheck_; }

private:
    friend class NodeTypeBuilder;
    friend class AttributeBuilder;
    std::string name_;
    std::string description_;
    std::vector<AttributeSpec> attributes_;
    std::vector<std::vector<AttrId>> affects_;
    std::vector<AttrId> outputs_;
    bool stateful_ = false;
    std::map<std::string, YamlFieldParser, std::less<>> yamlFields_;
    std::map<std::string, YamlConnector, std::less<>> yamlConnectors_;
    std::string mayaType_;
    bool readsMaya_ = true;
    std::map<std::string, MayaFieldParser, std::less<>> mayaFields_;
    MayaCheck mayaCheck_;
    std::function<std::unique_ptr<Node>()> factory_;
};

class NodeTypeBuilder;

// Fluent setters for the attribute just declared.
class AttributeBuilder {
public:
    AttributeBuilder(NodeTypeBuilder& owner, AttrId id) : owner_(owner), id_(id) {}
    AttributeBuilder& defaultValue(Value value);
    AttributeBuilder& unit(Unit unit);
    AttributeBuilder& keyable(bool on = true);
    AttributeBuilder& array(bool on = true);
    AttributeBuilder& range(double min, double max);
    AttributeBuilder& min(double min);
    AttributeBuilder& max(double max);
    AttributeBuilder& enumNames(std::vector<std::string> names);
    // Vector3 components; by default name + "X", "Y", "Z".
    AttributeBuilder& children(std::string x, std::string y, std::string z);
    AttributeBuilder& sceneTime(bool on = true);
    AttributeBuilder& filePath(bool on = true);
    AttributeBuilder& doc(std::string description);
    // Maya's short name (docs/maya.md): "t" for translate.
    AttributeBuilder& shortName(std::string name);
    // A vector3's children's short names where they are not the short name plus each child's suffix.
    AttributeBuilder& childShortNames(std::string x, std::string y, std::string z);
    // This array attribute is a child of Maya's compound multi attribute `longName` ("target", short "tg").
    AttributeBuilder& mayaCompound(std::string longName, std::string shortName);

private:
    AttributeSpec& spec();
    NodeTypeBuilder& owner_;
    AttrId id_;
};

class NodeTypeBuilder {
public:
    explicit NodeTypeBuilder(std::string typeName);

    // `id` must equal the number of attributes declared so far: node classes name attributes by an
    // enum, and this keeps the enum and the declaration in step.
    AttributeBuilder input(AttrId id, std::string name, ValueType type);
    AttributeBuilder output(AttrId id, std::string name, ValueType type);
    NodeTypeBuilder& affects(AttrId input, std::initializer_list<AttrId> outputs);
    // Every input affects every output.
    NodeTypeBuilder& affectsAll();
    NodeTypeBuilder& description(std::string text);
    NodeTypeBuilder& stateful(bool on = true);
    NodeTypeBuilder& yamlField(std::string field, YamlFieldParser parser);
    NodeTypeBuilder& yamlConnector(std::string field, YamlConnector connector);
    // The Maya node type this type stands for, when it is not the type's own name.
    NodeTypeBuilder& mayaType(std::string name);
    // This type is not the Maya node of the same name (see NodeType::readsMaya).
    NodeTypeBuilder& notMaya();
    // A Maya attribute read by a parser (MayaFieldParser), named by its long and short names.
    NodeTypeBuilder& mayaField(std::string longName, std::string shortName, MayaFieldParser parser);
    NodeTypeBuilder& mayaCheck(MayaCheck check);
    NodeTypeBuilder& factory(std::function<std::unique_ptr<Node>()> make);
    template <class T>
    NodeTypeBuilder& factory()
    {
        return factory([] { return std::unique_ptr<Node>(std::make_unique<T>()); });
    }

    // Checks the declaration (throws an internal rig::Error naming the type and attribute) and freezes it.
    std::shared_ptr<const NodeType> build();

private:
    friend class AttributeBuilder;
    AttributeBuilder add(AttrId id, std::string name, ValueType type, bool input);
    NodeType type_;
};

}  // namespace rig
