#include "nodes/clips/bvh.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <numbers>

#include <fmt/format.h>

#include "core/error.h"
#include "core/input_file.h"
#include "core/parse_number.h"

namespace rig {
namespace {

constexpr std::array<std::string_view, 6> channelNames{"Xposition", "Yposition", "Zposition",
                                                       "Xrotation", "Yrotation", "Zrotation"};

bool iequals(std::string_view a, std::string_view b)
{
    return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](char x, char y) {
               return std::tolower(static_cast<unsigned char>(x)) == std::tolower(static_cast<unsigned char>(y));
           });
}

bool istartsWith(std::string_view text, std::string_view prefix)
{
    return text.size() >= prefix.size() && iequals(text.substr(0, prefix.size()), prefix);
}

std::optional<long long> parseWhole(std::string_view s)
{
    long long x = 0;
    const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), x);
    if (s.empty() || ec != std::errc() || end != s.data() + s.size()) return std::nullopt;
    return x;
}

std::optional<BvhChannel> channelFromName(std::string_view name)
{
    for (std::size_t i = 0; i < channelNames.size(); ++i)
        if (iequals(name, channelNames[i])) return static_cast<BvhChannel>(i);
    return std::nullopt;
}

// Long lines (a motion line where a header was expected) are cut in messages.
std::string excerpt(std::string_view text)
{
    return text.size() <= 40 ? std::string(text) : fmt::format("{}...", text.substr(0, 40));
}

bool isKeyword(std::string_view t)
{
    for (std::string_view k : {"ROOT", "JOINT", "End", "OFFSET", "CHANNELS", "MOTION", "{", "}"})
        if (iequals(t, k)) return true;
    return false;
}

class Parser {
public:
    Parser(std::string_view text, const std::string& file) : file_(file)
    {
        if (text.starts_with("\xEF\xBB\xBF")) text.remove_prefix(3);
        text_ = text;
        // The number of the last line holding anything, for messages about a file that ends too early.
        int number = 1;
        for (std::size_t i = 0; i < text_.size(); ++i) {
            const char c = text_[i];
            if (c == '\n' || (c == '\r' && (i + 1 >= text_.size() || text_[i + 1] != '\n'))) ++number;
            else if (!std::isspace(static_cast<unsigned char>(c))) lastLine_ = number;
        }
        clip_.file = file;
        nextLine();
    }

    BvhClip parse()
    {
        parseHierarchy();
        parseMotion();
        detectPositionRule();
        return std::move(clip_);
    }

private:
    // The text is read a line at a time (only the current line's tokens are kept: a long clip costs
    // its values, not a token list per value). Blank lines are skipped.
    void nextLine()
    {
        tokens_.clear();
        ti_ = 0;
        while (tokens_.empty() && pos_ < text_.size()) {
            std::size_t end = pos_;
            while (end < text_.size() && text_[end] != '\n' && text_[end] != '\r') ++end;
            const std::string_view rest = text_.substr(pos_, end - pos_);
            std::size_t p = 0;
            while (p < rest.size()) {
                while (p < rest.size() && std::isspace(static_cast<unsigned char>(rest[p]))) ++p;
                const std::size_t start = p;
                while (p < rest.size() && !std::isspace(static_cast<unsigned char>(rest[p]))) ++p;
                if (p > start) tokens_.push_back(rest.substr(start, p - start));
            }
            lineNumber_ = nextNumber_;
            if (end >= text_.size()) pos_ = text_.size();
            else {
                pos_ = end + (text_[end] == '\r' && end + 1 < text_.size() && text_[end + 1] == '\n' ? 2 : 1);
                ++nextNumber_;
            }
        }
        if (!tokens_.empty()) ++lineIndex_;
    }

    bool atEnd() const { return tokens_.empty(); }
    std::string_view peek() const { return tokens_[ti_]; }
    int line() const { return atEnd() ? lastLine_ : lineNumber_; }
    void advance()
    {
        if (++ti_ >= tokens_.size()) nextLine();
    }
    std::string_view take()
    {
        const std::string_view t = peek();
        advance();
        return t;
    }

    [[noreturn]] void fail(int line, const std::string& what) const
    {
        throw Error(fmt::format("{}:{}: {}", file_, line, what));
    }

