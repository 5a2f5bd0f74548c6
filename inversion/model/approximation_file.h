#pragma once
// Reading approximation files, internal to approximation_reader.cpp and approximation_versions.cpp: fields read from
// YAML with one-line errors at the field's file:line:col, and what a file is (one YAML document of the format, at a
// version this program reads) before any field is read.

#include <algorithm>
#include <charconv>
#include <cmath>
#include <initializer_list>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include "core/error.h"
#include "inversion/model/approximation.h"

namespace rig::approximation_file {

// Reads the fields of one file, every problem one line: "file:line:col: field: what".
class Reader {
public:
    explicit Reader(std::string fileName) : file_(std::move(fileName)) {}

    [[noreturn]] void fail(const YAML::Node& at, std::string_view field, std::string_view what) const
    {
        const YAML::Mark mark = at.Mark();
        if (mark.line < 0) throw Error(fmt::format("{}: {}: {}", file_, field, what));
        throw Error(fmt::format("{}:{}:{}: {}: {}", file_, mark.line + 1, mark.column + 1, field, what));
    }

    // A map with exactly these keys (those in `optional` may be missing).
    void checkKeys(const YAML::Node& map, std::string_view field, std::initializer_list<std::string_view> required,
                   std::initializer_list<std::string_view> optional = {}) const
    {
        if (!map.IsMap()) fail(map, field, "expected a map of fields");
        std::string known;
        for (auto k : required) known += fmt::format("{}{}", known.empty() ? "" : ", ", k);
        for (auto k : optional) known += fmt::format("{}{}", known.empty() ? "" : ", ", k);
        for (const auto& kv : map) {
            const std::string key = kv.first.IsScalar() ? kv.first.Scalar() : std::string();
            const bool ok = std::find(required.begin(), required.end(), key) != required.end() ||
                            std::find(optional.begin(), optional.end(), key) != optional.end();
            if (!ok) fail(kv.first, field, fmt::format("unknown field '{}'; the fields are {}", key, known));
        }
        // At the top of the file, a missing field is most often a file cut short or edited by hand.
        for (auto k : required)
            if (!map[std::string(k)])
                fail(map, field,
                     fmt::format("the field '{}' is missing{}", k,
                                 field == "file"
                                     ? "; the file is incomplete (cut short?) or was edited: re-run rig-learn"
                                     : ""));
    }

    YAML::Node child(const YAML::Node& map, std::string_view key) const { return map[std::string(key)]; }

    // A field that must be there (before checkKeys has looked, or where it cannot).
    YAML::Node need(const YAML::Node& map, std::string_view key, std::string_view field) const
    {
        if (!map.IsMap()) fail(map, field, "expected a map of fields");
        YAML::Node n = map[std::string(key)];
        if (!n) fail(map, field, fmt::format("the field '{}' is missing", key));
        return n;
    }

