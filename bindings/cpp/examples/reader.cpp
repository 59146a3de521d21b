// reader: bind a module, register a trigger and print the wakeups it receives.
//
//   reader [--host 127.0.0.1] [--port 10000] [--name Reader] [--type Test.Ping.*]
//          [--from WB1] [--count 1] [--timeout-ms 30000] [--nolisten]
//
// Exit status: 0 when `count` wakeups arrived, 1 on timeout, 2 on a bad command line or an
// error.
#include <chrono>
#include <iostream>
#include <string>

#include "cli.hpp"
#include "openair/openair.hpp"
#include "openair/version.hpp"

namespace {

struct args {
    openair::client_options options;
    std::string pattern = "Test.Ping.*";
    std::string from;
    int count = 1;
    long timeout_ms = 30000;
};

void describe(CLI::App& app, args& a) {
    app.set_version_flag("--version", std::string("openair ") + openair::version);
    app.add_option("--host", a.options.host, "Server host")->capture_default_str();
    openair_cli::add_port(app, a.options.port, "Server port");
    app.add_option("--name", a.options.name, "Module name")->capture_default_str();
    app.add_option("--type", a.pattern, "Trigger type pattern")->capture_default_str();
    app.add_option("--from", a.from, "Whiteboard of the trigger (any when empty)");
    app.add_option("--count", a.count, "Exit 0 after this many wakeups")
        ->check(openair_cli::at_least(1))
        ->capture_default_str();
    app.add_option("--timeout-ms", a.timeout_ms, "Exit 1 when they have not arrived by then")
        ->check(openair_cli::at_least(0))
        ->capture_default_str();
    app.add_flag_callback(
        "--nolisten", [&a] { a.options.listen = false; },
        "Take deliveries on the callback connection only (BIND_NOLISTEN)");
}

}  // namespace

int main(int argc, char** argv) {
    args a;
    a.options.name = "Reader";
    CLI::App app{"Bind a module, register a trigger and print the wakeups it receives.", "reader"};
    describe(app, a);
    if (auto status = openair_cli::parse(app, argc, argv)) return *status;

    try {
        openair::client module = openair::client::connect(a.options);
        int seen = 0;
        module.on_wakeup([&seen](const openair::wakeup_event& event) {
            if (!event.wakeup.trigger) return;  // a phase update (OA-WAKE-8)
            const openair::message& m = *event.wakeup.trigger;
            std::cout << "wakeup " << m.type << " from " << m.sender << " on " << m.stored
                      << " (trigger " << event.wakeup.lasttrigger << ", via "
                      << (event.path == openair::delivery_path::callback ? "callback" : "listener")
                      << "): " << m.content << std::endl;
            ++seen;
        });
        module.subscribe({openair::trigger{a.pattern, a.from, 0, ""}});
        std::cout << "ready: " << a.options.name << " bound port " << module.bound_port()
                  << (module.legacy() ? " (legacy server)" : "") << std::endl;
        auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(a.timeout_ms);
        while (seen < a.count && std::chrono::steady_clock::now() < deadline) {
            module.poll(std::chrono::milliseconds(200));
        }
        return seen >= a.count ? 0 : 1;
    } catch (const std::exception& e) {
        std::cerr << "reader: " << e.what() << std::endl;
        return 2;
    }
}
