#include "core/error.h"

#include <fmt/format.h>

namespace rig {

namespace {

std::string withoutNul(std::string message)
{
    for (std::size_t at = message.find('\0'); at != std::string::npos; at = message.find('\0', at))
        message.replace(at, 1, "\\x00");
    return message;
}

}  // namespace

Error::Error(const std::string& message, ErrorKind kind) : std::runtime_error(withoutNul(message)), kind_(kind) {}

Error Error::in(std::string_view where) const { return Error(fmt::format("{}: {}", where, what()), kind_); }

std::string formatMark(const SourceMark& mark)
{
    if (mark.line <= 0) return mark.file;
    return fmt::format("{}:{}:{}", mark.file, mark.line, mark.column);
}

std::string oneLine(std::string_view message, std::size_t maxLength)
{
    std::string out;
    for (std::size_t i = 0; i < message.size(); ++i) {
        const char c = message[i];
        const auto u = static_cast<unsigned char>(c);
        // A UTF-8 sequence is kept whole when it is valid (joint names in any language); any other byte
        // above 0x7f (binary garbage) is escaped like a control character.
        const std::size_t length = u < 0x80 ? 1 : (u >> 5) == 0x6 ? 2 : (u >> 4) == 0xe ? 3 : (u >> 3) == 0x1e ? 4 : 0;
        bool valid = length > 0 && i + length <= message.size();
        for (std::size_t k = 1; valid && k < length; ++k)
            valid = (static_cast<unsigned char>(message[i + k]) >> 6) == 0x2;
        if (c == '\n') out += "\\n";
        else if (c == '\r') out += "\\r";
        else if (c == '\t') out += "\\t";
        else if (u < 0x20 || u == 0x7f || !valid) out += fmt::format("\\x{:02x}", u);
        else {
            out += message.substr(i, length);
            i += length - 1;
        }
    }
    if (out.size() <= maxLength) return out;
    const std::size_t keep = maxLength / 2;
    return fmt::format("{} [... {} characters cut ...] {}", out.substr(0, keep), out.size() - 2 * keep,
                       out.substr(out.size() - keep));
}

std::string messageExcerpt(std::string_view text, std::size_t maxLength)
{
    if (text.size() <= maxLength) return std::string(text);
    return fmt::format("{}... ({} characters)", text.substr(0, maxLength), text.size());
}

}  // namespace rig