    // Fails at the end of the file with `what` when no token is left.
    std::string_view takeOrFail(const std::string& what)
    {
        if (atEnd()) fail(lastLine_, what);
        return take();
    }

    std::string truncated(int joint) const
    {
        const BvhJoint& j = clip_.joints[static_cast<std::size_t>(joint)];
        return fmt::format(
            "the file ends inside joint '{}' ({} '{{' still open); the file is truncated or a '}}' is "
            "missing",
            j.name, j.depth + 1);
    }

    Eigen::Vector3d readOffset(int joint, std::string_view where)
    {
        Eigen::Vector3d v;
        for (int k = 0; k < 3; ++k) {
            const int l = line();
            const std::string_view t = takeOrFail(truncated(joint));
            const auto x = parseFiniteNumber(t);
            if (!x) fail(l, fmt::format("OFFSET of {} needs three numbers, found '{}'; write OFFSET X Y Z", where, t));
            v[k] = *x;
        }
        return v;
    }

    void readChannels(int joint)
    {
        const int l = line();
        const std::string_view countText = takeOrFail(truncated(joint));
        const auto count = parseWhole(countText);
        const std::string& name = clip_.joints[static_cast<std::size_t>(joint)].name;
        if (!count || *count < 0 || *count > bvhMaxChannelsPerJoint)
            fail(l, fmt::format("CHANNELS of joint '{}' needs a count from 0 to {}, found '{}'; write CHANNELS N "
                                "followed by N channel names",
                                name, bvhMaxChannelsPerJoint, countText));
        std::vector<BvhChannel> channels;
        std::array<bool, 3> position{};
        for (long long k = 0; k < *count; ++k) {
            const int at = line();
            const std::string_view t = takeOrFail(truncated(joint));
            const auto c = channelFromName(t);
            if (!c && isKeyword(t))
                fail(at, fmt::format("CHANNELS {} of joint '{}' lists only {} channel names, then '{}'; list as many "
                                     "names as the count says",
                                     *count, name, k, t));
            if (!c)
                fail(at,
                     fmt::format("unknown channel '{}' in joint '{}'; channels are Xposition, Yposition, Zposition, "
                                 "Xrotation, Yrotation, Zrotation",
                                 t, name));
            if (!bvhIsRotation(*c)) {
                auto& seen = position[static_cast<std::size_t>(bvhChannelAxis(*c))];
                if (seen)
                    fail(at, fmt::format("joint '{}' lists {} twice; a position channel may appear once per joint",
                                         name, bvhChannelName(*c)));
                seen = true;
            }
            channels.push_back(*c);
        }
        clip_.joints[static_cast<std::size_t>(joint)].channels = std::move(channels);
    }

    void parseEndSite(int joint)
    {
        const BvhJoint& j = clip_.joints[static_cast<std::size_t>(joint)];
        const std::string name = j.name;
        const int endLine = line();
        const std::size_t siteLine = lineIndex_;
        const std::string_view site = takeOrFail(truncated(joint));
        if (!iequals(site, "Site"))
            fail(endLine,
                 fmt::format("expected 'Site' after 'End' in joint '{}', found '{}'; write End Site", name, site));
        if (j.endSite)
            fail(endLine, fmt::format("joint '{}' has a second End Site; a joint ends in at most one", name));
        while (!atEnd() && lineIndex_ == siteLine && peek() != "{") advance();  // "End Site name": the name is dropped
        const int l1 = line();
        if (const auto t = takeOrFail(truncated(joint)); t != "{")
            fail(l1, fmt::format("expected '{{' after End Site of joint '{}', found '{}'; open the End Site with '{{'",
                                 name, t));
        const int l2 = line();
        if (const auto t = takeOrFail(truncated(joint)); !iequals(t, "OFFSET"))
            fail(l2, fmt::format("expected OFFSET in the End Site of joint '{}', found '{}'; an End Site holds one "
                                 "OFFSET X Y Z",
                                 name, t));
        const Eigen::Vector3d offset = readOffset(joint, fmt::format("the End Site of joint '{}'", name));
        const int l3 = line();
        if (const auto t = takeOrFail(truncated(joint)); t != "}")
            fail(l3, fmt::format("expected '}}' closing the End Site of joint '{}', found '{}'; an End Site holds "
                                 "only an OFFSET",
                                 name, t));
        clip_.joints[static_cast<std::size_t>(joint)].endSite = offset;
    }

