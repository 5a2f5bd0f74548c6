#include "inversion/model/approximation_io.h"

#include <cerrno>
#include <cstring>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "inversion/model/approximation_file.h"

// Approximation files read (approximation_io.h): every field checked as an evaluation relies on it. What a file is
// (one document, its format and version) is checked first, in approximation_versions.cpp.

namespace rig {

using namespace approximation_file;

namespace {

TrainingSummary readTraining(const Reader& r, const YAML::Node& training)
{
    r.checkKeys(training, "training", {"evaluations", "orderEvaluations", "seconds", "orderer"});
    TrainingSummary t;
    t.evaluations = r.integer<std::uint64_t>(training["evaluations"], "training.evaluations");
    t.orderEvaluations = r.integer<std::uint64_t>(training["orderEvaluations"], "training.orderEvaluations");
    t.seconds = r.nonNegative(training["seconds"], "training.seconds");
    t.orderer = r.text(training["orderer"], "training.orderer");
    return t;
}

ValidationSummary readValidation(const Reader& r, const YAML::Node& validation)
{
    r.checkKeys(validation, "validation",
                {"poses", "maxPositionErrorCm", "meanPositionErrorCm", "maxRotationErrorDeg", "meanRotationErrorDeg",
                 "worstOutput", "worstPose"},
                {"maxRelativeError", "worstRelativeOutput", "worstParameter", "nonFinitePoses", "withinEpsilon",
                 "singularPoses", "singularOutput"});
    ValidationSummary v;
    v.poses = r.count<int>(validation["poses"], "validation.poses");
    v.maxPositionErrorCm = r.nonNegative(validation["maxPositionErrorCm"], "validation.maxPositionErrorCm");
    v.meanPositionErrorCm = r.nonNegative(validation["meanPositionErrorCm"], "validation.meanPositionErrorCm");
    v.maxRotationErrorDeg = r.nonNegative(validation["maxRotationErrorDeg"], "validation.maxRotationErrorDeg");
    v.meanRotationErrorDeg = r.nonNegative(validation["meanRotationErrorDeg"], "validation.meanRotationErrorDeg");
    v.worstOutput = r.text(validation["worstOutput"], "validation.worstOutput");
    v.worstPose = r.count<int>(validation["worstPose"], "validation.worstPose", -1);
    if (const YAML::Node n = validation["maxRelativeError"])
        v.maxRelativeError = r.nonNegative(n, "validation.maxRelativeError");
    if (const YAML::Node n = validation["worstRelativeOutput"])
        v.worstRelativeOutput = r.text(n, "validation.worstRelativeOutput");
    if (const YAML::Node n = validation["worstParameter"]) v.worstParameter = r.text(n, "validation.worstParameter");
    if (const YAML::Node n = validation["nonFinitePoses"])
        v.nonFinitePoses = r.count<int>(n, "validation.nonFinitePoses");
    if (const YAML::Node n = validation["withinEpsilon"]) v.withinEpsilon = r.boolean(n, "validation.withinEpsilon");
    if (const YAML::Node n = validation["singularPoses"]) v.singularPoses = r.count<int>(n, "validation.singularPoses");
    if (const YAML::Node n = validation["singularOutput"]) v.singularOutput = r.text(n, "validation.singularOutput");
    return v;
}

// The outputs with their parents (by name), into a.outputs; returns each output's index by name. Their constraint
// indices are read once the constraints are (readConstraintIndices).
std::map<std::string, int> readOutputs(const Reader& r, const YAML::Node& root, int version, Approximation& a)
{
    std::map<std::string, int> outputIndex;
    const YAML::Node outputs = r.sequence(root["outputs"], "outputs");
    for (std::size_t k = 0; k < outputs.size(); ++k) {
        const std::string field = fmt::format("outputs[{}]", k);
        r.checkKeys(outputs[k], field, {"name", "rest"},
                    {"parent", "validationError", "modelled", "helper", "constraint"});
        checkVersion3Field(r, outputs[k]["helper"], field + ".helper", version);
        checkVersion3Field(r, outputs[k]["constraint"], field + ".constraint", version);
        ApproximationOutput out;
        out.name = r.text(outputs[k]["name"], field + ".name");
        if (!outputIndex.emplace(out.name, static_cast<int>(k)).second)
            r.fail(outputs[k]["name"], field + ".name", fmt::format("the output '{}' is listed twice", out.name));
        const YAML::Node rows = r.sequence(outputs[k]["rest"], field + ".rest", 4);
        for (int row = 0; row < 4; ++row) {
            const auto v = r.reals(rows[static_cast<std::size_t>(row)], field + ".rest", 4);
            for (int c = 0; c < 4; ++c) out.rest(row, c) = v[static_cast<std::size_t>(c)];
        }
        if (const YAML::Node n = outputs[k]["validationError"])
            out.validationError = r.nonNegative(n, field + ".validationError");
        if (const YAML::Node n = outputs[k]["modelled"]) out.modelled = r.boolean(n, field + ".modelled");
        if (const YAML::Node n = outputs[k]["helper"]) out.helper = r.boolean(n, field + ".helper");
        a.outputs.push_back(std::move(out));
    }
    for (std::size_t k = 0; k < outputs.size(); ++k) {
        const YAML::Node n = outputs[k]["parent"];
        if (!n) continue;
        const std::string field = fmt::format("outputs[{}].parent", k);
        const std::string name = r.text(n, field);
        const auto it = outputIndex.find(name);
        if (it == outputIndex.end()) r.fail(n, field, fmt::format("'{}' is not one of the outputs", name));
        if (!a.outputs[k].modelled || !a.outputs[static_cast<std::size_t>(it->second)].modelled)
            r.fail(n, field, "a non-compositional output (modelled: false) is in world space: no parent, no children");
        a.outputs[k].parent = it->second;
    }
    return outputIndex;
}

// A twist share's fields (ConstraintBase); its driver's rest rotation relative to its parent's comes from their
// rest matrices.
template <class Input>
ConstraintBase readTwistShare(const Reader& r, const YAML::Node& n, const std::string& field, const Input& input,
                              const Approximation& a)
{
    ConstraintBase base;
    base.kind = ConstraintKind::twistShare;
    base.anchor = input("anchor");
    base.driver = input("driver");
    base.driverParent = input("driverParent");
    base.root = r.vector3(r.child(n, "root"), field + ".root");
    const YAML::Node axis = r.child(n, "axis");
    base.axis = r.vector3(axis, field + ".axis");
    if (!(std::abs(base.axis.norm() - 1.0) < 1e-9))
        r.fail(axis, field + ".axis", "must be a unit vector (re-run rig-learn)");
    const YAML::Node twistAxis = r.child(n, "twistAxis");
    const std::string axisName = r.text(twistAxis, field + ".twistAxis");
    if (axisName != "x" && axisName != "y" && axisName != "z")
        r.fail(twistAxis, field + ".twistAxis", fmt::format("'{}' is not an axis; it is x, y or z", axisName));
    base.twistAxis = axisName[0] - 'x';
    const auto order = [&](std::string_view key) {
        const YAML::Node v = r.child(n, key);
        const std::string path = fmt::format("{}.{}", field, key);
        const std::optional<RotateOrder> o = rotateOrderFromName(r.text(v, path));
        if (!o) r.fail(v, path, "not a rotate order; it is one of xyz, yzx, zxy, xzy, yxz, zyx");
        return *o;
    };
    base.readOrder = order("readOrder");
    base.twistOrder = order("twistOrder");
    base.share = r.real(r.child(n, "share"), field + ".share");
    const auto restRotation = [&](int k) -> Eigen::Matrix3d {
        if (k < 0) return Eigen::Matrix3d::Identity();
        return polarRotation(a.outputs[static_cast<std::size_t>(k)].rest.block<3, 3>(0, 0));
    };
    base.driverRest = restRotation(base.driverParent).transpose() * restRotation(base.driver);
    return base;
}

// A blend's inputs and rule; its weight, a parameter, is read once the parameters are (readBlendWeights).
template <class Input>
ConstraintBase readBlend(const Reader& r, const YAML::Node& n, const std::string& field, const Input& input)
{
    ConstraintBase base;
    base.kind = ConstraintKind::blend;
    base.anchor = input("anchor");
    base.ik = input("ik");
    base.fk = input("fk");
    base.ikParent = input("ikParent");
    base.fkParent = input("fkParent");
    if (base.ik == base.fk) r.fail(r.child(n, "fk"), field + ".fk", "is the IK branch too; a blend has two branches");
    const YAML::Node mode = r.child(n, "mode");
    const std::string modeName = r.text(mode, field + ".mode");
    const std::optional<BlendMode> known = blendModeFromName(modeName);
    if (!known)
        r.fail(mode, field + ".mode",
               fmt::format("unknown blend '{}'; the blends are {} and {}", modeName,
                           blendModeName(BlendMode::eulerChannels), blendModeName(BlendMode::slerp)));
    base.blend.mode = *known;
    const YAML::Node order = r.child(n, "order");
    if (base.blend.mode == BlendMode::slerp && order)
        r.fail(order, field + ".order", "a slerp has no rotate order; remove it");
    if (base.blend.mode == BlendMode::eulerChannels) {
        if (!order) r.fail(n, field, "an eulerChannels blend needs `order`, the rotate order its angles are read in");
        const std::optional<RotateOrder> o = rotateOrderFromName(r.text(order, field + ".order"));
        if (!o) r.fail(order, field + ".order", "not a rotate order; it is one of xyz, yzx, zxy, xzy, yxz, zyx");
        base.blend.order = *o;
    }
    return base;
}

// Whether some blend names this parameter as its weight (checked further by readBlendWeights).
bool blendWeight(const YAML::Node& root, const std::string& name)
{
    const YAML::Node constraints = root["constraints"];
    if (!constraints || !constraints.IsSequence()) return false;
    for (const YAML::Node& c : constraints)
        if (c.IsMap() && c["kind"] && c["kind"].IsScalar() && c["kind"].Scalar() == "blend" && c["weight"] &&
            c["weight"].IsScalar() && c["weight"].Scalar() == name)
            return true;
    return false;
}

// The blends' weights, by parameter name: a modelled parameter limited to [0, 1], as a switch is.
void readBlendWeights(const Reader& r, const YAML::Node& root, Approximation& a)
{
    for (std::size_t c = 0; c < a.constraints.size(); ++c) {
        ConstraintBase& base = a.constraints[c];
        if (base.kind != ConstraintKind::blend) continue;
        const std::string field = fmt::format("constraints[{}].weight", c);
        const YAML::Node n = root["constraints"][c]["weight"];
        const std::string name = r.text(n, field);
        const auto it = std::find_if(a.parameters.begin(), a.parameters.end(),
                                     [&](const ModelledParameter& m) { return m.parameter.name == name; });
        if (it == a.parameters.end()) r.fail(n, field, fmt::format("'{}' is not one of the parameters", name));
        const RigParameter& p = it->parameter;
        if (!p.limited || p.min < 0.0 || p.max > 1.0)
            r.fail(
                n, field,
                fmt::format("'{}' is not limited to [0, 1]; a blend's weight is a switch's (re-run rig-learn)", name));
        base.weight = static_cast<int>(it - a.parameters.begin());
    }
}

// One constraint operator; its inputs are modelled outputs, by name.
ConstraintBase readConstraint(const Reader& r, const YAML::Node& n, const std::string& field,
                              const std::map<std::string, int>& outputIndex, const Approximation& a)
{
    const YAML::Node kind = r.need(n, "kind", field);
    const std::string kindName = r.text(kind, field + ".kind");
    const std::optional<ConstraintKind> known = constraintKindFromName(kindName);
    if (!known)
        r.fail(
            kind, field + ".kind",
            fmt::format("unknown constraint '{}'; the constraints are {}, {}, {} and {}", kindName,
                        constraintKindName(ConstraintKind::planarChain), constraintKindName(ConstraintKind::twistShare),
                        constraintKindName(ConstraintKind::blend), constraintKindName(ConstraintKind::oriented)));
    if (*known == ConstraintKind::blend)
        r.checkKeys(n, field, {"kind", "ik", "fk", "weight", "mode"}, {"anchor", "ikParent", "fkParent", "order"});
    else if (*known == ConstraintKind::oriented) r.checkKeys(n, field, {"kind", "orient", "origin"}, {"anchor"});
    else if (*known == ConstraintKind::twistShare)
        r.checkKeys(n, field, {"kind", "driver", "root", "axis", "twistAxis", "readOrder", "twistOrder", "share"},
                    {"anchor", "driverParent"});
    else
        r.checkKeys(n, field, {"kind", "goal", "root", "restPole", "shape"},
                    {"anchor", "pole", "restNormal", "worldUp", "poleTurns", "minimalTurn", "goalTurns", "lineTurn",
                     "orient", "origin"});
    const auto input = [&](std::string_view which) {
        const YAML::Node v = r.child(n, which);
        if (!v) return -1;
        const std::string path = fmt::format("{}.{}", field, which);
        const std::string name = r.text(v, path);
        const auto it = outputIndex.find(name);
        if (it == outputIndex.end()) r.fail(v, path, fmt::format("'{}' is not one of the outputs", name));
        if (!a.outputs[static_cast<std::size_t>(it->second)].modelled)
            r.fail(v, path,
                   fmt::format("'{}' is not modelled (modelled: false); a constraint reads outputs the approximation "
                               "predicts: re-run rig-learn",
                               name));
        return it->second;
    };
    if (*known == ConstraintKind::twistShare) return readTwistShare(r, n, field, input, a);
    if (*known == ConstraintKind::blend) return readBlend(r, n, field, input);
    ConstraintBase base;
    if (*known == ConstraintKind::oriented) {
        base.kind = ConstraintKind::oriented;
        base.anchor = input("anchor");
        base.orient = input("orient");
        base.origin = r.vector3(r.need(n, "origin", field), field + ".origin");
        return base;
    }
    base.kind = ConstraintKind::planarChain;
    base.anchor = input("anchor");
    base.goal = input("goal");
    base.pole = input("pole");
    base.orient = input("orient");
    if (base.orient >= 0) base.origin = r.vector3(r.need(n, "origin", field), field + ".origin");
    else if (const YAML::Node origin = r.child(n, "origin"))
        r.fail(origin, field + ".origin", "an origin belongs to a chain with an orient output; remove it");
    base.root = r.vector3(r.child(n, "root"), field + ".root");
    base.restPole = r.vector3(r.child(n, "restPole"), field + ".restPole");
    if (const YAML::Node up = r.child(n, "worldUp")) {
        base.worldUp = r.boolean(up, field + ".worldUp");
        if (base.worldUp && base.pole >= 0)
            r.fail(up, field + ".worldUp", "a chain with a pole has no world up; remove one");
    }
    if (const YAML::Node turns = r.child(n, "poleTurns")) {
        base.poleTurns = r.boolean(turns, field + ".poleTurns");
        if (base.poleTurns && base.pole < 0)
            r.fail(turns, field + ".poleTurns",
                   "a pole turned by its output needs a pole output; add one or remove it");
        if (base.poleTurns) base.poleRest = a.outputs[static_cast<std::size_t>(base.pole)].rest.block<3, 3>(0, 0);
    }
    if (const YAML::Node normal = r.child(n, "restNormal")) {
        if (base.pole >= 0) r.fail(normal, field + ".restNormal", "a chain with a pole has no rest plane; remove one");
        base.restNormal = r.vector3(normal, field + ".restNormal");
        if (!(std::abs(base.restNormal.norm() - 1.0) < 1e-9))
            r.fail(normal, field + ".restNormal", "must be a unit vector (re-run rig-learn)");
        base.restPlane = true;
    }
    if (const YAML::Node minimal = r.child(n, "minimalTurn")) {
        base.minimalTurn = r.boolean(minimal, field + ".minimalTurn");
        if (base.minimalTurn && !base.restPlane)
            r.fail(minimal, field + ".minimalTurn", "a plane turned minimally is a rest plane's; add restNormal");
    }
    if (const YAML::Node turns = r.child(n, "goalTurns")) {
        base.goalTurns = r.boolean(turns, field + ".goalTurns");
        if (base.goalTurns && !base.minimalTurn)
            r.fail(turns, field + ".goalTurns", "a plane the goal turns is a minimalTurn plane's; add minimalTurn");
        if (base.goalTurns && base.goal >= 0)
            base.goalRest = a.outputs[static_cast<std::size_t>(base.goal)].rest.block<3, 3>(0, 0);
    }
    if (const YAML::Node turn = r.child(n, "lineTurn")) {
        if (!base.minimalTurn) r.fail(turn, field + ".lineTurn", "a line's turn belongs to minimalTurn; remove it");
        base.lineTurn = r.op(turn, field + ".lineTurn");
        if (base.lineTurn.kind != OperatorKind::rotation)
            r.fail(turn, field + ".lineTurn", "must be a rotation operator (re-run rig-learn)");
    } else if (base.minimalTurn) {
        r.fail(n, field, "minimalTurn needs its lineTurn (re-run rig-learn)");
    }
    const YAML::Node shape = r.child(n, "shape");
    const YAML::Node shapeKind = r.need(shape, "kind", field + ".shape");
    const std::string shapeName = r.text(shapeKind, field + ".shape.kind");
    if (shapeName != operatorKindName(OperatorKind::sampledRigid))
        r.fail(shapeKind, field + ".shape.kind",
               fmt::format("'{}' is not sampledRigid; a chain's shape is a sampledRigid operator (re-run rig-learn)",
                           shapeName));
    base.shape = r.op(shape, field + ".shape");
    if (!base.prepare(a.outputs[static_cast<std::size_t>(base.goal)].rest.block<3, 1>(0, 3)))
        r.fail(n, field,
               "the rest points span no plane (the goal's rest origin on `root`, or `restPole` on the line through "
               "them); re-run rig-learn");
    return base;
}

// The top-level `constraints` list (version 3), into a.constraints.
void readConstraints(const Reader& r, const YAML::Node& root, int version,
                     const std::map<std::string, int>& outputIndex, Approximation& a)
{
    const YAML::Node constraints = root["constraints"];
    if (!constraints) return;
    checkVersion3Field(r, constraints, "constraints", version);
    for (std::size_t c = 0; c < r.sequence(constraints, "constraints").size(); ++c)
        a.constraints.push_back(readConstraint(r, constraints[c], fmt::format("constraints[{}]", c), outputIndex, a));
}

// The outputs' `constraint` indices: in range, on a modelled output without a parent, whose constraint does not
// read the output itself.
void readConstraintIndices(const Reader& r, const YAML::Node& root, Approximation& a)
{
    const YAML::Node outputs = root["outputs"];
    for (std::size_t k = 0; k < outputs.size(); ++k) {
        const YAML::Node n = outputs[k]["constraint"];
        if (!n) continue;
        const std::string field = fmt::format("outputs[{}].constraint", k);
        const int c = r.integer<int>(n, field);
        if (c < 0 || static_cast<std::size_t>(c) >= a.constraints.size())
            r.fail(n, field,
                   a.constraints.empty()
                       ? fmt::format("{} is not a constraint index: the file has no constraints list", c)
                       : fmt::format("{} is not a constraint index (0..{})", c, a.constraints.size() - 1));
        ApproximationOutput& out = a.outputs[k];
        if (out.parent >= 0)
            r.fail(n, field,
                   "a constraint output has no parent (its constraint's inputs move it); remove `parent` or "
                   "`constraint`");
        if (!out.modelled) r.fail(n, field, "a non-compositional output (modelled: false) has no constraint");
        const ConstraintBase& base = a.constraints[static_cast<std::size_t>(c)];
        for (const int i : base.frameInputs())
            if (i == static_cast<int>(k))
                r.fail(n, field,
                       fmt::format("constraints[{}] reads '{}' itself; a constraint reads outputs learned before its "
                                   "output",
                                   c, out.name));
        out.constraint = c;
    }
}

// Approximation::outputOrder takes a cycle of frames (parents, constraints' inputs) for a bug; in a file it is
// damage, refused here with the cycle named: placing outputs once their inputs are placed leaves the cycles and
// what they feed, where following unplaced inputs comes round to one.
void checkFrameCycles(const Reader& r, const YAML::Node& root, const Approximation& a)
{
    const std::vector<std::vector<int>> dependents = a.dependents();
    std::vector<std::size_t> unplacedInputs(a.outputs.size());
    std::vector<int> ready;
    for (std::size_t k = 0; k < a.outputs.size(); ++k) {
        unplacedInputs[k] = a.frameInputs(static_cast<int>(k)).size();
        if (!unplacedInputs[k]) ready.push_back(static_cast<int>(k));
    }
    while (!ready.empty()) {
        const int u = ready.back();
        ready.pop_back();
        for (const int d : dependents[static_cast<std::size_t>(u)])
            if (--unplacedInputs[static_cast<std::size_t>(d)] == 0) ready.push_back(d);
    }
    const auto left = std::find_if(unplacedInputs.begin(), unplacedInputs.end(), [](std::size_t n) { return n > 0; });
    if (left == unplacedInputs.end()) return;
    std::vector<int> walk, position(a.outputs.size(), -1);
    int u = static_cast<int>(left - unplacedInputs.begin());
    while (position[static_cast<std::size_t>(u)] < 0) {
        position[static_cast<std::size_t>(u)] = static_cast<int>(walk.size());
        walk.push_back(u);
        const std::vector<int> inputs = a.frameInputs(u);
        u = *std::find_if(inputs.begin(), inputs.end(),
                          [&](int i) { return unplacedInputs[static_cast<std::size_t>(i)] > 0; });
    }
    const std::vector<int> cycle(walk.begin() + position[static_cast<std::size_t>(u)], walk.end());
    const auto name = [&](int k) {
        return fmt::format("'{}'", messageExcerpt(a.outputs[static_cast<std::size_t>(k)].name));
    };
    std::string reads;
    for (std::size_t j = 0; j < cycle.size() && j < 6; ++j) reads += name(cycle[j]) + " reads ";
    reads += cycle.size() > 6 ? "..." : name(cycle.front());
    const YAML::Node outputs = root["outputs"];
    for (const int k : cycle)
        if (a.outputs[static_cast<std::size_t>(k)].constraint >= 0)
            r.fail(outputs[static_cast<std::size_t>(k)]["constraint"], fmt::format("outputs[{}].constraint", k),
                   fmt::format("the frames form a cycle ({}); a constraint reads outputs learned before its output, "
                               "never one that moves with it",
                               reads));
    r.fail(outputs, "outputs", "the outputs' parents form a cycle; an output's parent is an ancestor joint");
}

// One modelled parameter; `names` holds the parameters' names read so far (a name is listed once).
ModelledParameter readParameter(const Reader& r, const YAML::Node& root, const YAML::Node& n, const std::string& field,
                                const Approximation& a, const std::map<std::string, int>& outputIndex,
                                std::set<std::string>& names)
{
    r.checkKeys(n, field,
                {"name", "default", "min", "max", "limited", "angular", "form", "fitError", "samples", "outputs",
                 "operatorOfOutput", "operators"},
                {"validationError", "noEffect", "unmodelledOutputs"});
    ModelledParameter m;
    m.parameter = r.parameter(n, field);
    if (!names.insert(m.parameter.name).second)
        r.fail(n["name"], field + ".name", fmt::format("the parameter '{}' is listed twice", m.parameter.name));
    m.form = r.text(n["form"], field + ".form");
    m.fitError = r.nonNegative(n["fitError"], field + ".fitError");
    m.samples = r.count<int>(n["samples"], field + ".samples");
    if (const YAML::Node v = n["validationError"]) m.validationError = r.nonNegative(v, field + ".validationError");
    if (const YAML::Node v = n["noEffect"])
        for (const auto& range : r.sequence(v, field + ".noEffect")) {
            const auto ends = r.reals(range, field + ".noEffect", 2);
            if (!(ends[0] <= ends[1])) r.fail(range, field + ".noEffect", "a range is [low, high]");
            m.noEffect.emplace_back(ends[0], ends[1]);
        }
    const auto outputList = [&](const YAML::Node& list, const std::string& which, bool modelled) {
        std::vector<int> indices;
        for (const auto& o : r.sequence(list, field + "." + which)) {
            const std::string name = r.text(o, field + "." + which);
            const auto it = outputIndex.find(name);
            if (it == outputIndex.end())
                r.fail(o, field + "." + which, fmt::format("'{}' is not one of the outputs", name));
            if (!indices.empty() && it->second <= indices.back())
                r.fail(o, field + "." + which,
                       "the outputs must be listed once each, in the order of the outputs list");
            if (a.outputs[static_cast<std::size_t>(it->second)].modelled != modelled)
                r.fail(o, field + "." + which,
                       fmt::format("'{}' is {}modelled (its outputs entry says modelled: {}); list it under {}", name,
                                   modelled ? "not " : "", !modelled, modelled ? "unmodelledOutputs" : "outputs"));
            indices.push_back(it->second);
        }
        return indices;
    };
    m.outputs = outputList(n["outputs"], "outputs", true);
    if (const YAML::Node v = n["unmodelledOutputs"]) m.unmodelledOutputs = outputList(v, "unmodelledOutputs", false);
    // A blend's weight moves its outputs through the blend alone (readBlendWeights).
    if (m.outputs.empty() && m.unmodelledOutputs.empty() && !blendWeight(root, m.parameter.name))
        r.fail(n["outputs"], field + ".outputs", "a parameter affects at least one output");
    const YAML::Node operators = r.sequence(n["operators"], field + ".operators");
    if (operators.size() == 0 && !m.outputs.empty())
        r.fail(operators, field + ".operators", "a modelled parameter has at least one operator");
    for (std::size_t o = 0; o < operators.size(); ++o)
        m.operators.push_back(r.op(operators[o], fmt::format("{}.operators[{}]", field, o)));
    const YAML::Node which = r.sequence(n["operatorOfOutput"], field + ".operatorOfOutput", m.outputs.size());
    for (const auto& o : which) {
        const int index = r.integer<int>(o, field + ".operatorOfOutput");
        if (index < 0 || static_cast<std::size_t>(index) >= m.operators.size())
            r.fail(o, field + ".operatorOfOutput",
                   fmt::format("{} is not an operator index (0..{})", index, m.operators.size() - 1));
        m.operatorOfOutput.push_back(index);
    }
    return m;
}

// droppedOutputs and discarded (`names`: the modelled parameters' names, which a discarded one may not repeat).
void readSetAside(const Reader& r, const YAML::Node& root, std::set<std::string>& names, Approximation& a)
{
    if (const YAML::Node droppedOutputs = root["droppedOutputs"])
        for (std::size_t d = 0; d < r.sequence(droppedOutputs, "droppedOutputs").size(); ++d) {
            const std::string field = fmt::format("droppedOutputs[{}]", d);
            r.checkKeys(droppedOutputs[d], field, {"name", "reason"});
            a.droppedOutputs.push_back({r.text(droppedOutputs[d]["name"], field + ".name"),
                                        r.text(droppedOutputs[d]["reason"], field + ".reason")});
        }
    const YAML::Node discarded = r.sequence(root["discarded"], "discarded");
    for (std::size_t d = 0; d < discarded.size(); ++d) {
        const std::string field = fmt::format("discarded[{}]", d);
        r.checkKeys(discarded[d], field, {"name", "default", "min", "max", "limited", "angular", "reason"});
        DiscardedParameter x;
        x.parameter = r.parameter(discarded[d], field);
        if (!names.insert(x.parameter.name).second)
            r.fail(discarded[d]["name"], field + ".name",
                   fmt::format("the parameter '{}' is listed twice", x.parameter.name));
        x.reason = r.text(discarded[d]["reason"], field + ".reason");
        a.discarded.push_back(std::move(x));
    }
}

// The plugs held while learning; none of them is a parameter (`names`).
void readHeld(const Reader& r, const YAML::Node& root, const std::set<std::string>& names, Approximation& a)
{
    if (const YAML::Node held = root["held"])
        for (std::size_t h = 0; h < r.sequence(held, "held").size(); ++h) {
            const std::string field = fmt::format("held[{}]", h);
            r.checkKeys(held[h], field, {"plug", "value"});
            const YAML::Node plug = held[h]["plug"];
            HeldPlug x{r.text(plug, field + ".plug"), r.real(held[h]["value"], field + ".value")};
            if (x.plug.empty()) r.fail(plug, field + ".plug", "a held plug needs a name");
            if (names.count(x.plug))
                r.fail(plug, field + ".plug",
                       fmt::format("'{}' is also a parameter; a plug is inverted or held, not both: re-run rig-learn",
                                   x.plug));
            for (const HeldPlug& before : a.held)
                if (before.plug == x.plug)
                    r.fail(plug, field + ".plug", fmt::format("the plug '{}' is held twice", x.plug));
            a.held.push_back(std::move(x));
        }
}

}  // namespace

Approximation approximationFromYaml(std::string_view text, const std::string& fileName)
{
    // Read through a const node: operator[] on a mutable one would add the keys it looks for.
    const YAML::Node root = parseOneDocument(text, fileName);
    const Reader r(fileName);
    const int version = checkFormat(r, root, fileName);

    Approximation a;
    a.rigFile = r.text(root["rigFile"], "rigFile");
    a.rigFingerprint = r.text(root["rigFingerprint"], "rigFingerprint");
    a.epsilon = r.real(root["epsilon"], "epsilon");
    if (!(a.epsilon > 0)) r.fail(root["epsilon"], "epsilon", "must be positive");

    a.training = readTraining(r, root["training"]);
    a.validation = readValidation(r, root["validation"]);
    const std::map<std::string, int> outputIndex = readOutputs(r, root, version, a);
    readConstraints(r, root, version, outputIndex, a);
    readConstraintIndices(r, root, a);
    checkFrameCycles(r, root, a);
    std::set<std::string> names;
    const YAML::Node parameters = r.sequence(root["parameters"], "parameters");
    for (std::size_t p = 0; p < parameters.size(); ++p)
        a.parameters.push_back(
            readParameter(r, root, parameters[p], fmt::format("parameters[{}]", p), a, outputIndex, names));
    readBlendWeights(r, root, a);
    readSetAside(r, root, names, a);
    readHeld(r, root, names, a);
    return a;
}

Approximation readApproximationFile(const std::filesystem::path& file)
{
    // A folder opens as a stream of nothing, and a device or a pipe never ends: refuse them by name.
    std::error_code ec;
    const auto status = std::filesystem::status(file, ec);
    if (std::filesystem::is_directory(status))
        throw Error(
            fmt::format("{}: is a folder; give the approximation file (rig-learn -o writes one)", file.string()));
    if (std::filesystem::exists(status) && !std::filesystem::is_regular_file(status))
        throw Error(
            fmt::format("{}: is not a regular file (a device or a pipe?); give the approximation "
                        "file (rig-learn -o writes one)",
                        file.string()));
    if (std::filesystem::exists(status) && std::filesystem::file_size(file, ec) > approximationMaxFileBytes)
        throw Error(
            fmt::format("{}: more than the {} MB an approximation file may have; it is not one, "
                        "or it is damaged",
                        file.string(), approximationMaxFileBytes >> 20));
    std::ifstream in(file, std::ios::binary);
    if (!in) {
        const int error = errno;
        throw Error(
            fmt::format("{}: cannot read it ({}); {}", file.string(), std::strerror(error),
                        error == ENOENT ? "check the name (rig-learn -o writes one)" : "check its permissions"));
    }
    std::ostringstream s;
    s << in.rdbuf();
    return approximationFromYaml(s.str(), file.string());
}

std::string checkFingerprint(const Approximation& approximation, const std::string& fingerprint, bool strict)
{
    if (approximation.rigFingerprint == fingerprint) return {};
    const std::string message = fmt::format(
        "the rig changed since the approximation was learned from {} (fingerprint {}, now {}); re-run "
        "rig-learn",
        approximation.rigFile, approximation.rigFingerprint, fingerprint);
    if (strict) throw Error(message);
    return message;
}

}  // namespace rig
