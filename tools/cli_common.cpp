#include "tools/cli_common.h"

#include <charconv>
#include <iostream>

#include <fmt/format.h>

#include "core/error.h"

namespace rig::cli {

namespace {

// CLI11 says "Could not convert: --frames = abc" when a value is not of its option's type; say what the
// option takes instead (every typed option of the tools is a number or a list of numbers).
std::string conversionMessage(const CLI::App& app, const std::string& what)
{
    constexpr std::string_view prefix = "Could not convert: ";
    const auto equals = what.find(" = ");
    if (!what.starts_with(prefix) || equals == std::string::npos) return what;
    const std::string name = what.substr(prefix.size(), equals - prefix.size());
    const std::string value = what.substr(equals + 3);
    const CLI::Option* option = app.get_option_no_throw(name);
    const std::string type = option ? option->get_type_name() : std::string();
    const std::string_view kind = type.find("FLOAT") != std::string::npos ? "a number"
                                  : type.find("INT") != std::string::npos ? "a whole number in range"
                                                                          : "a value this option takes";
    return fmt::format("{}: '{}' is not {}", name, messageExcerpt(value), kind);
}

}  // namespace

int runMain(CLI::App& app, int argc, char** argv, const std::function<int()>& body)
{
    try {
        app.parse(argc, argv);
    }
    catch (const CLI::CallForHelp& e) {
        return app.exit(e);
    }
    catch (const CLI::ConversionError& e) {
        std::cerr << fmt::format("error: {}; run '{} --help' for usage\n", oneLine(conversionMessage(app, e.what())),
                                 app.get_name());
        return 2;
    }
    catch (const CLI::ParseError& e) {
        std::cerr << fmt::format("error: {}; run '{} --help' for usage\n", oneLine(e.what()), app.get_name());
        return 2;
    }
    // Messages quote what the user wrote (a name with a newline in it, a 10 MB line): oneLine keeps
    // them one printable line of bounded length.
    try {
        return body();
    }
    catch (const Error& e) {
        switch (e.kind()) {
            case ErrorKind::userInput:
                std::cerr << "error: " << oneLine(e.what()) << '\n';
                return 2;
            case ErrorKind::numerical:
                std::cerr << "error: " << oneLine(e.what()) << '\n';
                return 3;
            case ErrorKind::internal:
                break;
        }
        std::cerr << "internal error: " << oneLine(e.what()) << '\n';
        return 1;
    }
    catch (const std::bad_alloc&) {
        std::cerr << "error: out of memory; the input is too large for this machine (see docs/robustness.md for "
                     "the limits)\n";
        return 2;
    }
    catch (const std::exception& e) {
        std::cerr << "internal error: " << oneLine(e.what()) << '\n';
        return 1;
    }
}

CLI::Validator threadCount()
{
    return CLI::Validator(
        [](std::string& text) {
            int n = -1;
            const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), n);
            if (ec != std::errc() || end != text.data() + text.size() || n < 0 || n > 1024)
                return fmt::format("'{}' is not a thread count; give a whole number from 0 (all cores) to 1024", text);
            return std::string();
        },
        "0..1024");
}

CLI::Validator nonEmpty(std::string give)
{
    return CLI::Validator(
        [give = std::move(give)](std::string& text) {
            return text.empty() ? fmt::format("the value is empty; give {}", give) : std::string();
        },
        "TEXT");
}

}  // namespace rig::cli