    void parseJoint(int parent, int depth, std::string_view keyword, int keywordLine)
    {
        if (clip_.joints.size() >= static_cast<std::size_t>(bvhMaxJoints))
            fail(keywordLine,
                 fmt::format("more than {} joints; this is not a skeleton (or the file is damaged)", bvhMaxJoints));
        if (depth >= bvhMaxDepth)
            fail(keywordLine, fmt::format("joints nested more than {} levels deep; real skeletons stay far below "
                                          "that, check the braces",
                                          bvhMaxDepth));
        // The name is the rest of the keyword's line (it may hold spaces), up to a '{'.
        std::string name;
        const std::size_t nameLine = lineIndex_;
        while (!atEnd() && lineIndex_ == nameLine && ti_ > 0 && peek() != "{") {
            name += name.empty() ? "" : " ";
            name += take();
        }
        if (name.empty()) fail(keywordLine, fmt::format("{} without a name; write {} NAME", keyword, keyword));
        if (name.size() > static_cast<std::size_t>(bvhMaxNameLength))
            fail(keywordLine, fmt::format("the name of {} '{}' has {} characters, more than {}; shorten it", keyword,
                                          excerpt(name), name.size(), bvhMaxNameLength));

        const int joint = static_cast<int>(clip_.joints.size());
        BvhJoint j;
        j.name = name;
        j.parent = parent;
        j.depth = depth;
        j.line = keywordLine;
        clip_.joints.push_back(std::move(j));

        const int braceLine = line();
        if (const auto t = takeOrFail(truncated(joint)); t != "{")
            fail(braceLine, fmt::format("expected '{{' after {} {}, found '{}'; open the joint's block with '{{'",
                                        keyword, name, t));
        bool hasOffset = false;
        bool hasChannels = false;
        bool hasChildren = false;
        while (true) {
            const int l = line();
            const std::string_view t = takeOrFail(truncated(joint));
            if (iequals(t, "OFFSET")) {
                // (A joint's children need its OFFSET first, so an OFFSET after them is a second one.)
                if (hasOffset) fail(l, fmt::format("joint '{}' has a second OFFSET; give one OFFSET per joint", name));
                clip_.joints[static_cast<std::size_t>(joint)].offset =
                    readOffset(joint, fmt::format("joint '{}'", name));
                hasOffset = true;
            } else if (iequals(t, "CHANNELS")) {
                if (hasChannels)
                    fail(l, fmt::format("joint '{}' has a second CHANNELS line; list all its channels once", name));
                if (hasChildren)
                    fail(l, fmt::format("CHANNELS of joint '{}' comes after its children; write it before the first "
                                        "child",
                                        name));
                readChannels(joint);
                hasChannels = true;
            } else if (iequals(t, "JOINT") || iequals(t, "End")) {
                if (!hasOffset)
                    fail(l, fmt::format("joint '{}' has no OFFSET before its children; add OFFSET X Y Z after its "
                                        "'{{'",
                                        name));
                hasChildren = true;
                if (iequals(t, "End")) parseEndSite(joint);
                else parseJoint(joint, depth + 1, "JOINT", l);
            } else if (t == "}") {
                if (!hasOffset) fail(l, fmt::format("joint '{}' has no OFFSET; add OFFSET X Y Z after its '{{'", name));
                return;
            } else if (iequals(t, "MOTION") || iequals(t, "ROOT")) {
                fail(l, fmt::format("{} inside joint '{}' ({} '{{' still open); the braces do not match: a '}}' is "
                                    "missing above",
                                    t, name, depth + 1));
            } else {
                fail(l, fmt::format("unexpected '{}' in joint '{}'; expected OFFSET, CHANNELS, JOINT, End Site or '}}'",
                                    t, name));
            }
        }
    }

