#include "app/common/value_output.h"

#include <cmath>
#include <cstdint>
#include <numbers>

#include <fmt/format.h>

namespace rig::app {
namespace {

// The value's numbers in user units, with their column suffixes.
std::vector<std::pair<std::string, double>> flatten(const Graph& graph, const Plug& plug, const Value& value)
{
    const double k = userScale(graph, plug);
    const AttributeSpec& spec = graph.spec(plug);
    std::vector<std::pair<std::string, double>> out;
    std::visit(
        [&](const auto& v) {
            using T = std::decay_t<decltype(v)>;
            if constexpr (std::is_same_v<T, Eigen::Vector3d>) {
                for (int i = 0; i < 3; ++i)
                    out.emplace_back("." + spec.childNames[static_cast<std::size_t>(i)], v[i] * k);
            } else if constexpr (std::is_same_v<T, Eigen::Matrix4d>) {
                for (int r = 0; r < 4; ++r)
                    for (int c = 0; c < 4; ++c) out.emplace_back(fmt::format("[{}][{}]", r, c), v(r, c));
            } else if constexpr (std::is_same_v<T, std::vector<double>>) {
                for (std::size_t i = 0; i < v.size(); ++i) out.emplace_back(fmt::format("[{}]", i), v[i] * k);
            } else if constexpr (std::is_same_v<T, Matrix4Array>) {
                for (std::size_t i = 0; i < v.size(); ++i)
                    for (int r = 0; r < 4; ++r)
                        for (int c = 0; c < 4; ++c) out.emplace_back(fmt::format("[{}][{}][{}]", i, r, c), v[i](r, c));
            } else if constexpr (std::is_same_v<T, std::string>) {
            } else out.emplace_back("", toDouble(v) * k);
        },
        value);
    return out;
}

Json matrixJson(const Eigen::Matrix4d& m)
{
    Json rows = Json::array();
    for (int r = 0; r < 4; ++r)
        rows.push_back(
            Json::array({numberJson(m(r, 0)), numberJson(m(r, 1)), numberJson(m(r, 2)), numberJson(m(r, 3))}));
    return rows;
}

}  // namespace

double userScale(const Graph& graph, const Plug& plug) { return unitFactor(graph.spec(plug).unit, Unit::None); }

double parameterUserValue(const RigParameter& parameter, double internal)
{
    return parameter.angular ? internal * 180.0 / std::numbers::pi : internal;
}

double parameterInternalValue(const RigParameter& parameter, double user)
{
    return parameter.angular ? user * std::numbers::pi / 180.0 : user;
}

std::string heldText(const std::vector<HeldPlug>& held)
{
    std::string out;
    for (const HeldPlug& h : held) out += fmt::format("{}{} = {}", out.empty() ? "" : ", ", h.plug, h.value);
    return out;
}

Json heldJson(const std::vector<HeldPlug>& held)
{
    Json out = Json::array();
    for (const HeldPlug& h : held) out.push_back({{"plug", h.plug}, {"value", numberJson(h.value)}});
    return out;
}

Json numberJson(double x)
{
    // Below 1e16 every whole double is an exact int64. -0 stays a double: as an integer it would read
    // back as +0. NaN and infinities stay doubles too, which nlohmann writes as null.
    if (x == std::trunc(x) && std::abs(x) < 1e16 && !(x == 0.0 && std::signbit(x))) return static_cast<std::int64_t>(x);
    return x;
}

std::string jsonText(const Json& json, int indent)
{
    if (indent >= 0 || !json.is_array()) return json.dump(indent, ' ', false, Json::error_handler_t::replace);
    // nlohmann's one-line form has no spaces; values hold arrays, never objects.
    std::string out = "[";
    for (std::size_t i = 0; i < json.size(); ++i) (out += i ? ", " : "") += jsonText(json[i]);
    return out + "]";
}

std::string frameJson(double frame, const std::vector<std::pair<std::string, Json>>& values)
{
    std::string out = "  {\"frame\": " + jsonText(numberJson(frame));
    for (const auto& [name, value] : values) out += ",\n   " + jsonText(Json(name)) + ": " + jsonText(value);
    return out + "}";
}

Json valueToJson(const Graph& graph, const Plug& plug, const Value& value)
{
    const double k = userScale(graph, plug);
    const AttributeSpec& spec = graph.spec(plug);
    return std::visit(
        [&](const auto& v) -> Json {
            using T = std::decay_t<decltype(v)>;
            if constexpr (std::is_same_v<T, Eigen::Vector3d>)
                return Json::array({numberJson(v[0] * k), numberJson(v[1] * k), numberJson(v[2] * k)});
            else if constexpr (std::is_same_v<T, Eigen::Matrix4d>) return matrixJson(v);
            else if constexpr (std::is_same_v<T, std::vector<double>>) {
                Json out = Json::array();
                for (const double x : v) out.push_back(numberJson(x * k));
                return out;
            } else if constexpr (std::is_same_v<T, Matrix4Array>) {
                Json out = Json::array();
                for (const auto& m : v) out.push_back(matrixJson(m));
                return out;
            } else if constexpr (std::is_same_v<T, std::string> || std::is_same_v<T, bool>) return v;
            else if constexpr (std::is_same_v<T, int>) {
                if (plug.child < 0 && spec.type == ValueType::Enum && v >= 0 &&
                    static_cast<std::size_t>(v) < spec.enumNames.size())
                    return spec.enumNames[static_cast<std::size_t>(v)];
                return v;
            } else return numberJson(v * k);
        },
        value);
}

std::vector<std::string> csvColumns(const Graph& graph, const Plug& plug, const Value& value)
{
    const std::string name = graph.plugName(plug);
    std::vector<std::string> columns;
    if (std::holds_alternative<std::string>(value)) return {name};
    for (const auto& [suffix, x] : flatten(graph, plug, value)) {
        // A vector3 component column is named like its plug: node.rotateX, not node.rotate.rotateX.
        if (!suffix.empty() && suffix.front() == '.' && plug.index < 0)
            columns.push_back(name.substr(0, name.find('.')) + suffix);
        else columns.push_back(name + suffix);
    }
    return columns;
}

std::vector<std::string> csvFields(const Graph& graph, const Plug& plug, const Value& value, int digits)
{
    if (const auto* s = std::get_if<std::string>(&value)) return {jsonText(Json(*s))};
    // An enum by its name, as the JSON output writes it (one spelling whatever the format); names need no quotes.
    if (std::holds_alternative<int>(value))
        if (const Json named = valueToJson(graph, plug, value); named.is_string()) return {named.get<std::string>()};
    std::vector<std::string> fields;
    for (const auto& [suffix, x] : flatten(graph, plug, value)) {
        if (!std::isfinite(x)) fields.emplace_back();
        else if (digits > 0) fields.push_back(fmt::format("{:.{}g}", x == 0.0 ? 0.0 : x, digits));
        else fields.push_back(fmt::format("{}", x));
    }
    return fields;
}

}  // namespace rig::app
