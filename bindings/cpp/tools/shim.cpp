// The shim driver: drives the C++ client for the conformance kit (protocol `openair-shim/1`,
// conformance/openair_conformance/shim/PROTOCOL.md). One JSON object per line on stdin, one per
// line on stdout; free text on stderr. Between commands the client keeps answering deliveries.
// `openair-shim` runs it as is (shim_main.cpp); the test-only `openair-shim-broken` runs it with
// hooks that break one behaviour (shim_broken.cpp).
#include "shim.hpp"

#include <poll.h>
#include <unistd.h>

#include <chrono>
#include <cstdint>
#include <deque>
#include <iostream>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "openair/client.hpp"
#include "openair/version.hpp"
#include "shim_streams.hpp"

namespace openair::shim {

namespace {

// -- reading commands: an absent or null member means its default ----------------------------

const json* member(const json& v, std::string_view key) {
    auto it = v.find(key);
    return it == v.end() || it->is_null() ? nullptr : &*it;
}

std::string text(const json& v, std::string_view key, const std::string& dflt = "") {
    const json* m = member(v, key);
    return m == nullptr ? dflt : m->get<std::string>();
}

bool flag(const json& v, std::string_view key, bool dflt) {
    const json* m = member(v, key);
    return m == nullptr ? dflt : m->get<bool>();
}

std::int64_t integer(const json& v, std::string_view key, std::int64_t dflt) {
    const json* m = member(v, key);
    return m == nullptr ? dflt : m->get<std::int64_t>();
}

std::vector<std::string> strings(const json& v, std::string_view key) {
    const json* list = member(v, key);
    return list == nullptr ? std::vector<std::string>{} : list->get<std::vector<std::string>>();
}

// -- writing answers ---------------------------------------------------------------------------

json time_json(const std::optional<openair::air_time>& t) {
    if (!t) return nullptr;
    return json::array({t->sec, t->msec});
}

template <typename T>
json optional_json(const std::optional<T>& v) {
    return v ? json(*v) : json(nullptr);
}

json message_json(const openair::message& m) {
    return json{
        {"type", m.type},
        {"id", m.id},
        {"from", m.sender},
        {"to", m.to},
        {"cc", m.cc},
        {"stored", m.stored},
        {"isresponse", m.isresponse},
        {"posted", time_json(m.posted)},
        {"received", time_json(m.received)},
        {"priority", optional_json(m.priority)},
        {"wbid", optional_json(m.wbid)},
        {"content", m.content},
        {"xml", m.content_is_xml},
        {"attachments", attachments_json(m)},
    };
}

json wakeup_json(const openair::wakeup_event& e) {
    json retrieved = json::array();
    for (const openair::message& m : e.wakeup.retrieved) retrieved.push_back(message_json(m));
    return json{
        {"message", message_json(e.msg)},
        {"trigger", e.wakeup.trigger ? message_json(*e.wakeup.trigger) : json(nullptr)},
        {"retrieved", std::move(retrieved)},
        {"lasttrigger", e.wakeup.lasttrigger},
        {"received_ns", e.received_ns},
        {"path", e.path == openair::delivery_path::callback ? "callback" : "listener"},
    };
}

openair::retrieve_spec spec_from(const json& v) {
    openair::retrieve_spec s;
    s.whiteboard = text(v, "whiteboard");
    s.type = text(v, "type");
    s.sender = text(v, "sender");
    s.content = text(v, "content");
    s.latest = static_cast<std::uint64_t>(integer(v, "latest", 1));
    if (const json* ms = member(v, "lastmsec")) {
        s.lastmsec = static_cast<std::uint64_t>(ms->get<std::int64_t>());
    }
    return s;
}

class driver {
public:
    explicit driver(const hooks& h) : hooks_(h) {}