    void parseHierarchy()
    {
        if (atEnd()) fail(1, "the file is empty; a BVH file starts with HIERARCHY");
        const int first = line();
        if (const auto t = take(); !iequals(t, "HIERARCHY"))
            fail(first, fmt::format("expected HIERARCHY, found '{}'; a BVH file starts with HIERARCHY", t));
        while (true) {
            if (atEnd()) {
                if (clip_.joints.empty())
                    fail(lastLine_,
                         "the file ends after HIERARCHY; the skeleton (ROOT NAME {...}) is missing, the "
                         "file is truncated");
                fail(lastLine_,
                     "the file ends after the hierarchy without a MOTION section; the file is truncated, "
                     "export it again");
            }
            const int l = line();
            const std::string_view t = take();
            if (iequals(t, "ROOT")) parseJoint(-1, 0, "ROOT", l);
            else if (iequals(t, "MOTION") && !clip_.joints.empty()) {
                motionLine_ = l;
                break;
            } else if (clip_.joints.empty())
                fail(l, fmt::format("expected ROOT, found '{}'; the hierarchy starts with ROOT NAME", t));
            else if (t == "}")
                fail(l, "'}' closes nothing (the braces do not match); remove it or add the missing '{'");
            else
                fail(l, fmt::format("expected MOTION after the hierarchy, found '{}'; add a MOTION line before "
                                    "'Frames:'",
                                    t));
        }
        int column = 0;
        for (BvhJoint& j : clip_.joints) {
            j.firstChannel = column;
            column += static_cast<int>(j.channels.size());
        }
        clip_.channelCount = column;
    }

    // The value of a header line "KEY: VALUE" ("Frames: 120", "Frame Time: 0.0333"): the key's words
    // may be spaced by any whitespace, the colon glued to the key or the value, or standing alone.
    std::string headerLine(std::string_view key, std::string_view expected, const std::string& ifTruncated, int& number)
    {
        if (atEnd()) fail(lastLine_, ifTruncated);
        number = lineNumber_;
        std::string joined;
        for (std::string_view t : tokens_) joined += fmt::format("{}{}", joined.empty() ? "" : " ", t);
        nextLine();
        std::string rest = istartsWith(joined, key) ? joined.substr(key.size()) : std::string("?");
        if (!rest.empty() && rest[0] != ' ' && rest[0] != ':')
            fail(number, fmt::format("expected '{}', found '{}'; the MOTION header is 'Frames: N' then 'Frame Time: "
                                     "SECONDS'",
                                     expected, excerpt(joined)));
        if (rest.starts_with(' ')) rest.erase(0, 1);
        if (rest.starts_with(':')) rest.erase(0, 1);
        if (rest.starts_with(' ')) rest.erase(0, 1);
        return rest;
    }

    void parseMotion()
    {
        if (!atEnd() && ti_ > 0)
            fail(motionLine_, fmt::format("unexpected '{}' after MOTION; 'Frames: N' goes on the next line", peek()));
        const std::string noFrames =
            "the file ends after MOTION; 'Frames: N', 'Frame Time: SECONDS' and the motion "
            "data are missing, the file is truncated";
        int framesLine = 0;
        const std::string framesText = headerLine("Frames", "Frames: N", noFrames, framesLine);
        const auto declared = parseWhole(framesText);
        if (!declared || *declared < 0)
            fail(framesLine,
                 fmt::format("'Frames: {}' is not a frame count; write a whole number of frames", framesText));

        const std::string noTime =
            "the file ends before 'Frame Time: SECONDS' and the motion data; the file is truncated";
        int timeLine = 0;
        const std::string timeText = headerLine("Frame Time", "Frame Time: SECONDS", noTime, timeLine);
        const auto frameTime = parseFiniteNumber(timeText);
        if (!frameTime || *frameTime <= 0.0)
            fail(timeLine, fmt::format("'Frame Time: {}' must be a positive number of seconds per frame (e.g. "
                                       "0.0333333 for 30 fps)",
                                       timeText));
        clip_.frameTime = *frameTime;

        if (clip_.channelCount == 0)
            fail(motionLine_, "the hierarchy has no channels (every CHANNELS count is 0); there is no motion to read");
        if (atEnd())
            fail(lastLine_, fmt::format("no motion data after 'Frame Time' (the file announces {} frames); the file is "
                                        "truncated",
                                        *declared));
        const auto perLine = static_cast<std::size_t>(clip_.channelCount);
        // Room for the announced frames, but never more than the rest of the text can hold (a value
        // takes at least two characters): a damaged 'Frames:' must not reserve the memory away.
        const std::size_t fit = (text_.size() - pos_ + tokens_.size() * 2) / 2 / perLine + 1;
        clip_.values.reserve(std::min(static_cast<std::size_t>(*declared), fit) * perLine);
        int frame = 0;
        for (; !atEnd(); nextLine()) {
            ++frame;
            if (tokens_.size() != perLine)
                fail(lineNumber_,
                     fmt::format("motion line {} has {} values but the hierarchy has {} channels; the line "
                                 "is truncated or does not belong to this hierarchy",
                                 frame, tokens_.size(), perLine));
            for (std::size_t k = 0; k < perLine; ++k) {
                const auto x = parseFiniteNumber(tokens_[k]);
                if (!x)
                    fail(lineNumber_, fmt::format("value {} of motion line {} is '{}', not a number; motion lines hold "
                                                  "only numbers",
                                                  k + 1, frame, excerpt(tokens_[k])));
                clip_.values.push_back(*x);
            }
        }
        clip_.frameCount = frame;
        if (*declared != frame)
            clip_.warnings.push_back(
                fmt::format("{}:{}: 'Frames: {}' but the file has {} motion lines; using the {} "
                            "lines",
                            file_, framesLine, *declared, frame, frame));
    }

