#pragma once
// The behaviour of one node instance (Maya's MPxNode) and the only window it has on the graph: its
// own input values, through a ComputeContext. Reading anything else is impossible by construction.

#include <memory>
#include <span>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "graph/attribute.h"
#include "graph/value.h"

namespace rig {

// The elements of an array attribute, by logical index.
struct ArrayData {
    std::vector<Value> elements;
    std::vector<bool> present;  // which logical indices exist
};

// Storage of one attribute of one node instance. An array's elements are apart, made with its first element:
// a crowd holds thousands of attributes per character, few of them arrays.
struct AttrData {
    Value value;                       // non-array attributes
    std::unique_ptr<ArrayData> array;  // array attributes, once they have an element

    AttrData() = default;
    AttrData(const AttrData& other) : value(other.value), array(copyOf(other.array)) {}
    AttrData& operator=(const AttrData& other)
    {
        value = other.value;
        array = copyOf(other.array);
        return *this;
    }
    AttrData(AttrData&&) noexcept = default;
    AttrData& operator=(AttrData&&) noexcept = default;
    ~AttrData() = default;

    std::size_t elementCount() const { return array ? array->elements.size() : 0; }
    bool hasElement(std::size_t i) const { return array && i < array->present.size() && array->present[i]; }
    ArrayData& elements()
    {
        if (!array) array = std::make_unique<ArrayData>();
        return *array;
    }

private:
    static std::unique_ptr<ArrayData> copyOf(const std::unique_ptr<ArrayData>& a)
    {
        return a ? std::make_unique<ArrayData>(*a) : nullptr;
    }
};

class ComputeContext {
public:
    ComputeContext(std::string_view nodeName, const std::vector<AttributeSpec>& specs, std::vector<AttrData>& data)
        : nodeName_(nodeName), specs_(specs), data_(data)
    {
    }

    std::string_view nodeName() const { return nodeName_; }

    double getDouble(AttrId a) const { return std::get<double>(input(a).value); }
    int getInt(AttrId a) const { return std::get<int>(input(a).value); }
    int getEnum(AttrId a) const { return std::get<int>(input(a).value); }
    bool getBool(AttrId a) const { return std::get<bool>(input(a).value); }
    const std::string& getString(AttrId a) const { return std::get<std::string>(input(a).value); }
    const Eigen::Vector3d& getVector3(AttrId a) const { return std::get<Eigen::Vector3d>(input(a).value); }
    const Eigen::Matrix4d& getMatrix(AttrId a) const { return std::get<Eigen::Matrix4d>(input(a).value); }
    const std::vector<double>& getDoubleArray(AttrId a) const { return std::get<std::vector<double>>(input(a).value); }
    const Matrix4Array& getMatrixArray(AttrId a) const { return std::get<Matrix4Array>(input(a).value); }

    // Array inputs: calls f(logicalIndex, value) for each existing element, in index order.
    template <class F>
    void forEachElement(AttrId a, F&& f) const
    {
        const AttrData& d = input(a);
        for (std::size_t i = 0; i < d.elementCount(); ++i)
            if (d.array->present[i]) f(static_cast<int>(i), d.array->elements[i]);
    }

    void setOutput(AttrId a, Value value);
    // Array outputs: replaces all elements (logical indices 0..n-1).
    void setOutputElements(AttrId a, std::vector<Value> elements);
    // The same, assigned in place: a node that writes as many elements every evaluation (a clip's joints)
    // reuses their storage instead of allocating a new array each frame.
    void assignOutputElements(AttrId a, std::span<const double> elements);
    void assignOutputElements(AttrId a, std::span<const Eigen::Matrix4d> elements);

private:
    const AttrData& input(AttrId a) const;
    template <class T>
    void assignElements(AttrId a, std::span<const T> elements);

    std::string_view nodeName_;
    const std::vector<AttributeSpec>& specs_;
    std::vector<AttrData>& data_;
};

class Node {
public:
    virtual ~Node() = default;
    // Reads the node's inputs and writes all of its outputs. May throw rig::Error for user errors
    // (a missing file named by an attribute, say).
    virtual void compute(ComputeContext& context) = 0;
};

}  // namespace rig
