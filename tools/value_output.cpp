#include "tools/value_output.h"

#include <cmath>

#include <fmt/format.h>

namespace rig::cli {
namespace {

std::string number(double x) { return std::isfinite(x) ? fmt::format("{}", x) : std::string("null"); }

double userScale(const Graph& graph, const Plug& plug) { return unitFactor(graph.spec(plug).unit, Unit::None); }

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
            }
            else if constexpr (std::is_same_v<T, Eigen::Matrix4d>) {
                for (int r = 0; r < 4; ++r)
                    for (int c = 0; c < 4; ++c) out.emplace_back(fmt::format("[{}][{}]", r, c), v(r, c));
            }
            else if constexpr (std::is_same_v<T, std::vector<double>>) {
                for (std::size_t i = 0; i < v.size(); ++i) out.emplace_back(fmt::format("[{}]", i), v[i] * k);
            }
            else if constexpr (std::is_same_v<T, Matrix4Array>) {
                for (std::size_t i = 0; i < v.size(); ++i)
                    for (int r = 0; r < 4; ++r)
                        for (int c = 0; c < 4; ++c) out.emplace_back(fmt::format("[{}][{}][{}]", i, r, c), v[i](r, c));
            }
            else if constexpr (std::is_same_v<T, std::string>) {
            }
            else out.emplace_back("", toDouble(v) * k);
        },
        value);
    return out;
}

std::string matrixJson(const Eigen::Matrix4d& m)
{
    std::string out = "[";
    for (int r = 0; r < 4; ++r)
        out += fmt::format("{}[{}, {}, {}, {}]", r ? ", " : "", number(m(r, 0)), number(m(r, 1)), number(m(r, 2)),
                           number(m(r, 3)));
    return out + "]";
}

std::string quoted(const std::string& s)
{
    std::string out = "\"";
    for (char c : s) {
        if (c == '"' || c == '\\') out += '\\';
        if (static_cast<unsigned char>(c) < 0x20) out += fmt::format("\\u{:04x}", c);
        else out += c;
    }
    return out + "\"";
}

}  // namespace

std::string valueToJson(const Graph& graph, const Plug& plug, const Value& value)
{
    const double k = userScale(graph, plug);
    const AttributeSpec& spec = graph.spec(plug);
    return std::visit(
        [&](const auto& v) -> std::string {
            using T = std::decay_t<decltype(v)>;
            if constexpr (std::is_same_v<T, Eigen::Vector3d>)
                return fmt::format("[{}, {}, {}]", number(v[0] * k), number(v[1] * k), number(v[2] * k));
            else if constexpr (std::is_same_v<T, Eigen::Matrix4d>) return matrixJson(v);
            else if constexpr (std::is_same_v<T, std::vector<double>>) {
                std::string out = "[";
                for (std::size_t i = 0; i < v.size(); ++i) out += (i ? ", " : "") + number(v[i] * k);
                return out + "]";
            }
            else if constexpr (std::is_same_v<T, Matrix4Array>) {
                std::string out = "[";
                for (std::size_t i = 0; i < v.size(); ++i) out += (i ? ", " : "") + matrixJson(v[i]);
                return out + "]";
            }
            else if constexpr (std::is_same_v<T, std::string>) return quoted(v);
            else if constexpr (std::is_same_v<T, bool>) return v ? "true" : "false";
            else if constexpr (std::is_same_v<T, int>) {
                if (plug.child < 0 && spec.type == ValueType::Enum && v >= 0
                    && static_cast<std::size_t>(v) < spec.enumNames.size())
                    return quoted(spec.enumNames[static_cast<std::size_t>(v)]);
                return fmt::format("{}", v);
            }
            else return number(v * k);
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
    if (const auto* s = std::get_if<std::string>(&value)) return {quoted(*s)};
    std::vector<std::string> fields;
    for (const auto& [suffix, x] : flatten(graph, plug, value)) {
        if (!std::isfinite(x)) fields.emplace_back();
        else if (digits > 0) fields.push_back(fmt::format("{:.{}g}", x == 0.0 ? 0.0 : x, digits));
        else fields.push_back(fmt::format("{}", x));
    }
    return fields;
}

}  // namespace rig::cli
