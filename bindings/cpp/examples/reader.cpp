// reader: bind a module, register a trigger and print the wakeups it receives.
//
//   reader [--host 127.0.0.1] [--port 10000] [--name Reader] [--type Test.Ping.*]
//          [--from WB1] [--count 1] [--timeout-ms 30000] [--nolisten]
//
// Exit status: 0 when `count` wakeups arrived, 1 on timeout, 2 on an error.
#include <chrono>
#include <cstdlib>
#include <iostream>
#include <string>

#include "openair/openair.hpp"

namespace {

struct args {
    openair::client_options options;
    std::string pattern = "Test.Ping.*";
    std::string from;
    int count = 1;
    long timeout_ms = 30000;
};

args parse(int argc, char** argv) {
    args a;
    a.options.name = "Reader";
    for (int i = 1; i < argc; ++i) {
        std::string key = argv[i];
        auto value = [&]() -> std::string {
            if (i + 1 >= argc) throw std::runtime_error(key + " needs a value");
            return argv[++i];
        };
        if (key == "--host")
            a.options.host = value();
        else if (key == "--port")
            a.options.port = static_cast<std::uint16_t>(std::stoi(value()));
        else if (key == "--name")
            a.options.name = value();
        else if (key == "--type")
            a.pattern = value();
        else if (key == "--from")
            a.from = value();
        else if (key == "--count")
            a.count = std::stoi(value());
        else if (key == "--timeout-ms")
            a.timeout_ms = std::stol(value());
        else if (key == "--nolisten")
            a.options.listen = false;
        else
            throw std::runtime_error("unknown option " + key);
    }
    return a;
}

}  // namespace

int main(int argc, char** argv) {
    try {
        args a = parse(argc, argv);
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
