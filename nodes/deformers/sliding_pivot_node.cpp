// slidingPivot: a knee-like hinge whose pivot slides as it bends (the femur's condyles roll on the
// tibia): drives the lower joint's rotate and translate from one angle.

#include "graph/node_type.h"
#include "nodes/builtin_nodes.h"

namespace rig {
namespace {

enum Attr : AttrId { Angle, Axis, Slide, SlideQuadratic, SlideAxis, RestTranslate, OutRotate, OutTranslate };

int axisOf(int index) { return index >= 0 && index < 3 ? index : 0; }

class SlidingPivotNode final : public Node {
public:
    void compute(ComputeContext& context) override
    {
        const double angle = context.getDouble(Angle);
        const double travel = context.getDouble(Slide) * angle + context.getDouble(SlideQuadratic) * angle * angle;
        Eigen::Vector3d rotate = Eigen::Vector3d::Zero();
        rotate[axisOf(context.getEnum(Axis))] = angle;
        Eigen::Vector3d translate = context.getVector3(RestTranslate);
        translate[axisOf(context.getEnum(SlideAxis))] += travel;
        context.setOutput(OutRotate, rotate);
        context.setOutput(OutTranslate, translate);
    }
};

}  // namespace

std::shared_ptr<const NodeType> makeSlidingPivotType()
{
    NodeTypeBuilder b("slidingPivot");
    b.description(
        "A hinge whose pivot slides with the angle (a knee): outRotate = angle about `axis` (xyz order, one "
        "non-zero component), outTranslate = restTranslate + travel * slideAxis with travel = slide * angle + "
        "slideQuadratic * angle^2 (angle in radians). Connect outRotate to the lower joint's rotate and "
        "outTranslate to its translate. The lower joint's orientation is an exact rotation about a fixed "
        "axis, but its origin moves along slideAxis as well, so the motion is not a rotation about any fixed "
        "pivot (slide = r is a circle of radius r rolling without slipping). No single Maya node; riggers "
        "build it with set-driven keys on translate.");
    b.input(Angle, "angle", ValueType::Double).unit(Unit::Angle).keyable().doc("The hinge angle (the knee bend).");
    b.input(Axis, "axis", ValueType::Enum)
        .enumNames({"x", "y", "z"})
        .defaultValue(2)
        .doc("The hinge axis, in the lower joint's rotate space (its local axes after jointOrient).");
    b.input(Slide, "slide", ValueType::Double)
        .unit(Unit::Distance)
        .keyable()
        .doc("Pivot travel in cm per radian of angle, along slideAxis (may be negative).");
    b.input(SlideQuadratic, "slideQuadratic", ValueType::Double)
        .unit(Unit::Distance)
        .keyable()
        .doc("The optional nonlinearity: extra travel in cm per radian squared (0 = travel linear in the angle).");
    b.input(SlideAxis, "slideAxis", ValueType::Enum)
        .enumNames({"x", "y", "z"})
        .defaultValue(1)
        .doc(
            "The direction the pivot travels along, in the lower joint's translate space (the upper bone's "
            "frame).");
    b.input(RestTranslate, "restTranslate", ValueType::Vector3)
        .unit(Unit::Distance)
        .doc("The lower joint's translate at angle 0 (constant, cm).");
    b.output(OutRotate, "outRotate", ValueType::Vector3)
        .unit(Unit::Angle)
        .doc("The lower joint's rotate (xyz order): angle on the `axis` component, 0 elsewhere.");
    b.output(OutTranslate, "outTranslate", ValueType::Vector3)
        .unit(Unit::Distance)
        .doc("The lower joint's translate: restTranslate moved by travel along slideAxis.");
    b.affects(Angle, {OutRotate, OutTranslate}).affects(Axis, {OutRotate});
    for (AttrId in : {Slide, SlideQuadratic, SlideAxis, RestTranslate}) b.affects(in, {OutTranslate});
    b.factory<SlidingPivotNode>();
    return b.build();
}

}  // namespace rig