    double real(const YAML::Node& n, std::string_view field) const
    {
        if (!n.IsScalar()) fail(n, field, "expected a number");
        const std::string& text = n.Scalar();
        double x = 0.0;
        const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), x);
        if (text.empty() || ec != std::errc() || end != text.data() + text.size())
            fail(n, field, fmt::format("'{}' is not a number", text));
        if (!std::isfinite(x)) fail(n, field, fmt::format("'{}' is not a finite number", text));
        return x;
    }

    template <class Int>
    Int integer(const YAML::Node& n, std::string_view field) const
    {
        if (!n.IsScalar()) fail(n, field, "expected a whole number");
        const std::string& text = n.Scalar();
        Int x = 0;
        const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), x);
        if (ec == std::errc::result_out_of_range && end == text.data() + text.size())
            fail(n, field,
                 fmt::format("{} is out of range ({} to {})", text, std::numeric_limits<Int>::min(),
                             std::numeric_limits<Int>::max()));
        if (text.empty() || ec != std::errc() || end != text.data() + text.size())
            fail(n, field, fmt::format("'{}' is not a whole number", text));
        return x;
    }

    // A count, an error or a time: a number that cannot be below zero (from `least`).
    template <class Int>
    Int count(const YAML::Node& n, std::string_view field, Int least = 0) const
    {
        const Int x = integer<Int>(n, field);
        if (x < least) fail(n, field, fmt::format("{} is below {}; a count is not negative", x, least));
        return x;
    }
    double nonNegative(const YAML::Node& n, std::string_view field) const
    {
        const double x = real(n, field);
        if (x < 0) fail(n, field, fmt::format("{} is negative; errors and times are not", x));
        return x;
    }

    bool boolean(const YAML::Node& n, std::string_view field) const
    {
        if (!n.IsScalar() || (n.Scalar() != "true" && n.Scalar() != "false")) fail(n, field, "expected true or false");
        return n.Scalar() == "true";
    }

    std::string text(const YAML::Node& n, std::string_view field) const
    {
        if (!n.IsScalar()) fail(n, field, "expected a string");
        return n.Scalar();
    }

    // A node by value (a handle): `for (x : sequence(map["key"], ...))` must not hold a reference to the
    // temporary map["key"], which dies before the loop runs.
    YAML::Node sequence(const YAML::Node& n, std::string_view field, std::size_t size = 0) const
    {
        if (!n.IsSequence()) fail(n, field, size ? fmt::format("expected a list of {}", size) : "expected a list");
        if (size && n.size() != size) fail(n, field, fmt::format("expected {} entries, found {}", size, n.size()));
        return n;
    }

    std::vector<double> reals(const YAML::Node& n, const std::string& field, std::size_t size = 0) const
    {
        std::vector<double> out;
        for (const auto& x : sequence(n, field, size)) out.push_back(real(x, field));
        return out;
    }

    Eigen::Vector3d vector3(const YAML::Node& n, const std::string& field) const
    {
        const auto v = reals(n, field, 3);
        return {v[0], v[1], v[2]};
    }

    template <int D>
    CubicSpline<D> spline(const YAML::Node& knotsNode, const YAML::Node& valuesNode, const std::string& field) const
    {
        const std::vector<double> knots = reals(knotsNode, field + ".knots");
        sequence(valuesNode, field + ".values");
        if (knots.size() < 2) fail(knotsNode, field + ".knots", "a curve needs at least two knots");
        if (valuesNode.size() != knots.size())
            fail(valuesNode, field + ".values", fmt::format("{} values for {} knots", valuesNode.size(), knots.size()));
        checkKnots(knots, knotsNode, field + ".knots");
        std::vector<typename CubicSpline<D>::Vector> values;
        for (const auto& v : valuesNode) {
            typename CubicSpline<D>::Vector y;
            if constexpr (D == 1) y[0] = real(v, field + ".values");
            else {
                const auto entries = reals(v, field + ".values", D);
                for (int d = 0; d < D; ++d) y[d] = entries[static_cast<std::size_t>(d)];
            }
            values.push_back(y);
        }
        for (std::size_t j = 1; j < knots.size(); ++j)
            if (knots[j] == knots[j - 1] && values[j] != values[j - 1])
                fail(valuesNode, field + ".values",
                     fmt::format("the two values at the break {} differ; a curve is continuous at its breaks",
                                 knots[j]));
        return CubicSpline<D>(knots, std::move(values));
    }

    // Knots increase, but for a break (CubicSpline): one knot twice in a row, neither the first nor the last.
    void checkKnots(const std::vector<double>& knots, const YAML::Node& n, const std::string& field) const
    {
        for (std::size_t j = 1; j < knots.size(); ++j) {
            if (knots[j] > knots[j - 1]) continue;
            if (knots[j] < knots[j - 1])
                fail(n, field, fmt::format("the knots must increase ({} after {})", knots[j], knots[j - 1]));
            if (j == 1 || j + 1 == knots.size())
                fail(n, field,
                     fmt::format("the {} knot {} is repeated; a break (a knot twice) is inside the curve",
                                 j == 1 ? "first" : "last", knots[j]));
            if (knots[j - 2] == knots[j])
                fail(n, field,
                     fmt::format("the knot {} is repeated more than once; a break is a knot twice", knots[j]));
        }
    }

    RigParameter parameter(const YAML::Node& n, const std::string& field) const
    {
        RigParameter p;
        p.name = text(child(n, "name"), field + ".name");
        if (p.name.empty()) fail(child(n, "name"), field + ".name", "a parameter needs a name");
        p.defaultValue = real(child(n, "default"), field + ".default");
        p.min = real(child(n, "min"), field + ".min");
        p.max = real(child(n, "max"), field + ".max");
        p.limited = boolean(child(n, "limited"), field + ".limited");
        p.angular = boolean(child(n, "angular"), field + ".angular");
        if (!(p.min <= p.defaultValue && p.defaultValue <= p.max))
            fail(n, field, fmt::format("the default {} is not within min {} and max {}", p.defaultValue, p.min, p.max));
        return p;
    }

    Operator op(const YAML::Node& n, const std::string& field) const
    {
        const std::string kindName = text(need(n, "kind", field), field + ".kind");
        const auto kind = operatorKindFromName(kindName);
        if (!kind) {
            std::string names;
            for (const OperatorKindTraits& t : operatorKindTraits)
                names += fmt::format("{}{}", names.empty() ? "" : ", ", t.name);
            fail(need(n, "kind", field), field + ".kind",
                 fmt::format("unknown operator '{}'; the operators are {}", kindName, names));
        }
        Operator op;
        op.kind = *kind;
        if (const YAML::Node held = child(n, "held")) {
            const YAML::Node ends = sequence(held, field + ".held", 2);
            auto end = [&](const YAML::Node& e, double open) {
                return e.IsNull() || (e.IsScalar() && e.Scalar() == "null") ? open : real(e, field + ".held");
            };
            op.low = end(ends[0], -std::numeric_limits<double>::infinity());
            op.high = end(ends[1], std::numeric_limits<double>::infinity());
            if (!(op.low <= 0.0 && 0.0 <= op.high))
                fail(held, field + ".held", "expected [low, high] with low <= 0 <= high");
        }
        if (op.traits().sampled) {
            checkKeys(n, field, {"kind", "knots", "values"}, {"held"});
            if (op.kind == OperatorKind::sampledRigid)
                op.rigid = spline<6>(child(n, "knots"), child(n, "values"), field);
            else op.affine = spline<12>(child(n, "knots"), child(n, "values"), field);
            return op;
        }
        checkKeys(n, field, {"kind", "axis", "pivot"}, {"slope", "curve", "held"});
        if (!child(n, "slope") == !child(n, "curve")) fail(n, field, "give either slope (linear) or curve, not both");
        op.axis = vector3(child(n, "axis"), field + ".axis");
        // Axes are unit vectors up to rounding; anything else is a damaged file.
        if (std::abs(op.axis.norm() - 1.0) > 1e-9) fail(child(n, "axis"), field + ".axis", "not a unit vector");
        op.pivot = vector3(child(n, "pivot"), field + ".pivot");
        if (child(n, "slope")) op.slope = real(child(n, "slope"), field + ".slope");
        else {
            const YAML::Node curve = child(n, "curve");
            checkKeys(curve, field + ".curve", {"knots", "values"});
            op.curve = spline<1>(child(curve, "knots"), child(curve, "values"), field + ".curve");
        }
        return op;
    }

private:
    std::string file_;
};

// The text as its one YAML document. Throws rig::Error for a second document, a syntax error or nesting too deep.
YAML::Node parseOneDocument(std::string_view text, const std::string& fileName);

// The format and version first: any other problem in a file of another kind or version says less.
// Returns the version.
int checkFormat(const Reader& r, const YAML::Node& root, const std::string& fileName);

// A field version 3 added (helper outputs, constraint operators) means nothing to an older file's writer: such a
// file was edited, or its version was.
void checkVersion3Field(const Reader& r, const YAML::Node& n, const std::string& field, int version);

}  // namespace rig::approximation_file