    // The rule documented in bvh.h: each root alone, all non-root joints together.
    void detectPositionRule()
    {
        auto decide = [&](const std::vector<int>& group) {
            double sumReplace = 0.0;
            double sumAdd = 0.0;
            for (int f = 0; f < clip_.frameCount; ++f) {
                const auto values = clip_.frame(f);
                for (int j : group) {
                    const BvhJoint& joint = clip_.joints[static_cast<std::size_t>(j)];
                    for (std::size_t k = 0; k < joint.channels.size(); ++k) {
                        if (bvhIsRotation(joint.channels[k])) continue;
                        const double v = values[static_cast<std::size_t>(joint.firstChannel) + k];
                        const double o = joint.offset[bvhChannelAxis(joint.channels[k])];
                        sumReplace += (v - o) * (v - o);
                        sumAdd += v * v;
                    }
                }
            }
            for (int j : group) clip_.joints[static_cast<std::size_t>(j)].positionReplacesOffset = sumReplace < sumAdd;
        };
        std::vector<int> inner;
        for (std::size_t j = 0; j < clip_.joints.size(); ++j) {
            if (clip_.joints[j].parent < 0) decide({static_cast<int>(j)});
            else inner.push_back(static_cast<int>(j));
        }
        decide(inner);
    }

    std::string file_;
    std::string_view text_;
    std::size_t pos_ = 0;                   // start of the next line to read
    int nextNumber_ = 1;                    // its number
    std::vector<std::string_view> tokens_;  // the current line's tokens (empty at the end of the text)
    std::size_t ti_ = 0;                    // the next token of the current line
    int lineNumber_ = 0;                    // the current line's number
    std::size_t lineIndex_ = 0;             // counts the non-blank lines read, to tell lines apart
    int lastLine_ = 1;
    int motionLine_ = 1;
    BvhClip clip_;
};

// Elementary rotation about axis 0, 1, 2 (x, y, z) by `degrees`: column vectors, right-handed.
Eigen::Matrix4d rotation(int axis, double degrees)
{
    const double a = degrees * std::numbers::pi / 180.0;
    const double c = std::cos(a);
    const double s = std::sin(a);
    Eigen::Matrix4d m;
    if (axis == 0) m << 1, 0, 0, 0, 0, c, -s, 0, 0, s, c, 0, 0, 0, 0, 1;
    else if (axis == 1) m << c, 0, s, 0, 0, 1, 0, 0, -s, 0, c, 0, 0, 0, 0, 1;
    else m << c, -s, 0, 0, s, c, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1;
    return m;
}

}  // namespace

std::string_view bvhChannelName(BvhChannel channel) { return channelNames[static_cast<std::size_t>(channel)]; }

int bvhChannelAxis(BvhChannel channel) { return static_cast<int>(channel) % 3; }

bool bvhIsRotation(BvhChannel channel) { return static_cast<int>(channel) >= 3; }

std::span<const double> BvhClip::frame(int index) const
{
    const auto n = static_cast<std::size_t>(channelCount);
    return std::span<const double>(values).subspan(static_cast<std::size_t>(index) * n, n);
}

BvhClip parseBvh(std::string_view text, const std::string& fileName) { return Parser(text, fileName).parse(); }