    /// Handle one command line; false once the shim must exit.
    bool handle(const std::string& line) {
        json cmd;
        std::int64_t seq = 0;
        std::string name;
        try {
            cmd = json::parse(line);
        } catch (const json::exception& e) {
            std::cerr << "openair-shim: not a JSON command: " << e.what() << std::endl;
            return true;  // OA-GEN-5: nothing on stdout, it cannot be paired with a command
        }
        const json* raw_seq = cmd.is_object() ? member(cmd, "seq") : nullptr;
        if (raw_seq == nullptr || !raw_seq->is_number_integer() || raw_seq->get<std::int64_t>() < 0) {
            std::cerr << "openair-shim: a command must be a JSON object with a non-negative "
                         "integer seq: "
                      << line << std::endl;
            return true;  // OA-GEN-5
        }
        try {
            seq = raw_seq->get<std::int64_t>();
            name = cmd.at("cmd").get<std::string>();
            if (hooks_.command) cmd = hooks_.command(name, cmd);
            json fields = json::object();
            bool more = run(name, cmd, fields);
            json answer{{"seq", seq}, {"ok", true}};
            answer.update(fields);
            say(name, std::move(answer));
            return more;
        } catch (const openair::error& e) {
            fail(name, seq, std::string(openair::errc_name(e.code())),
                 e.detail().empty() ? e.what() : e.detail());
        } catch (const std::exception& e) {
            fail(name, seq, "API_MISUSE", e.what());
        }
        return true;
    }

    /// Keep the client's deliveries flowing while no command is running.
    void idle() {
        if (!client_ || !client_->connected()) return;
        try {
            client_->poll(std::chrono::milliseconds(0));
        } catch (const std::exception& e) {
            std::cerr << "openair-shim: " << e.what() << std::endl;
        }
    }

    /// Write one protocol line: compact, UTF-8, bytes that are not UTF-8 as U+FFFD.
    static void write(const json& v) {
        std::cout << v.dump(-1, ' ', false, json::error_handler_t::replace) << '\n' << std::flush;
    }

private:
    void say(const std::string& name, json answer) const {
        write(hooks_.answer ? hooks_.answer(name, std::move(answer)) : answer);
    }

    void fail(const std::string& name, std::int64_t seq, const std::string& code,
              const std::string& message) const {
        say(name, json{{"seq", seq},
                       {"ok", false},
                       {"error", json{{"code", code}, {"message", message}}}});
    }

    openair::client& connected() {
        if (!client_) throw openair::error(openair::errc::api_misuse, "connect first");
        return *client_;
    }

    bool run(const std::string& name, const json& cmd, json& out) {
        if (name == "connect") return connect(cmd, out);
        if (name == "register") return subscribe(cmd);
        if (name == "post" || name == "post-noreply") return post(name, cmd, out);
        if (name == "retrieve") return retrieve(cmd, out);
        if (name == "await-wakeup") return await_wakeup(cmd, out);
        if (name == "close") {
            if (client_) client_->close();
            return false;
        }
        if (name.rfind("stream-", 0) == 0 || name == "await-sample" || name == "alarms-subscribe" ||
            name == "await-alarm") {
            if (streams_.run(connected(), name, cmd, out)) return true;
        }
        throw openair::error(openair::errc::api_misuse, "unknown command " + name);
    }

    bool connect(const json& cmd, json& out) {
        openair::client_options options;
        options.host = text(cmd, "host", "127.0.0.1");
        options.port = static_cast<std::uint16_t>(integer(cmd, "port", 10000));
        options.name = text(cmd, "name");
        options.bind = flag(cmd, "bind", true);
        options.listen = flag(cmd, "listen", true);
        options.callback = flag(cmd, "callback", true);
        if (cmd.contains("extensions")) {
            std::vector<std::string> known;
            for (const std::string& e : strings(cmd, "extensions")) {
                if (openair::client_extensions().count(e) != 0) known.push_back(e);
            }
            options.extensions = known;
        }
        if (client_) client_->close();
        client_.emplace(openair::client::connect(options));
        client_->on_wakeup([this](const openair::wakeup_event& e) { wakeups_.push_back(e); });
        streams_.attach(*client_);
        out["bound_port"] = client_->bound_port();
        out["legacy"] = client_->legacy();
        return true;
    }

