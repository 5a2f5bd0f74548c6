// riginv: the Python module (docs/python.md). Loads and evaluates rig graphs, learns approximations and
// inverts targets with NumPy arrays, through the same library code as graph-eval, rig-learn and
// rig-invert (tools/eval_run.h, learn_run.h, invert_run.h): the same values, reports and one-line errors.
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <yaml-cpp/yaml.h>

#include "app/common/frame_range.h"
#include "app/common/output_file.h"
#include "app/common/solve_settings.h"
#include "app/eval/eval_run.h"
#include "app/invert/invert_run.h"
#include "app/learn/learn_ranges.h"
#include "app/learn/learn_run.h"
#include "core/error.h"
#include "graph/rig_file.h"
#include "graph/yaml_loader.h"
#include "inversion/model/approximation_io.h"

namespace py = pybind11;

namespace rig::python {
namespace {

// A report as Python objects, equal to what json.load gives for the file the command line writes
// (nlohmann writes a number that is not finite as null).
py::object toPython(const app::Json& json)
{
    switch (json.type()) {
        case app::Json::value_t::null:
            return py::none();
        case app::Json::value_t::boolean:
            return py::bool_(json.get<bool>());
        case app::Json::value_t::number_integer:
            return py::int_(json.get<std::int64_t>());
        case app::Json::value_t::number_unsigned:
            return py::int_(json.get<std::uint64_t>());
        case app::Json::value_t::number_float: {
            const double x = json.get<double>();
            return std::isfinite(x) ? py::object(py::float_(x)) : py::object(py::none());
        }
        case app::Json::value_t::string:
            return py::str(json.get_ref<const std::string&>());
        case app::Json::value_t::array: {
            py::list list;
            for (const auto& item : json) list.append(toPython(item));
            return list;
        }
        case app::Json::value_t::object: {
            py::dict dict;
            for (const auto& [key, value] : json.items()) dict[py::str(key)] = toPython(value);
            return dict;
        }
        default:
            throw internalError("a report holds no binary JSON");
    }
}

std::string typeName(const py::handle& value) { return py::str(py::type::handle_of(value).attr("__name__")); }

// Arguments are taken as Python objects and converted here, so that a value of the wrong type is a one-line
// riginv.Error naming the argument, not pybind11's TypeError listing the signature over several lines.

// A path argument `what`: str or os.PathLike.
std::string pathText(const py::handle& path, std::string_view what)
{
    if (!py::isinstance<py::str>(path) && !py::hasattr(path, "__fspath__"))
        throw Error(fmt::format("{}: expected a path (str or os.PathLike), got a {}", what, typeName(path)));
    return py::str(py::module_::import("os").attr("fspath")(path));
}

std::string textArgument(const py::handle& value, std::string_view what)
{
    if (!py::isinstance<py::str>(value))
        throw Error(fmt::format("{}: expected a str, got a {}", what, typeName(value)));
    return value.cast<std::string>();
}

// A list (or tuple) of str; a str alone is refused, since it would be read as its letters.
std::vector<std::string> textList(const py::handle& value, std::string_view what)
{
    if (py::isinstance<py::str>(value))
        throw Error(fmt::format("{}: expected a list of str, got a str; put it in a list: ['{}']", what,
                                messageExcerpt(value.cast<std::string>())));
    if (!py::isinstance<py::list>(value) && !py::isinstance<py::tuple>(value))
        throw Error(fmt::format("{}: expected a list of str, got a {}", what, typeName(value)));
    std::vector<std::string> out;
    for (const auto& item : value) {
        if (!py::isinstance<py::str>(item))
            throw Error(fmt::format("{}: expected a list of str, got a {} holding a {}", what, typeName(value),
                                    typeName(item)));
        out.push_back(item.cast<std::string>());
    }
    return out;
}

// A NumPy scalar (numpy.int64(3), numpy.float32(0.5), numpy.bool_(True)) as the Python scalar it holds, so that
// it is taken wherever a Python number is; anything else as it is.
py::object plainScalar(const py::handle& value)
{
    const py::object numpy = py::module_::import("numpy");
    if (py::isinstance(value, numpy.attr("generic"))) return value.attr("item")();
    return py::reinterpret_borrow<py::object>(value);
}

// A number argument (an int, a float or a NumPy scalar of either; not a bool) as a double: an int too large
// for a double is infinite, for the caller's check of finite values to refuse. Empty when it is no number.
std::optional<double> numberOf(const py::handle& value)
{
    const py::object v = plainScalar(value);
    if (py::isinstance<py::bool_>(v)) return std::nullopt;
    if (py::isinstance<py::float_>(v)) return v.cast<double>();
    if (!py::isinstance<py::int_>(v)) return std::nullopt;
    const double x = PyLong_AsDouble(v.ptr());
    if (x == -1.0 && PyErr_Occurred()) {
        PyErr_Clear();  // OverflowError: past the largest double
        return v > py::int_(0) ? HUGE_VAL : -HUGE_VAL;
    }
    return x;
}

// True or False (a Python or NumPy bool).
bool flagArgument(const py::handle& value, std::string_view what)
{
    const py::object v = plainScalar(value);
    if (!py::isinstance<py::bool_>(v))
        throw Error(fmt::format("{}: expected True or False, got a {}", what, typeName(value)));
    return v.cast<bool>();
}

// None or a dict.
std::optional<py::dict> dictArgument(const py::handle& value, std::string_view what)
{
    if (value.is_none()) return std::nullopt;
    if (!py::isinstance<py::dict>(value))
        throw Error(fmt::format("{}: expected None or a dict {{plug: value}}, got a {}", what, typeName(value)));
    return py::reinterpret_borrow<py::dict>(value);
}

// None or a callable, called with the GIL held.
void checkProgress(const py::handle& progress)
{
    if (!progress.is_none() && !PyCallable_Check(progress.ptr()))
        throw Error(fmt::format("progress: expected None or a callable, got a {}", typeName(progress)));
}

// A number argument named `what`, refused with riginv.Error when it is something else.
double numberArgument(const py::handle& value, std::string_view what)
{
    if (const auto x = numberOf(value)) return *x;
    throw Error(fmt::format("{}: expected a number, got a {}", what, typeName(value)));
}

// A whole-number argument named `what` (an int or a NumPy integer), refused when it is something else or
// past what an int holds.
int intArgument(const py::handle& value, std::string_view what)
{
    const py::object v = plainScalar(value);
    if (py::isinstance<py::bool_>(v) || !py::isinstance<py::int_>(v))
        throw Error(fmt::format("{}: expected a whole number, got a {}", what, typeName(value)));
    int overflow = 0;
    const long long x = PyLong_AsLongLongAndOverflow(v.ptr(), &overflow);
    if (overflow != 0 || x < std::numeric_limits<int>::min() || x > std::numeric_limits<int>::max())
        throw Error(fmt::format("{}: {} is out of range; give a whole number from {} to {}", what,
                                messageExcerpt(std::string(py::str(v))), std::numeric_limits<int>::min(),
                                std::numeric_limits<int>::max()));
    return static_cast<int>(x);
}

// The solve settings' keyword arguments (app/common/solve_settings.h), one per row of the table: converted as their
// kind is, then checked by the table, so that a bad value is the table's one line naming the keyword.
using SettingArguments = std::array<py::object, app::solveSettingCount>;
app::SolveSettings settingsArgument(const SettingArguments& values)
{
    app::SolveSettings out = app::concurrentSolveDefaults();
    const auto& table = app::solveSettings();
    for (std::size_t i = 0; i < table.size(); ++i) {
        const app::SolveSetting& s = table[i];
        const std::string key = app::settingName(s, app::Spelling::key);
        if (s.kind == app::SettingKind::count) s.set(out, intArgument(values[i], key));
        else if (s.kind == app::SettingKind::flag) s.set(out, flagArgument(values[i], key));
        else s.set(out, app::parseSetting(s, textArgument(values[i], key), app::Spelling::key));
    }
    app::checkSettings(out, app::Spelling::key);
    return out;
}

// A setting's default keyword value: what the table's default is in Python (an int, a bool, a word).
py::object settingDefault(const app::SolveSetting& s)
{
    const int value = s.get(app::concurrentSolveDefaults());
    if (s.kind == app::SettingKind::count) return py::int_(value);
    if (s.kind == app::SettingKind::flag) return py::bool_(value != 0);
    return py::str(app::settingText(s, value));
}

// ---------------------------------------------------------------------------------------------------------
// Graph

// A value of `graph-eval --set`, written as in a rig file: NumPy arrays and scalars as their Python values.
YAML::Node yamlValue(py::handle value, const std::string& name)
{
    py::object v = py::reinterpret_borrow<py::object>(value);
    if (!py::isinstance<py::str>(v) && py::hasattr(v, "tolist")) v = v.attr("tolist")();
    if (py::isinstance<py::bool_>(v)) return YAML::Node(v.cast<bool>() ? "true" : "false");
    if (py::isinstance<py::int_>(v)) return YAML::Node(std::string(py::str(v)));
    if (py::isinstance<py::float_>(v)) {
        const double x = v.cast<double>();
        if (std::isnan(x)) return YAML::Node(".nan");
        if (std::isinf(x)) return YAML::Node(x > 0 ? ".inf" : "-.inf");
        return YAML::Node(fmt::format("{}", x));  // the shortest text that reads back the same bits
    }
    if (py::isinstance<py::str>(v)) return YAML::Node(v.cast<std::string>());
    if (py::isinstance<py::sequence>(v)) {
        YAML::Node list(YAML::NodeType::Sequence);
        for (const auto& item : v) list.push_back(yamlValue(item, name));
        return list;
    }
    throw Error(fmt::format("--set {}: a {} is not a value; numbers, true/false, names, [x, y, z]", name, typeName(v)));
}

// One plug's values over the frames as NumPy arrays, in user units as graph-eval prints them: (F,) for
// numbers (int64 for whole numbers and enums, bool), (F, 3) for vectors, (F, 4, 4) for matrices, (F, N) and
// (F, N, 4, 4) for arrays whose length does not change (a list of arrays otherwise), a list for strings.
py::object plugArray(const Graph& graph, const Plug& plug, const std::vector<Value>& values)
{
    const double k = app::userScale(graph, plug);
    const auto frames = static_cast<py::ssize_t>(values.size());
    const Value& first = values.front();
    const auto sameLength = [&]<class T>(const T&) {
        for (const Value& v : values)
            if (std::get<T>(v).size() != std::get<T>(first).size()) return false;
        return true;
    };
    if (std::holds_alternative<double>(first)) {
        py::array_t<double> out(frames);
        for (py::ssize_t f = 0; f < frames; ++f) out.mutable_at(f) = std::get<double>(values[f]) * k;
        return out;
    }
    if (std::holds_alternative<int>(first)) {
        py::array_t<std::int64_t> out(frames);
        for (py::ssize_t f = 0; f < frames; ++f) out.mutable_at(f) = std::get<int>(values[f]);
        return out;
    }
    if (std::holds_alternative<bool>(first)) {
        py::array_t<bool> out(frames);
        for (py::ssize_t f = 0; f < frames; ++f) out.mutable_at(f) = std::get<bool>(values[f]);
        return out;
    }
    if (std::holds_alternative<std::string>(first)) {
        py::list out;
        for (const Value& v : values) out.append(std::get<std::string>(v));
        return out;
    }
    if (std::holds_alternative<Eigen::Vector3d>(first)) {
        py::array_t<double> out({frames, py::ssize_t{3}});
        for (py::ssize_t f = 0; f < frames; ++f)
            for (py::ssize_t i = 0; i < 3; ++i) out.mutable_at(f, i) = std::get<Eigen::Vector3d>(values[f])[i] * k;
        return out;
    }
    if (std::holds_alternative<Eigen::Matrix4d>(first)) {
        py::array_t<double> out({frames, py::ssize_t{4}, py::ssize_t{4}});
        for (py::ssize_t f = 0; f < frames; ++f)
            for (py::ssize_t r = 0; r < 4; ++r)
                for (py::ssize_t c = 0; c < 4; ++c)
                    out.mutable_at(f, r, c) = std::get<Eigen::Matrix4d>(values[f])(r, c);
        return out;
    }
    const auto doubles = [&](const std::vector<double>& xs) {
        py::array_t<double> out(static_cast<py::ssize_t>(xs.size()));
        for (std::size_t i = 0; i < xs.size(); ++i) out.mutable_at(static_cast<py::ssize_t>(i)) = xs[i] * k;
        return out;
    };
    const auto matrices = [](const Matrix4Array& ms) {
        py::array_t<double> out({static_cast<py::ssize_t>(ms.size()), py::ssize_t{4}, py::ssize_t{4}});
        for (std::size_t i = 0; i < ms.size(); ++i)
            for (py::ssize_t r = 0; r < 4; ++r)
                for (py::ssize_t c = 0; c < 4; ++c) out.mutable_at(static_cast<py::ssize_t>(i), r, c) = ms[i](r, c);
        return out;
    };
    const bool doubleArray = std::holds_alternative<std::vector<double>>(first);
    py::list perFrame;
    for (const Value& v : values)
        perFrame.append(doubleArray ? doubles(std::get<std::vector<double>>(v)) : matrices(std::get<Matrix4Array>(v)));
    const bool stack = doubleArray ? sameLength(std::vector<double>{}) : sameLength(Matrix4Array{});
    return stack ? py::module_::import("numpy").attr("stack")(perFrame) : py::object(std::move(perFrame));
}

class PyGraph {
public:
    static PyGraph load(const py::object& path, const py::object& plugins)
    {
        PyGraph g;
        g.file_ = pathText(path, "path");
        g.registry_ = app::nodeRegistry(textList(plugins, "plugins"));
        g.graph_ = loadRigFile(g.file_, g.registry_);
        return g;
    }

