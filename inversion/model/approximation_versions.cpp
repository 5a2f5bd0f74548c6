#include "inversion/model/approximation_file.h"

#include <yaml-cpp/depthguard.h>

#include "inversion/model/approximation_io.h"

// What an approximation file is, before its fields are read (approximation_reader.cpp): one YAML document, of the
// format, at a version this program reads (1 to approximationFormatVersion), and no field a later version added in an
// older file. The versions' differences are fields added: a version 1 file has no `parent:` (every output in world
// space), versions 1 and 2 no helpers nor constraints.

namespace rig::approximation_file {
namespace {

// One document: a marker line ('---' or '...' at column 0, which ends a document wherever it stands) after the
// first content line would start another, which YAML::Load would silently drop. Found by reading lines, not by
// YAML::LoadAll: yaml-cpp 0.7 returns empty documents without end on some damaged text until the memory runs out
// (found by fuzz/approximation_loader_fuzzer).
void checkOneDocument(std::string_view text, const std::string& fileName)
{
    bool content = false;
    int lineNumber = 0;
    for (std::size_t start = 0; start < text.size();) {
        const std::size_t end = std::min(text.find('\n', start), text.size());
        const std::string_view line = text.substr(start, end - start);
        start = end + 1;
        ++lineNumber;
        const bool marker = (line.starts_with("---") || line.starts_with("...")) &&
                            (line.size() == 3 || line[3] == ' ' || line[3] == '\t' || line[3] == '\r');
        if (marker && content)
            throw Error(
                fmt::format("{}:{}:1: file: '{}' ends the YAML document; an approximation file is "
                            "one document: remove it and what follows, or re-run rig-learn",
                            fileName, lineNumber, line.substr(0, 3)));
        const auto first = line.find_first_not_of(" \t\r");
        content = content || (!marker && first != std::string_view::npos && line[first] != '#');
    }
}

YAML::Node parseDocument(std::string_view text, const std::string& fileName)
{
    try {
        return YAML::Load(std::string(text));
    }
    catch (const YAML::DeepRecursion& e) {
        throw Error(
            fmt::format("{}:{}:{}: YAML lists and maps nested more than {} levels deep; an "
                        "approximation file nests a few levels, so the file is damaged",
                        fileName, e.mark.line + 1, e.mark.column + 1, e.depth() - 1));
    }
    catch (const YAML::Exception& e) {
        throw Error(
            fmt::format("{}:{}:{}: YAML syntax error: {}", fileName, e.mark.line + 1, e.mark.column + 1, e.msg));
    }
}

}  // namespace

YAML::Node parseOneDocument(std::string_view text, const std::string& fileName)
{
    checkOneDocument(text, fileName);
    return parseDocument(text, fileName);
}

int checkFormat(const Reader& r, const YAML::Node& root, const std::string& fileName)
{
    if (!root.IsMap())
        throw Error(
            fmt::format("{}: not an approximation file (expected a map with format: {}); rig-learn -o "
                        "writes one",
                        fileName, approximationFormatName));
    if (!root["format"])
        throw Error(fmt::format("{}: not an approximation file (no 'format: {}'); rig-learn -o writes one", fileName,
                                approximationFormatName));
    const YAML::Node format = root["format"];
    if (!format.IsScalar() || format.Scalar() != approximationFormatName)
        r.fail(format, "format",
               fmt::format("not an approximation file (expected format: {})", approximationFormatName));
    const int version = r.integer<int>(r.need(root, "version", "file"), "version");
    if (version < 1 || version > approximationFormatVersion)
        r.fail(root["version"], "version",
               fmt::format("version {} is not supported; this program reads versions 1 to {} (re-run rig-learn)",
                           version, approximationFormatVersion));
    r.checkKeys(root, "file",
                {"format", "version", "rigFile", "rigFingerprint", "epsilon", "training", "validation", "outputs",
                 "parameters", "discarded"},
                {"droppedOutputs", "held", "constraints"});
    return version;
}

void checkVersion3Field(const Reader& r, const YAML::Node& n, const std::string& field, int version)
{
    if (n && version < 3)
        r.fail(n, field,
               fmt::format("version 3 added this field, but the file says version {}; re-run rig-learn, or write "
                           "version: 3",
                           version));
}

}  // namespace rig::approximation_file