    bool subscribe(const json& cmd) {
        std::vector<openair::trigger> triggers;
        if (const json* list = member(cmd, "triggers")) {
            for (const json& t : list->get_ref<const json::array_t&>()) {
                triggers.push_back({t.at("type").get<std::string>(), text(t, "from"),
                                    static_cast<std::uint64_t>(integer(t, "after", 0)), ""});
            }
        }
        std::vector<openair::retrieve_spec> retrieves;
        if (const json* list = member(cmd, "retrieves")) {
            for (const json& r : list->get_ref<const json::array_t&>()) {
                retrieves.push_back(spec_from(r));
            }
        }
        connected().subscribe(triggers, retrieves, flag(cmd, "allowselftriggering", false),
                              strings(cmd, "streams"));  // OA-STREAM-14
        return true;
    }

    bool post(const std::string& name, const json& cmd, json& out) {
        openair::post_options options;
        options.content_is_xml = flag(cmd, "xml", false);
        options.cc = strings(cmd, "cc");
        if (const json* p = member(cmd, "priority")) options.priority = p->get<double>();
        for (const std::string& chunk : strings(cmd, "attachments")) {
            options.binary.push_back(base64_decode(chunk));  // attachments: binary chunks
        }
        std::string to = cmd.at("to").get<std::string>();
        std::string type = cmd.at("type").get<std::string>();
        std::string content = text(cmd, "content");
        openair::message sent = name == "post"
                                    ? connected().post(to, type, content, options)
                                    : connected().post_noreply(to, type, content, options);
        out["id"] = sent.id;
        return true;
    }

    bool retrieve(const json& cmd, json& out) {
        std::vector<openair::retrieve_spec> specs;
        for (const json& s : cmd.at("specs").get_ref<const json::array_t&>()) {
            specs.push_back(spec_from(s));
        }
        json messages = json::array();
        std::string to = text(cmd, "to", "AIRCentral");
        for (const openair::message& m : connected().retrieve(specs, to)) {
            messages.push_back(message_json(m));
        }
        out["messages"] = std::move(messages);
        return true;
    }

    bool await_wakeup(const json& cmd, json& out) {
        auto timeout = std::chrono::milliseconds(integer(cmd, "timeout_ms", 10000));
        auto deadline = std::chrono::steady_clock::now() + timeout;
        openair::client& c = connected();
        while (wakeups_.empty()) {
            auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
                deadline - std::chrono::steady_clock::now());
            if (left.count() <= 0) {
                throw openair::error(openair::errc::request_timeout,
                                     "no wakeup within " + std::to_string(timeout.count()) + " ms");
            }
            c.poll(left);
        }
        out["wakeup"] = wakeup_json(wakeups_.front());
        wakeups_.pop_front();
        return true;
    }

    const hooks& hooks_;
    std::optional<openair::client> client_;
    std::deque<openair::wakeup_event> wakeups_;
    stream_commands streams_;
};

}  // namespace

int run(const hooks& h) {
    std::ios::sync_with_stdio(false);
    driver::write(json{{"event", "ready"},
                       {"protocol", "openair-shim/1"},
                       {"library", h.library},
                       {"version", openair::version}});
    driver shim(h);
    std::string pending;
    char buf[4096];
    while (true) {
        pollfd in{STDIN_FILENO, POLLIN, 0};
        int rc = ::poll(&in, 1, 50);
        if (rc <= 0) {
            shim.idle();
            continue;
        }
        ssize_t n = ::read(STDIN_FILENO, buf, sizeof buf);
        if (n <= 0) break;  // end of input means close
        pending.append(buf, static_cast<std::size_t>(n));
        std::size_t nl;
        while ((nl = pending.find('\n')) != std::string::npos) {
            std::string line = pending.substr(0, nl);
            pending.erase(0, nl + 1);
            if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
            if (!shim.handle(line)) return 0;
        }
    }
    return 0;
}

}  // namespace openair::shim