    py::dict evaluate(const py::object& get, const py::object& setArgument, const py::object& frames,
                      const py::object& threadsArgument)
    {
        Graph& graph = *graph_;
        // Taken as an object: pybind11's int would refuse 1.5 with its TypeError listing the signature.
        const int threads = intArgument(threadsArgument, "threads");
        if (threads < 0 || threads > 1024)
            throw Error(
                fmt::format("threads: {} is not a thread count; give a whole number from 0 (all cores) to 1024, as "
                            "graph-eval --threads",
                            threads));
        graph.setThreads(threads);
        const auto set = dictArgument(setArgument, "set");
        if (set)
            for (const auto& [key, value] : *set) {
                const std::string name = py::str(key);
                const Plug plug = app::settablePlug(graph, name);
                app::setPlug(graph, plug, name, yamlValue(value, name));
            }
        std::vector<double> numbers{graph.time()};
        const bool setTime = !frames.is_none();
        if (py::isinstance<py::str>(frames))
            numbers = app::parseFrameRange(frames.cast<std::string>(), "--frames").frames();
        else if (setTime) numbers = frameNumbers(frames);
        std::vector<std::string> patterns;
        if (py::isinstance<py::str>(get)) patterns.push_back(get.cast<std::string>());
        else if (!get.is_none()) {
            try {
                patterns = get.cast<std::vector<std::string>>();
            }
            catch (const py::cast_error&) {
                throw Error(
                    fmt::format("get: expected None, a plug name or glob, or a list of them; got a {}", typeName(get)));
            }
        }
        const auto plugs =
            app::selectPlugs(graph, file_, patterns, setTime ? std::optional(numbers.front()) : std::nullopt);
        std::vector<std::vector<Value>> columns(plugs.size());
        for (const double frame : numbers) {
            // Ctrl-C stops a long evaluation between frames (Python runs its handler only once this returns).
            if (PyErr_CheckSignals() != 0) throw py::error_already_set();
            auto values = app::evaluateFrame(graph, file_, frame, setTime, plugs);
            // graph-eval's limit, measured as graph-eval measures it: its JSON for as many frames as the first.
            if (columns.empty() || columns.front().empty())
                app::checkOutputSize(app::jsonOutputEstimate(graph, plugs, frame, values, numbers.size()),
                                     numbers.size(), plugs.size());
            for (std::size_t i = 0; i < plugs.size(); ++i) columns[i].push_back(std::move(values[i]));
        }
        py::dict out;
        for (std::size_t i = 0; i < plugs.size(); ++i)
            out[py::str(graph.plugName(plugs[i]))] = plugArray(graph, plugs[i], columns[i]);
        return out;
    }

