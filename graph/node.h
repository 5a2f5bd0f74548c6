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
#include "graph/value_store.h"

namespace rig {

class ComputeContext {
public:
    // `slots`: where each of the node's attributes is in `store`.
    // The name is read only for messages: a crowd's frame computes thousands of nodes without touching it.
    ComputeContext(const std::string& nodeName, const std::vector<AttributeSpec>& specs, ValueStore& store,
                   std::span<const ValueStore::Slot> slots)
        : nodeName_(&nodeName), specs_(specs), store_(store), slots_(slots)
    {
    }

    std::string_view nodeName() const { return *nodeName_; }

    double getDouble(AttrId a) const { return input<double>(a); }
    int getInt(AttrId a) const { return input<int>(a); }
    int getEnum(AttrId a) const { return input<int>(a); }
    bool getBool(AttrId a) const { return input<bool>(a); }
    const std::string& getString(AttrId a) const { return input<std::string>(a); }
    const Eigen::Vector3d& getVector3(AttrId a) const { return input<Eigen::Vector3d>(a); }
    const Eigen::Matrix4d& getMatrix(AttrId a) const { return input<Eigen::Matrix4d>(a); }
    const std::vector<double>& getDoubleArray(AttrId a) const { return input<std::vector<double>>(a); }
    const Matrix4Array& getMatrixArray(AttrId a) const { return input<Matrix4Array>(a); }

    // An array input's elements as its attribute's type T (int for enums): has(i), [i], valueOr(i, fallback).
    template <class T>
    class Elements {
    public:
        explicit Elements(const ArrayData* data) : data_(data) {}
        // One past the highest existing index.
        std::size_t size() const { return data_ ? data_->size() : 0; }
        bool has(int i) const { return i >= 0 && data_ && data_->has(static_cast<std::size_t>(i)); }
        const T& operator[](int i) const { return data_->get<T>(static_cast<std::size_t>(i)); }
        T valueOr(int i, const T& fallback) const { return has(i) ? (*this)[i] : fallback; }

    private:
        const ArrayData* data_;
    };
    template <class T>
    Elements<T> elements(AttrId a) const
    {
        const ValueStore::Slot slot = inputSlot(a, true);
        if (!holds<T>(specs_[static_cast<std::size_t>(a)].type)) wrongType(a);
        return Elements<T>(store_.array(slot));
    }
    // Calls f(logicalIndex) for each existing element of array input `a`, in index order, whatever its type.
    template <class F>
    void forEachIndex(AttrId a, F&& f) const
    {
        const ArrayData* d = store_.array(inputSlot(a, true));
        for (std::size_t i = 0; d && i < d->size(); ++i)
            if (d->has(i)) f(static_cast<int>(i));
    }
    // Calls f(logicalIndex, value) for each existing element of array input `a`, in index order, as T.
    template <class T, class F>
    void forEachElement(AttrId a, F&& f) const
    {
        const Elements<T> e = elements<T>(a);
        for (int i = 0; static_cast<std::size_t>(i) < e.size(); ++i)
            if (e.has(i)) f(i, e[i]);
    }

    void setOutput(AttrId a, Value value);
    // Array outputs: replaces all elements (logical indices 0..n-1).
    void setOutputElements(AttrId a, std::vector<Value> elements);
    // The same, assigned in place: a node that writes as many elements every evaluation (a clip's joints)
    // reuses their storage instead of allocating a new array each frame.
    void assignOutputElements(AttrId a, std::span<const double> elements);
    void assignOutputElements(AttrId a, std::span<const Eigen::Matrix4d> elements);

private:
    // The slot of input `a`, an array or not as asked; a node reading anything else is a defect of its type.
    ValueStore::Slot inputSlot(AttrId a, bool array) const;
    template <class T>
    const T& input(AttrId a) const
    {
        const ValueStore::Slot slot = inputSlot(a, false);
        if (!holds<T>(specs_[static_cast<std::size_t>(a)].type)) wrongType(a);
        return store_.get<T>(slot);
    }
    template <class T>
    static bool holds(ValueType type)
    {
        return visitValueType(type, []<class U>(std::type_identity<U>) { return std::is_same_v<T, U>; });
    }
    [[noreturn]] void wrongType(AttrId a) const;
    template <class T>
    void assignElements(AttrId a, std::span<const T> elements);

    const std::string* nodeName_;
    const std::vector<AttributeSpec>& specs_;
    ValueStore& store_;
    std::span<const ValueStore::Slot> slots_;
};

class Node {
public:
    virtual ~Node() = default;
    // Reads the node's inputs and writes all of its outputs. May throw rig::Error for user errors
    // (a missing file named by an attribute, say).
    virtual void compute(ComputeContext& context) = 0;
};

}  // namespace rig
