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
#include <iostream>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "cli.hpp"
#include "shim.hpp"
#include "test_faults.hpp"

#ifndef OPENAIR_TEST_FAULTS
#error "openair-shim-broken needs the fault hooks (OPENAIR_TEST_FAULTS)"
#endif

namespace {

using openair::shim::hooks;
using openair::shim::json;

/// A copy of object `v` whose member `key` is `replacement` (added at the end when absent).
json with(const json& v, const std::string& key, json replacement) {
    json copy = v;
    copy[key] = std::move(replacement);
    return copy;
}

bool succeeded(const json& answer) {
    auto ok = answer.find("ok");
    return ok != answer.end() && ok->get<bool>();
}

/// An answer hook that rewrites the successful answers to `command` only.
void on_answer(hooks& h, std::string command, json (*rewrite)(const json& answer)) {
    h.answer = [command = std::move(command), rewrite](const std::string& cmd, json answer) {
        return cmd == command && succeeded(answer) ? rewrite(answer) : answer;
    };
}

/// The wakeup answer with its wakeup object rewritten by `rewrite`.
json rewrite_wakeup(const json& answer, json (*rewrite)(const json& wakeup)) {
    return with(answer, "wakeup", rewrite(answer.at("wakeup")));
}

// -- the shim-layer breaks -------------------------------------------------------------------

/// Report the trigger message's from and to swapped.
void wrong_trigger(hooks& h) {
    on_answer(h, "await-wakeup", [](const json& answer) {
        return rewrite_wakeup(answer, [](const json& wakeup) {
            const json& trigger = wakeup.at("trigger");
            if (trigger.is_null()) return wakeup;
            json swapped = with(trigger, "from", trigger.at("to"));
            swapped = with(swapped, "to", trigger.at("from"));
            return with(wakeup, "trigger", swapped);
        });
    });
}

/// Report retrieved messages oldest first.
void retrieve_oldest_first(hooks& h) {
    on_answer(h, "retrieve", [](const json& answer) {
        json messages = answer.at("messages");
        std::reverse(messages.begin(), messages.end());
        return with(answer, "messages", std::move(messages));
    });
}

/// Report a callback delivery as a listener one and the other way round.
void path_swapped(hooks& h) {
    on_answer(h, "await-wakeup", [](const json& answer) {
        return rewrite_wakeup(answer, [](const json& wakeup) {
            bool callback = wakeup.at("path").get<std::string>() == "callback";
            return with(wakeup, "path", callback ? "listener" : "callback");
        });
    });
}

/// Report a phase update as if the wakeup message itself had triggered it.
void phase_as_trigger(hooks& h) {
    on_answer(h, "await-wakeup", [](const json& answer) {
        return rewrite_wakeup(answer, [](const json& wakeup) {
            if (!wakeup.at("trigger").is_null()) return wakeup;
            return with(wakeup, "trigger", wakeup.at("message"));
        });
    });
}

/// Never report a legacy server.
void legacy_hidden(hooks& h) {
    on_answer(h, "connect",
              [](const json& answer) { return with(answer, "legacy", false); });
}

/// Post XML content as text.
void xml_as_text(hooks& h) {
    h.command = [](const std::string& cmd, json command) {
        if (cmd != "post" && cmd != "post-noreply") return command;
        return with(command, "xml", false);
    };
}

/// Report every failure as REQUEST_FAILED, whatever the library's error was.
void errors_as_request_failed(hooks& h) {
    h.answer = [](const std::string&, json answer) {
        if (succeeded(answer)) return answer;
        json error = with(answer.at("error"), "code", "REQUEST_FAILED");
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

std::vector<std::string> all_names() {
    std::vector<std::string> names;
    for (const auto& entry : shim_breaks) names.emplace_back(entry.first);
    for (std::string_view name : openair::detail::faults::names()) names.emplace_back(name);
    return names;
}

}  // namespace

int main(int argc, char** argv) {
    std::string name;
    bool list = false;
    CLI::App app{"The conformance shim with one behaviour broken on purpose (tests only).",
                 "openair-shim-broken"};
    auto* broken = app.add_option("--break", name, "Run the shim with NAME broken")
                       ->option_text("NAME")
                       ->check(CLI::IsMember(all_names()));
    app.add_flag("--list", list, "Print every NAME, one a line")->excludes(broken);
    app.require_option(1);
    if (auto status = openair_cli::parse(app, argc, argv)) return *status;

    if (list) {
        for (const std::string& n : all_names()) std::cout << n << '\n';
        return 0;
    }
    hooks h;
    h.library = "openair-cpp-broken-" + name;
    auto found = std::find_if(std::begin(shim_breaks), std::end(shim_breaks),
                              [&name](const auto& entry) { return entry.first == name; });
    if (found != std::end(shim_breaks)) {
        found->second(h);
    } else {
        (void)openair::detail::faults::select(name);  // a member of all_names(): always found
    }
    return openair::shim::run(h);
}