    // A list (or array) of frame numbers: Python or NumPy numbers, finite.
    static std::vector<double> frameNumbers(const py::object& frames)
    {
        const auto wrongType = [&](const std::string& got) {
            return Error(fmt::format("frames: expected None, 'A:B[:STEP]' or a list of frame numbers; got {}", got));
        };
        std::vector<py::object> items;
        try {
            items = frames.cast<std::vector<py::object>>();
        }
        catch (const py::cast_error&) {
            throw wrongType("a " + typeName(frames));
        }
        if (items.empty()) throw Error("frames: an empty list; give frame numbers, or 'A:B[:STEP]'");
        std::vector<double> numbers;
        for (const py::object& item : items) {
            const auto frame = numberOf(item);
            if (!frame) throw wrongType(fmt::format("a {} holding a {}", typeName(frames), typeName(item)));
            if (!std::isfinite(*frame))
                throw Error(
                    fmt::format("frames: {} is not a frame number", messageExcerpt(std::string(py::str(item)))));
            numbers.push_back(*frame);
        }
        return numbers;
    }

    std::vector<std::string> plugs(const py::object& glob)
    {
        std::vector<std::string> names;
        for (const Plug& p : app::selectPlugs(*graph_, file_, {textArgument(glob, "glob")}, std::nullopt))
            names.push_back(graph_->plugName(p));
        return names;
    }

