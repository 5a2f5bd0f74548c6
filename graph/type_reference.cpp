#include "graph/type_reference.h"

#include <fmt/format.h>

namespace rig {
namespace {

// A default in file units, as a rig file would write it.
std::string defaultText(const AttributeSpec& spec)
{
    const double k = unitFactor(spec.unit, Unit::None);
    const Value& v = spec.defaultValue;
    if (spec.array) return "";
    switch (spec.type) {
        case ValueType::Double:
            return fmt::format("{:g}", std::get<double>(v) * k);
        case ValueType::Int:
            return fmt::format("{}", std::get<int>(v));
        case ValueType::Bool:
            return std::get<bool>(v) ? "true" : "false";
        case ValueType::Enum:
            return spec.enumNames.at(static_cast<std::size_t>(std::get<int>(v)));
        case ValueType::String:
            return fmt::format("\"{}\"", std::get<std::string>(v));
        case ValueType::Vector3: {
            const auto& x = std::get<Eigen::Vector3d>(v);
            return fmt::format("[{:g}, {:g}, {:g}]", x[0] * k, x[1] * k, x[2] * k);
        }
        case ValueType::Matrix4:
            return "identity";
        case ValueType::DoubleArray:
        case ValueType::Matrix4Array:
            return "[]";
    }
    return "";
}

std::string typeText(const AttributeSpec& spec)
{
    std::string text(valueTypeName(spec.type));
    if (spec.type == ValueType::Enum) {
        std::string names;
        for (const auto& n : spec.enumNames) names += (names.empty() ? "" : "/") + n;
        text += " (" + names + ")";
    }
    if (spec.type == ValueType::Vector3)
        text += fmt::format(" ({}, {}, {})", spec.childNames[0], spec.childNames[1], spec.childNames[2]);
    if (spec.array) text += "[]";
    return text;
}

std::string unitText(const AttributeSpec& spec)
{
    switch (spec.unit) {
        case Unit::Angle:
            return "degrees";
        case Unit::Distance:
            return "cm";
        case Unit::Time:
            return "frames";
        case Unit::None:
            break;
    }
    return "";
}

std::string limitsText(const AttributeSpec& spec)
{
    const double k = unitFactor(spec.unit, Unit::None);
    if (spec.min && spec.max) return fmt::format("{:g}..{:g}", *spec.min * k, *spec.max * k);
    if (spec.min) return fmt::format(">= {:g}", *spec.min * k);
    if (spec.max) return fmt::format("<= {:g}", *spec.max * k);
    return "";
}

// Maya's name for the attribute (docs/maya.md): `.t`, or `.tg[i].tt` for a child of a compound multi attribute.
std::string mayaText(const AttributeSpec& a)
{
    if (a.shortName.empty()) return "";
    if (!a.mayaCompound.empty()) return fmt::format("`.{}[i].{}`", a.mayaCompoundShort, a.shortName);
    return fmt::format("`.{}`", a.shortName);
}

}  // namespace

std::string nodeTypeReference(const NodeRegistry& registry)
{
    std::string out;
    for (const std::string& name : registry.typeNames()) {
        const NodeType& type = *registry.find(name);
        out += fmt::format("### {}\n\n{}\n\n", name, type.description());
        if (type.stateful()) out += "History-dependent: its output depends on earlier evaluations.\n\n";
        if (!type.yamlFields().empty() || !type.yamlConnectors().empty()) {
            std::string fields;
            for (const auto& f : type.yamlFields()) fields += (fields.empty() ? "`" : ", `") + f.first + "`";
            for (const auto& f : type.yamlConnectors()) fields += (fields.empty() ? "`" : ", `") + f.first + "`";
            out += fmt::format("Rig-file fields besides attributes: {}.\n\n", fields);
        }
        if (!type.mayaType().empty()) out += fmt::format("Read from a Maya scene's `{}` nodes.\n\n", type.mayaType());
        if (!type.mayaFields().empty()) {
            std::string fields;
            for (const auto& f : type.mayaFields()) fields += (fields.empty() ? "`." : ", `.") + f.first + "`";
            out += fmt::format("Maya attributes read into the attributes below: {}.\n\n", fields);
        }
        out += "| attribute | Maya | in/out | type | unit | default | limits | keyable | description |\n";
        out += "|---|---|---|---|---|---|---|---|---|\n";
        for (const AttributeSpec& a : type.attributes())
            out += fmt::format("| `{}` | {} | {} | {} | {} | {} | {} | {} | {} |\n", a.name, mayaText(a),
                               a.input ? "in" : "out", typeText(a), unitText(a), defaultText(a), limitsText(a),
                               a.keyable ? "yes" : "",
                               a.description + (a.sceneTime ? " Follows the scene time when unconnected." : ""));
        std::string affects;
        for (AttrId i = 0; i < static_cast<AttrId>(type.attributes().size()); ++i) {
            if (type.affects(i).empty()) continue;
            std::string outs;
            for (AttrId o : type.affects(i)) outs += (outs.empty() ? "" : ", ") + type.attribute(o).name;
            affects += fmt::format("`{}` → {}; ", type.attribute(i).name, outs);
        }
        if (!affects.empty()) out += fmt::format("\nAffects: {}\n", affects.substr(0, affects.size() - 2));
        out += "\n";
    }
    return out;
}

}  // namespace rig
