#pragma once
// Plug values as command lines print them: in the file's units (degrees for angles), matrices as
// four rows (column-vector convention: translation in the last column). JSON is nlohmann's; the
// tools' JSON files share the number rule and the frame layout below.

#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "graph/graph.h"
#include "inversion/model/approximation.h"
#include "inversion/model/rig_function.h"

namespace rig::app {

// Keys stay in insertion order: a report reads in the order its docs list the keys.
using Json = nlohmann::ordered_json;

// A number: a whole number below 1e16 as an integer ("frame": 1, where nlohmann writes a double as
// 1.0), anything else as the double, text that reads back the same bits (-0 as -0.0; null when not finite).
Json numberJson(double x);

// `json` as text. Pretty (`indent` >= 0) or on one line with ", " between items, as graph-eval has
// always printed values. Strings that are not UTF-8 get U+FFFD instead of failing the run.
std::string jsonText(const Json& json, int indent = -1);

// One frame of the JSON list graph-eval writes (rig-invert's curves too): {"frame": F, then one
// "name": value per line}, indented for the list. Lists are written a frame at a time, so a long run
// never holds all its frames as JSON values.
std::string frameJson(double frame, const std::vector<std::pair<std::string, Json>>& values);

// JSON of a value of `plug` (null for a non-finite number).
Json valueToJson(const Graph& graph, const Plug& plug, const Value& value);

// What a plug's numbers are multiplied by to be in user units (degrees for angles; 1 otherwise).
double userScale(const Graph& graph, const Plug& plug);

// A rig parameter's value in user units (degrees for angles, cm) from internal units (radians), and back:
// curves files, reports and the Python module's arrays hold user units.
double parameterUserValue(const RigParameter& parameter, double internal);
double parameterInternalValue(const RigParameter& parameter, double user);

// Held plugs (rig-learn --set) as reports show them: "PLUG = VALUE, ..." in the rig file's units, and a JSON
// list of {plug, value}.
std::string heldText(const std::vector<HeldPlug>& held);
Json heldJson(const std::vector<HeldPlug>& held);

// CSV column names for `plug` (one per number) and the matching fields of a value.
std::vector<std::string> csvColumns(const Graph& graph, const Plug& plug, const Value& value);
// `digits` > 0 rounds to that many significant digits (for tables meant to be read). An enum is its name, as in JSON.
std::vector<std::string> csvFields(const Graph& graph, const Plug& plug, const Value& value, int digits = 0);

}  // namespace rig::app