    std::vector<std::string> nodeTypes() const { return registry_->typeNames(); }
    const std::string& file() const { return file_; }
    double time() const { return graph_->time(); }

private:
    std::string file_;
    std::shared_ptr<NodeRegistry> registry_;
    std::shared_ptr<Graph> graph_;
};

// ---------------------------------------------------------------------------------------------------------
// Approximation

// The library's progress callback while it works without the GIL: takes the GIL to let Ctrl-C stop the work
// (a Python exception thrown through the library) and to call `progress`, at every call when there is one,
// otherwise at most every 0.1 s: taking the GIL while another Python thread runs waits for that thread's
// switch interval, which every frame would add up to more than the solve.
class ProgressToPython {
public:
    explicit ProgressToPython(const py::object& progress) : progress_(progress) {}

    template <class Done, class Total>
    void operator()(Done done, Total total)
    {
        const auto now = std::chrono::steady_clock::now();
        if (progress_.is_none() && now - lastCheck_ < std::chrono::milliseconds(100)) return;
        lastCheck_ = now;
        py::gil_scoped_acquire acquire;
        if (PyErr_CheckSignals() != 0) throw py::error_already_set();
        if (!progress_.is_none()) progress_(done, total);
    }

private:
    const py::object& progress_;
    std::chrono::steady_clock::time_point lastCheck_ = std::chrono::steady_clock::now();
};

// learn(ranges=): {parameter glob: [min, max]}, as a spec's ranges: reads them.
std::vector<GraphRigOptions::LearnRange> learnRanges(const py::object& rangesArgument)
{
    std::vector<GraphRigOptions::LearnRange> out;
    if (const auto ranges = dictArgument(rangesArgument, "ranges"))
        for (const auto& [key, value] : *ranges) {
            const std::string glob = py::isinstance<py::str>(key) ? std::string(py::str(key)) : std::string();
            std::optional<double> low, high;
            if (py::isinstance<py::sequence>(value) && !py::isinstance<py::str>(value) && py::len(value) == 2) {
                low = numberOf(value[py::int_(0)]);
                high = numberOf(value[py::int_(1)]);
            }
            if (glob.empty() || !low || !high || !std::isfinite(*low) || !std::isfinite(*high) || !(*low < *high))
                throw Error(
                    fmt::format("ranges: give {{parameter glob: [min, max]}} with finite min < max in the "
                                "rig file's units (a spec's ranges:), got a {} for '{}'",
                                typeName(value), messageExcerpt(glob)));
            out.push_back({glob, *low, *high});
        }
    return out;
}

// learn(ranges_from=, ranges_map=, ranges_take=, ranges_frames=): rig-learn --ranges-from's clip, --map, --take and
// --frames; none without ranges_from.
std::optional<app::RangesFrom> rangesFromArguments(const py::object& clip, const py::object& map,
                                                   const py::object& take, const py::object& frames)
{
    if (clip.is_none()) {
        if (!map.is_none() || !take.is_none() || !frames.is_none())
            throw Error("ranges_map, ranges_take and ranges_frames: give ranges_from, the clip they are about");
        return std::nullopt;
    }
    app::RangesFrom from{pathText(clip, "ranges_from"), map.is_none() ? "" : pathText(map, "ranges_map"),
                         take.is_none() ? "" : textArgument(take, "ranges_take"), std::nullopt};
    if (!frames.is_none()) from.frames = textArgument(frames, "ranges_frames");
    return from;
}

class PyApproximation {
public:
    static PyApproximation load(const py::object& path)
    {
        PyApproximation a;
        a.file_ = pathText(path, "path");
        a.approximation_ = std::make_shared<const Approximation>(readApproximationFile(*a.file_));
        return a;
    }

