// Shared by Skundar's C++ modules: `key=value;...` contents, the server address, stopping.
#pragma once

#include <atomic>
#include <csignal>
#include <cstdlib>
#include <iomanip>
#include <map>
#include <sstream>
#include <string>

namespace skundar {

inline std::atomic<bool> running{true};

inline void on_signal(int) { running = false; }

/// Stop the poll loop on SIGTERM or SIGINT (the demo runner stops modules with SIGTERM).
inline void handle_signals() {
    std::signal(SIGTERM, on_signal);
    std::signal(SIGINT, on_signal);
}

/// Parse `a=1;b=2`.
inline std::map<std::string, std::string> kv(const std::string& content) {
    std::map<std::string, std::string> out;
    std::istringstream in(content);
    std::string part;
    while (std::getline(in, part, ';')) {
        auto eq = part.find('=');
        if (eq != std::string::npos) out[part.substr(0, eq)] = part.substr(eq + 1);
    }
    return out;
}

inline double number(const std::map<std::string, std::string>& values, const std::string& key) {
    auto it = values.find(key);
    return it == values.end() ? 0.0 : std::strtod(it->second.c_str(), nullptr);
}

inline std::string fixed(double value) {
    std::ostringstream out;
    out << std::fixed << std::setprecision(6) << value;
    return out.str();
}

/// The server from SKUNDAR_HOST / SKUNDAR_PORT (defaults 127.0.0.1:10000).
inline void address(std::string& host, std::uint16_t& port) {
    const char* h = std::getenv("SKUNDAR_HOST");
    const char* p = std::getenv("SKUNDAR_PORT");
    host = h != nullptr ? h : "127.0.0.1";
    port = static_cast<std::uint16_t>(p != nullptr ? std::atoi(p) : 10000);
}

}  // namespace skundar
