// openair-shim-broken: the conformance shim with one behaviour broken on purpose, so that the
// tests (tests/bindings/test_cpp_binding.py) can prove `openair conform-client` catches a
// misbehaving C++ binding.
//
//   openair-shim-broken --break NAME   run the shim (openair-shim/1) with NAME broken
//   openair-shim-broken --list         print every NAME, one a line
//
// Shim-layer breaks rewrite what the shim reports or asks of the library (the hooks of
// shim.hpp). Library breaks select a fault hook of the test library openair_client_faults
// (src/test_faults.hpp, compiled only under OPENAIR_TEST_FAULTS). This binary is built only with
// OPENAIR_BUILD_BROKEN_SHIM and is never installed or linked into anything else.
#include <algorithm>
#include <cstring>
#include <iostream>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "json.hpp"
#include "shim.hpp"
#include "test_faults.hpp"

#ifndef OPENAIR_TEST_FAULTS
#error "openair-shim-broken needs the fault hooks (OPENAIR_TEST_FAULTS)"
#endif

namespace {

using openair::json::array;
using openair::json::object;
using openair::json::value;
using openair::shim::hooks;

/// A copy of object `v` whose member `key` is `replacement` (added when absent).
value with(const value& v, std::string_view key, value replacement) {
    object members = v.as_object();
    for (auto& [name, member] : members) {
        if (name == key) {
            member = std::move(replacement);
            return value(std::move(members));
        }
    }
    members.emplace_back(std::string(key), std::move(replacement));
    return value(std::move(members));
}

bool succeeded(const value& answer) {
    const value* ok = answer.find("ok");
    return ok != nullptr && ok->as_bool();
}

/// An answer hook that rewrites the successful answers to `command` only.
void on_answer(hooks& h, std::string command, value (*rewrite)(const value& answer)) {
    h.answer = [command = std::move(command), rewrite](const std::string& cmd, value answer) {
        return cmd == command && succeeded(answer) ? rewrite(answer) : answer;
    };
}

/// The wakeup answer with its wakeup object rewritten by `rewrite`.
value rewrite_wakeup(const value& answer, value (*rewrite)(const value& wakeup)) {
    return with(answer, "wakeup", rewrite(answer.at("wakeup")));
}

// -- the shim-layer breaks -------------------------------------------------------------------

/// Report the trigger message's from and to swapped.
void wrong_trigger(hooks& h) {
    on_answer(h, "await-wakeup", [](const value& answer) {
        return rewrite_wakeup(answer, [](const value& wakeup) {
            const value& trigger = wakeup.at("trigger");
            if (trigger.is_null()) return wakeup;
            value swapped = with(trigger, "from", trigger.at("to"));
            swapped = with(swapped, "to", trigger.at("from"));
            return with(wakeup, "trigger", swapped);
        });
    });
}

/// Report retrieved messages oldest first.
void retrieve_oldest_first(hooks& h) {
    on_answer(h, "retrieve", [](const value& answer) {
        array messages = answer.at("messages").as_array();
        std::reverse(messages.begin(), messages.end());
        return with(answer, "messages", value(std::move(messages)));
    });
}

/// Report a callback delivery as a listener one and the other way round.
void path_swapped(hooks& h) {
    on_answer(h, "await-wakeup", [](const value& answer) {
        return rewrite_wakeup(answer, [](const value& wakeup) {
            bool callback = wakeup.at("path").as_string() == "callback";
            return with(wakeup, "path", value(callback ? "listener" : "callback"));
        });
    });
}

/// Report a phase update as if the wakeup message itself had triggered it.
void phase_as_trigger(hooks& h) {
    on_answer(h, "await-wakeup", [](const value& answer) {
        return rewrite_wakeup(answer, [](const value& wakeup) {
            if (!wakeup.at("trigger").is_null()) return wakeup;
            return with(wakeup, "trigger", wakeup.at("message"));
        });
    });
}

/// Never report a legacy server.
void legacy_hidden(hooks& h) {
    on_answer(h, "connect",
              [](const value& answer) { return with(answer, "legacy", value(false)); });
}

/// Post XML content as text.
void xml_as_text(hooks& h) {
    h.command = [](const std::string& cmd, value command) {
        if (cmd != "post" && cmd != "post-noreply") return command;
        return with(command, "xml", value(false));
    };
}

/// Report every failure as REQUEST_FAILED, whatever the library's error was.
void errors_as_request_failed(hooks& h) {
    h.answer = [](const std::string&, value answer) {
        if (succeeded(answer)) return answer;
        value error = with(answer.at("error"), "code", value("REQUEST_FAILED"));
        return with(answer, "error", std::move(error));
    };
}

const std::pair<std::string_view, void (*)(hooks&)> shim_breaks[] = {
    {"wrong-trigger", wrong_trigger},
    {"retrieve-oldest-first", retrieve_oldest_first},
    {"path-swapped", path_swapped},
    {"phase-as-trigger", phase_as_trigger},
    {"legacy-hidden", legacy_hidden},
    {"xml-as-text", xml_as_text},
    {"errors-as-request-failed", errors_as_request_failed},
};

std::vector<std::string_view> all_names() {
    std::vector<std::string_view> names;
    for (const auto& entry : shim_breaks) names.push_back(entry.first);
    for (std::string_view name : openair::detail::faults::names()) names.push_back(name);
    return names;
}

int usage(const char* program) {
    std::cerr << "usage: " << program << " --break NAME | --list\nNAME is one of:";
    for (std::string_view name : all_names()) std::cerr << ' ' << name;
    std::cerr << std::endl;
    return 2;
}

}  // namespace

int main(int argc, char** argv) {
    if (argc == 2 && std::strcmp(argv[1], "--list") == 0) {
        for (std::string_view name : all_names()) std::cout << name << '\n';
        return 0;
    }
    if (argc != 3 || std::strcmp(argv[1], "--break") != 0) return usage(argv[0]);
    std::string_view name = argv[2];
    hooks h;
    h.library = "openair-cpp-broken-" + std::string(name);
    auto found = std::find_if(std::begin(shim_breaks), std::end(shim_breaks),
                              [name](const auto& entry) { return entry.first == name; });
    if (found != std::end(shim_breaks)) {
        found->second(h);
    } else if (!openair::detail::faults::select(name)) {
        return usage(argv[0]);
    }
    return openair::shim::run(h);
}