    static PyApproximation learn(const py::object& rig, const py::object& params, const py::object& outputs,
                                 const py::object& epsilon, const py::object& orderer, const py::object& progress,
                                 const py::object& plugins, const py::object& worldSpace, const py::object& setArgument,
                                 const py::object& rangesArgument, const py::object& rangesFrom,
                                 const py::object& rangesMap, const py::object& rangesTake,
                                 const py::object& rangesFrames)
    {
        app::LearnJob job{pathText(rig, "rig_path"),
                          textList(params, "params"),
                          textList(outputs, "outputs"),
                          textList(plugins, "plugins"),
                          {},
                          {}};
        if (job.params.empty()) throw Error("params: give one or more parameter plug globs (rig-learn --params)");
        checkProgress(progress);
        const auto set = dictArgument(setArgument, "set");
        if (set)
            for (const auto& [key, value] : *set) {
                if (!py::isinstance<py::str>(key))
                    throw Error(fmt::format("set: a key is a {}, not a plug name (str)", typeName(key)));
                const std::string plug = py::str(key);
                const auto x = numberOf(value);
                if (!x)
                    throw Error(fmt::format("set['{}']: expected a number (the rig file's units), got a {}", plug,
                                            typeName(value)));
                if (!std::isfinite(*x))
                    throw Error(
                        fmt::format("set['{}']: {} is not a finite number; give a finite number in the rig "
                                    "file's units (degrees for angles)",
                                    plug, messageExcerpt(std::string(py::str(value)))));
                job.held.push_back({plug, *x});
            }
        job.ranges = learnRanges(rangesArgument);
        const std::optional<app::RangesFrom> from =
            rangesFromArguments(rangesFrom, rangesMap, rangesTake, rangesFrames);
        job.rigLoaded = [&](const GraphRigFunction& loaded) { app::checkLearnRanges(loaded, job.ranges, "ranges"); };
        job.options.epsilon = app::parseEpsilon(fmt::format("{}", numberArgument(epsilon, "epsilon")));
        job.options.orderer = app::ordererFromName(textArgument(orderer, "orderer"));
        job.options.relativeFrames = !flagArgument(worldSpace, "world_space");
        ProgressToPython onProgress(progress);
        job.options.progress = [&](std::string_view stage, double fraction) {
            onProgress(app::learningFraction(stage, fraction), 1.0);
        };
        std::shared_ptr<app::LearnOutcome> outcome;
        {
            py::gil_scoped_release release;
            outcome = std::make_shared<app::LearnOutcome>(from ? app::learnCoveringClip(job, *from) : app::learn(job));
        }
        PyApproximation a;
        a.rig_ = job.rig;
        a.learned_ = outcome;
        a.approximation_ = std::shared_ptr<const Approximation>(outcome, &outcome->approximation);
        if (a.approximation_->parameters.empty() &&
            PyErr_WarnEx(PyExc_RuntimeWarning,
                         "no parameter could be modelled; the approximation is empty (see report['discarded'])",
                         1) != 0)
            throw py::error_already_set();
        return a;
    }

    void save(const py::object& path, const py::object& allowInexactArgument)
    {
        const std::string file = pathText(path, "path");
        const bool allowInexact = flagArgument(allowInexactArgument, "allow_inexact");
        if (const std::string failure = app::validationFailure(*approximation_); !failure.empty() && !allowInexact)
            throw Error(
                fmt::format("{}; {} not written (save(path, allow_inexact=True) writes it anyway)", failure, file));
        app::checkOutputFile(file, "approximation.yaml", "save()");
        app::checkDistinctFiles({{"the rig file", approximation_->rigFile}}, {{"save()", file}});
        app::writeFileAtomically(file, approximationToYaml(*approximation_));
        file_ = file;
    }

    py::object report() const
    {
        if (!learned_) return py::none();
        return toPython(app::learnReport(*learned_, rig_, file_, file_.has_value()));
    }

