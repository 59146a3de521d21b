// Command-line handling shared by the examples and the kit's C++ tools (CLI11, header-only).
#pragma once

#include <CLI/CLI.hpp>

#include <cstdint>
#include <iostream>
#include <optional>
#include <string>

namespace openair_cli {

/// The exit status of a program run with a bad command line.
inline constexpr int usage_status = 2;

/// Add `--port` (1-65535) to `app`, stored in `port`.
inline CLI::Option* add_port(CLI::App& app, std::uint16_t& port, const std::string& what) {
    return app.add_option("--port", port, what)->check(CLI::Range(1, 65535))->capture_default_str();
}

/// Accept a whole number of at least `min` (CLI11's own PositiveNumber reports its range in
/// doubles).
inline CLI::Validator at_least(long long min) {
    auto check = [min](std::string& input) -> std::string {
        long long number = 0;
        if (CLI::detail::lexical_cast(input, number) && number >= min) return {};
        return "Value " + input + " is not a whole number >= " + std::to_string(min);
    };
    return CLI::Validator(check, ">=" + std::to_string(min));
}

/// Parse the command line into `app`. Return nothing when the program goes on, or its exit
/// status: 0 after --help or --version (printed on stdout), 2 on a bad command line, reported
/// on one line of stderr.
inline std::optional<int> parse(CLI::App& app, int argc, char** argv) {
    try {
        app.parse(argc, argv);
        return std::nullopt;
    } catch (const CLI::ParseError& e) {
        if (e.get_exit_code() == static_cast<int>(CLI::ExitCodes::Success)) return app.exit(e);
        std::string what = e.what();
        for (char& c : what) {
            if (c == '\n') c = ' ';  // one line, whatever CLI11 wrote
        }
        std::cerr << app.get_name() << ": " << what << " (usage: " << app.get_name()
                  << " --help)" << std::endl;
        return usage_status;
    }
}

}  // namespace openair_cli