BvhClip readBvhFile(const std::filesystem::path& file)
{
    return parseBvh(
        readInputFile(file, {"a BVH file", "a .bvh file", bvhMaxFileBytes, "cut the clip into shorter ones"}),
        file.string());
}

Eigen::Vector3d bvhTranslation(const BvhClip& clip, int joint, std::span<const double> frame)
{
    const BvhJoint& j = clip.joints[static_cast<std::size_t>(joint)];
    Eigen::Vector3d t = j.offset;
    for (std::size_t k = 0; k < j.channels.size(); ++k) {
        if (bvhIsRotation(j.channels[k])) continue;
        const double v = frame[static_cast<std::size_t>(j.firstChannel) + k];
        const int axis = bvhChannelAxis(j.channels[k]);
        t[axis] = j.positionReplacesOffset ? v : t[axis] + v;
    }
    return t;
}

std::vector<double> bvhRigChannels(const BvhClip& clip, std::span<const double> frame)
{
    std::vector<double> out;
    bvhRigChannels(clip, frame, out);
    return out;
}

void bvhRigChannels(const BvhClip& clip, std::span<const double> frame, std::vector<double>& out)
{
    out.assign(frame.begin(), frame.end());
    for (std::size_t j = 0; j < clip.joints.size(); ++j) {
        const BvhJoint& joint = clip.joints[j];
        const Eigen::Vector3d t = bvhTranslation(clip, static_cast<int>(j), frame);
        for (std::size_t k = 0; k < joint.channels.size(); ++k)
            if (!bvhIsRotation(joint.channels[k]))
                out[static_cast<std::size_t>(joint.firstChannel) + k] = t[bvhChannelAxis(joint.channels[k])];
    }
}

std::vector<double> bvhSample(const BvhClip& clip, double time)
{
    std::vector<double> out;
    bvhSample(clip, time, out);
    return out;
}

void bvhSample(const BvhClip& clip, double time, std::vector<double>& out)
{
    const double last = static_cast<double>(clip.frameCount);
    const double t = time >= last ? last : time >= 1.0 ? time : 1.0;  // NaN holds frame 1
    const double below = std::floor(t);
    const int i = static_cast<int>(below) - 1;
    const double u = t - below;
    const auto a = clip.frame(i);
    out.assign(a.begin(), a.end());
    if (u == 0.0 || i + 1 >= clip.frameCount) return;
    const auto b = clip.frame(i + 1);
    for (const BvhJoint& joint : clip.joints)
        for (std::size_t k = 0; k < joint.channels.size(); ++k) {
            const auto c = static_cast<std::size_t>(joint.firstChannel) + k;
            double d = b[c] - a[c];
            if (bvhIsRotation(joint.channels[k])) d -= 360.0 * std::floor((d + 180.0) / 360.0);
            out[c] = a[c] + u * d;
        }
}

std::vector<Eigen::Matrix4d> bvhWorldMatrices(const BvhClip& clip, std::span<const double> frame)
{
    std::vector<Eigen::Matrix4d> world;
    bvhWorldMatrices(clip, frame, world);
    return world;
}

void bvhWorldMatrices(const BvhClip& clip, std::span<const double> frame, std::vector<Eigen::Matrix4d>& world)
{
    world.resize(clip.joints.size());
    for (std::size_t j = 0; j < clip.joints.size(); ++j) {
        const BvhJoint& joint = clip.joints[j];
        Eigen::Matrix4d local = Eigen::Matrix4d::Identity();
        local.block<3, 1>(0, 3) = bvhTranslation(clip, static_cast<int>(j), frame);
        for (std::size_t k = 0; k < joint.channels.size(); ++k)
            if (bvhIsRotation(joint.channels[k]))
                local = local * rotation(bvhChannelAxis(joint.channels[k]),
                                         frame[static_cast<std::size_t>(joint.firstChannel) + k]);
        world[j] = joint.parent < 0 ? local : Eigen::Matrix4d(world[static_cast<std::size_t>(joint.parent)] * local);
    }
}

std::vector<Eigen::Matrix4d> bvhWorldMatrices(const BvhClip& clip, int frameIndex)
{
    return bvhWorldMatrices(clip, clip.frame(frameIndex));
}

}  // namespace rig