    py::tuple invert(const py::object& targets, const py::object& rig, const py::object& map,
                     const py::object& progress, const py::object& plugins, const py::object& frames,
                     const py::object& take, const py::object& contacts, const SettingArguments& settings) const
    {
        app::InvertJob job;
        job.loadedApproximation = approximation_;
        job.approximation = name();
        job.rig = pathText(rig, "rig");
        job.plugins = textList(plugins, "plugins");
        if (py::isinstance<py::dict>(targets)) job.targets = targetClip(targets.cast<py::dict>());
        else if (py::isinstance<py::str>(targets) || py::hasattr(targets, "__fspath__"))
            job.clip = pathText(targets, "targets");
        else
            throw Error(
                fmt::format("targets: expected a dict from joint name to an (F, 4, 4) float64 array, "
                            "or a clip path (BVH, FBX, glTF, Collada, ..., .json); got a {}",
                            typeName(targets)));
        if (!map.is_none()) job.map = pathText(map, "map");
        if (!frames.is_none()) job.frames = textArgument(frames, "frames");
        // '' would mean None (the first take, no contacts): refused, as rig-invert refuses --take ''.
        if (!take.is_none() && (job.take = textArgument(take, "take")).empty())
            throw Error("take: the value is empty; give a take's name or 0-based index, or None for the first");
        if (!contacts.is_none() && (job.contacts = pathText(contacts, "contacts")).empty())
            throw Error("contacts: the value is empty; give 'auto' or a contacts file, or None");
        job.contactsName = "contacts";
        checkProgress(progress);
        job.settings = settingsArgument(settings);
        ProgressToPython onProgress(progress);
        job.progress = [&](int done, int total) { onProgress(done, total); };
        job.warning = [](const std::string& warning) {
            py::gil_scoped_acquire acquire;
            if (PyErr_WarnEx(PyExc_RuntimeWarning, warning.c_str(), 1) != 0) throw py::error_already_set();
        };
        std::optional<app::InvertOutcome> outcome;
        std::string curves;
        {
            py::gil_scoped_release release;
            outcome.emplace(app::invert(job));
            curves = app::curvesJson(*outcome);
        }
        const auto values = app::curveValues(*outcome);
        const auto& parameters = approximation_->parameters;
        py::array_t<double> array(
            {static_cast<py::ssize_t>(values.size()), static_cast<py::ssize_t>(parameters.size())});
        for (std::size_t f = 0; f < values.size(); ++f)
            for (std::size_t i = 0; i < parameters.size(); ++i)
                array.mutable_at(static_cast<py::ssize_t>(f), static_cast<py::ssize_t>(i)) = values[f][i];
        py::list names;
        for (const auto& p : parameters) names.append(p.parameter.name);
        const auto clip = job.targets ? std::nullopt : std::optional(job.clip);
        const auto report =
            app::invertReport(*outcome, file_, job.rig, clip, std::nullopt, app::fingerprintText(curves));
        return py::make_tuple(array, names, toPython(report));
    }

    std::vector<std::string> parameters() const
    {
        std::vector<std::string> names;
        for (const auto& p : approximation_->parameters) names.push_back(p.parameter.name);
        return names;
    }
    std::vector<std::string> outputs() const
    {
        std::vector<std::string> names;
        for (const auto& o : approximation_->outputs) names.push_back(o.name);
        return names;
    }
    const std::string& rigFile() const { return approximation_->rigFile; }
    py::dict held() const
    {
        py::dict out;
        for (const HeldPlug& h : approximation_->held) out[py::str(h.plug)] = h.value;
        return out;
    }
    const std::optional<std::string>& file() const { return file_; }

    // What names the approximation in messages: its file, or the rig it was learned from.
    std::string name() const
    {
        return file_ ? *file_ : fmt::format("the approximation learned from {}", approximation_->rigFile);
    }

private:
    // The targets of a dict: joint name -> (F, 4, 4) float64 array, every joint with the same F. Frames are
    // numbered 0 to F - 1, the rows of the arrays.
    static TargetClip targetClip(const py::dict& targets)
    {
        if (targets.empty()) throw Error("targets: an empty dict; give joint names with (F, 4, 4) float64 arrays");
        TargetClip clip;
        clip.file = "targets";
        std::vector<py::array_t<double>> arrays;
        py::ssize_t frames = -1;
        std::string firstJoint;
        for (const auto& [key, value] : targets) {
            if (!py::isinstance<py::str>(key))
                throw Error(fmt::format("targets: a key is a {}, not a joint name (str)", typeName(key)));
            const std::string joint = py::str(key);
            if (!py::isinstance<py::array>(value))
                throw Error(
                    fmt::format("targets['{}']: expected a NumPy array of shape (F, 4, 4) and dtype float64, "
                                "got a {}",
                                joint, typeName(value)));
            const auto array = py::reinterpret_borrow<py::array>(value);
            std::vector<std::string> shape;
            for (py::ssize_t d = 0; d < array.ndim(); ++d) shape.push_back(fmt::format("{}", array.shape(d)));
            const std::string got = fmt::format("({}{})", fmt::join(shape, ", "), shape.size() == 1 ? "," : "");
            if (array.ndim() != 3 || array.shape(1) != 4 || array.shape(2) != 4)
                throw Error(
                    fmt::format("targets['{}']: expected an array of shape (F, 4, 4), got shape {}", joint, got));
            if (!array.dtype().is(py::dtype::of<double>()))
                throw Error(
                    fmt::format("targets['{}']: expected dtype float64, got {} (shape {}); convert it with "
                                ".astype(numpy.float64)",
                                joint, std::string(py::str(array.dtype())), got));
            if (array.shape(0) == 0)
                throw Error(fmt::format("targets['{}']: no frames (shape {}); give at least one", joint, got));
            if (frames >= 0 && array.shape(0) != frames)
                throw Error(
                    fmt::format("targets['{}']: {} frames where targets['{}'] has {}; every joint needs the "
                                "same frames",
                                joint, array.shape(0), firstJoint, frames));
            if (frames < 0) {
                frames = array.shape(0);
                firstJoint = joint;
            }
            clip.joints.push_back(joint);
            arrays.push_back(py::reinterpret_borrow<py::array_t<double>>(value));
        }
        for (py::ssize_t f = 0; f < frames; ++f) {
            clip.frameNumbers.push_back(static_cast<double>(f));
            auto& worlds = clip.worlds.emplace_back();
            for (const auto& array : arrays) {
                const auto a = array.unchecked<3>();
                Eigen::Matrix4d m;
                for (py::ssize_t r = 0; r < 4; ++r)
                    for (py::ssize_t c = 0; c < 4; ++c) m(r, c) = a(f, r, c);
                worlds.push_back(m);
            }
        }
        return clip;
    }

    std::shared_ptr<const Approximation> approximation_;
    std::optional<std::string> file_;             // loaded from or saved to
    std::shared_ptr<app::LearnOutcome> learned_;  // what learning measured, for the report (none once loaded)
    std::string rig_;                             // the rig file as given to learn
};

template <std::size_t>
using Object = py::object;

// Approximation.invert, with a keyword argument per row of the solve settings' table, its default the table's.
template <std::size_t... I>
void defInvert(py::class_<PyApproximation>& approximation, std::index_sequence<I...>)
{
    const auto& table = app::solveSettings();
    std::vector<std::string> keys{app::settingName(table[I], app::Spelling::key)...};
    // pybind11 copies the names and the text.
    const std::string doc = fmt::format(
        "Inverts targets to the rig's parameters, as rig-invert, and returns (values, names, report).\n\n"
        "targets: a dict {{joint: (F, 4, 4) float64 array of world matrices, cm}}, frames numbered 0 to F - 1, or a "
        "clip path: BVH, an animation assimp reads (FBX, glTF, Collada, X, ...; docs/clips.md), or .json as graph-eval "
        "writes world matrices, read by content; take: the clip file's animation, a name or 0-based index (None: the "
        "first).\n"
        "rig: the rig file the approximation was learned from; map: a map file (scale, joint renames, ignored "
        "joints, weights, and retarget: for a clip path; docs/retargeting.md).\n"
        "progress: called as progress(frames done, frames total), with the GIL held.\n"
        "plugins, frames: as rig-invert's --plugin and --frames ('A:B' in the clip's numbering).\n"
        "contacts: as rig-invert's --contacts: 'auto' (the feet's contacts detected from the clip) or a file of "
        "frame ranges per joint, held above the other targets (docs/retargeting.md); None: none.\n"
        "{}: the solve settings, as rig-invert's flags of those names ('-' for '_'; a flag's keyword is True or "
        "False); threads counts the solver's threads (0: all cores; the values do not depend on it).\n"
        "values: an (F, P) float64 array in the curves' units (degrees, cm); names: its P parameter names; report: "
        "the dict rig-invert --report-json writes (curves.file is None: nothing is written). The GIL is released "
        "while solving; Ctrl-C stops it (between frames, seen every 0.1 s).",
        fmt::join(keys, ", "));
    approximation.def(
        "invert",
        [](const PyApproximation& self, const py::object& targets, const py::object& rig, const py::object& map,
           const py::object& progress, const py::object& plugins, const py::object& frames, const py::object& take,
           const py::object& contacts, const Object<I>&... settings) {
            return self.invert(targets, rig, map, progress, plugins, frames, take, contacts,
                               SettingArguments{settings...});
        },
        py::arg("targets"), py::arg("rig"), py::arg("map") = py::none(), py::arg("progress") = py::none(),
        py::kw_only(), py::arg("plugins") = py::list(), py::arg("frames") = py::none(), py::arg("take") = py::none(),
        py::arg("contacts") = py::none(), (py::arg(keys[I].c_str()) = settingDefault(table[I]))..., doc.c_str());
}

}  // namespace
}  // namespace rig::python

PYBIND11_MODULE(riginv, m)
{
    using namespace rig::python;
    m.doc() =
        "Rig inversion from Python (docs/python.md): load and evaluate rig graphs, learn a rig's approximation "
        "and invert joint targets to rig parameter curves, with NumPy arrays. The same library code as the "
        "command lines graph-eval, rig-learn and rig-invert: the same numbers, reports and error messages.";

    static py::exception<rig::Error> error(m, "Error");
    error.doc() =
        "A user-facing error: the one-line message the command lines print after 'error: ' (a bad file, "
        "glob, value or option).";
    py::register_exception_translator([](std::exception_ptr p) {
        try {
            if (p) std::rethrow_exception(p);
        }
        catch (const rig::Error& e) {
            // A broken invariant is a bug, not the caller's input: Python's RuntimeError, as the command lines'
            // "internal error".
            if (e.kind() == rig::ErrorKind::internal)
                PyErr_SetString(PyExc_RuntimeError, ("internal error: " + rig::oneLine(e.what())).c_str());
            else error(rig::oneLine(e.what()).c_str());
        }
    });

    py::class_<PyGraph>(m, "Graph", "A rig graph (a YAML rig file) loaded into its own stateful instance.")
        .def_static("load", &PyGraph::load, py::arg("path"), py::arg("plugins") = py::list(),
                    "Loads a rig file (docs/rig-format.md) after the built-in node types and the plugins named "
                    "(as graph-eval --plugin). Raises riginv.Error with graph-eval's message for a bad file.")
        .def("evaluate", &PyGraph::evaluate, py::arg("get") = py::none(), py::arg("set") = py::none(),
             py::arg("frames") = py::none(), py::kw_only(), py::arg("threads") = 1,
             "Sets plugs, evaluates and returns {plug name: NumPy array}, as graph-eval --set/--get/--frames/"
             "--threads.\n\n"
             "get: plug names or globs ('*.worldMatrix'); None: every output plug.\n"
             "set: {plug: value}, values as in a rig file (degrees for angles, cm; [x, y, z]; a 4x4 matrix as "
             "rows; enum names); they stay set on the graph.\n"
             "frames: None (the current time, one frame), 'A:B[:STEP]', or a list of frame numbers; the scene "
             "time is set to each.\n"
             "threads: evaluation threads, as graph-eval --threads (1 serial, N parallel, 0 every core); the values "
             "do not depend on it (a crowd's characters evaluate in parallel, docs/crowds.md).\n"
             "Arrays are in user units: (F,) for numbers (float64; int64 for whole numbers and enum indices; bool), "
             "(F, 3) for vectors, (F, 4, 4) for matrices (translation in the last column), (F, N) and (F, N, 4, 4) "
             "for arrays, a list of F strings for strings.")
        .def("plugs", &PyGraph::plugs, py::arg("glob") = "*",
             "Names of the plugs a glob matches (after an evaluation, so array outputs are listed), as graph-eval "
             "--get sees them. Raises riginv.Error when nothing matches.")
        .def("node_types", &PyGraph::nodeTypes, "Names of every node type the graph can use (built-ins and plugins).")
        .def_property_readonly("file", &PyGraph::file, "The rig file, as given to load().")
        .def_property_readonly("time", &PyGraph::time, "The scene time (frame) last evaluated.")
        .def("__repr__", [](const PyGraph& g) { return fmt::format("<riginv.Graph {}>", g.file()); });

    py::class_<PyApproximation> approximation(m, "Approximation",
                                              "A rig's learned approximation (docs/rig-learn.md): made by "
                                              "riginv.learn() or Approximation.load(), inverted with invert().");
    defInvert(approximation, std::make_index_sequence<rig::app::solveSettingCount>());
    approximation
        .def_static("load", &PyApproximation::load, py::arg("path"),
                    "Reads an approximation file written by rig-learn or save() (docs/approximation-format.md).")
        .def("save", &PyApproximation::save, py::arg("path"), py::arg("allow_inexact") = false,
             "Writes the approximation file (through a temporary file, as rig-learn -o). An approximation whose "
             "validation exceeds epsilon is refused with riginv.Error unless allow_inexact (rig-learn "
             "--allow-inexact).")
        .def_property_readonly("report", &PyApproximation::report,
                               "The dict rig-learn --report-json writes, for an approximation learned by "
                               "riginv.learn() ('approximation' and 'written' name the file once saved); None for "
                               "one loaded from a file.")
        .def_property_readonly("parameters", &PyApproximation::parameters,
                               "The modelled parameters' names, in composition order: the columns of invert()'s "
                               "values.")
        .def_property_readonly("outputs", &PyApproximation::outputs, "The output joints' names: the possible targets.")
        .def_property_readonly("held", &PyApproximation::held,
                               "The plugs held at a value while learning (rig-learn --set), in the rig file's units.")
        .def_property_readonly("rig_file", &PyApproximation::rigFile,
                               "The rig file it was learned from, as given then.")
        .def_property_readonly("file", &PyApproximation::file, "The file it was loaded from or saved to, or None.")
        .def("__repr__", [](const PyApproximation& a) {
            return fmt::format("<riginv.Approximation of {} ({} parameters, {} outputs)>", a.rigFile(),
                               a.parameters().size(), a.outputs().size());
        });

    m.def(
        "learn", &PyApproximation::learn, py::arg("rig_path"), py::arg("params"), py::arg("outputs") = py::list(),
        py::arg("epsilon") = 0.001, py::arg("orderer") = "structured", py::arg("progress") = py::none(), py::kw_only(),
        py::arg("plugins") = py::list(), py::arg("world_space") = false, py::arg("set") = py::none(),
        py::arg("ranges") = py::none(), py::arg("ranges_from") = py::none(), py::arg("ranges_map") = py::none(),
        py::arg("ranges_take") = py::none(), py::arg("ranges_frames") = py::none(),
        "Learns a rig's approximation, as rig-learn, and returns an Approximation.\n\n"
        "params: parameter plug globs ('L_arm_*.rotate?'); outputs: output joint globs (empty: every joint).\n"
        "epsilon: the validation threshold, cm per unit of a parameter; orderer: 'structured' or 'talk'; "
        "plugins, world_space: rig-learn's --plugin and --world-space; set: {plug: value}, plugs held at a "
        "value while learning, in the rig file's units (rig-learn --set); ranges: {parameter glob: [min, max]}, where "
        "controls without declared limits are learned (a spec's ranges:, rig-learn --range); ranges_from: a clip whose "
        "motion "
        "the ranges must cover (rig-learn --ranges-from), read with ranges_map, ranges_take and ranges_frames as "
        "invert() reads map, take and frames; report['ranges_from'] says what was widened.\n"
        "progress: called as progress(fraction done, 1.0), with the GIL held.\n"
        "An approximation over epsilon is returned (report['within_epsilon'] is False) but save() refuses it. "
        "The GIL is released while learning; Ctrl-C stops it (between learning steps, seen every 0.1 s).");
}
