// The shim driver: drives the C++ client for the conformance kit (protocol `openair-shim/1`,
// conformance/openair_conformance/shim/PROTOCOL.md). One JSON object per line on stdin, one per
// line on stdout; free text on stderr. Between commands the client keeps answering deliveries.
// `openair-shim` runs it as is (shim_main.cpp); the test-only `openair-shim-broken` runs it with
// hooks that break one behaviour (shim_broken.cpp).
#include "shim.hpp"

#include <poll.h>
#include <unistd.h>

#include <chrono>
#include <deque>
#include <iostream>
#include <optional>
#include <string>

#include "openair/client.hpp"

namespace openair::shim {

namespace {

using openair::json::array;
using openair::json::object;
using openair::json::value;

constexpr const char* library_version = "0.1.0";

value time_json(const std::optional<openair::air_time>& t) {
    if (!t) return value(nullptr);
    return value(array{value(t->sec), value(t->msec)});
}

value message_json(const openair::message& m) {
    return value(object{
        {"type", value(m.type)},
        {"id", value(m.id)},
        {"from", value(m.sender)},
        {"to", value(m.to)},
        {"cc", value(m.cc)},
        {"stored", value(m.stored)},
        {"isresponse", value(m.isresponse)},
        {"posted", time_json(m.posted)},
        {"received", time_json(m.received)},
        {"priority", m.priority ? value(*m.priority) : value(nullptr)},
        {"wbid", m.wbid ? value(*m.wbid) : value(nullptr)},
        {"content", value(m.content)},
        {"xml", value(m.content_is_xml)},
    });
}

value wakeup_json(const openair::wakeup_event& e) {
    array retrieved;
    for (const openair::message& m : e.wakeup.retrieved) retrieved.push_back(message_json(m));
    return value(object{
        {"message", message_json(e.msg)},
        {"trigger", e.wakeup.trigger ? message_json(*e.wakeup.trigger) : value(nullptr)},
        {"retrieved", value(std::move(retrieved))},
        {"lasttrigger", value(e.wakeup.lasttrigger)},
        {"received_ns", value(e.received_ns)},
        {"path", value(e.path == openair::delivery_path::callback ? "callback" : "listener")},
    });
}

openair::retrieve_spec spec_from(const value& v) {
    openair::retrieve_spec s;
    s.whiteboard = v.get_string("whiteboard");
    s.type = v.get_string("type");
    s.sender = v.get_string("sender");
    s.content = v.get_string("content");
    s.latest = static_cast<std::uint64_t>(v.get_int("latest", 1));
    if (const value* ms = v.find("lastmsec"); ms != nullptr && !ms->is_null()) {
        s.lastmsec = static_cast<std::uint64_t>(ms->as_int());
    }
    return s;
}

std::vector<std::string> strings(const value& v, std::string_view key) {
    std::vector<std::string> out;
    if (const value* list = v.find(key); list != nullptr && !list->is_null()) {
        for (const value& item : list->as_array()) out.push_back(item.as_string());
    }
    return out;
}

class driver {
public:
    explicit driver(const hooks& h) : hooks_(h) {}

    /// Handle one command line; false once the shim must exit.
    bool handle(const std::string& line) {
        value cmd;
        std::int64_t seq = 0;
        std::string name;
        try {
            cmd = openair::json::parse(line);
            seq = cmd.get_int("seq", 0);
            name = cmd.at("cmd").as_string();
            if (hooks_.command) cmd = hooks_.command(name, cmd);
            object fields;
            bool more = run(name, cmd, fields);
            object answer{{"seq", value(seq)}, {"ok", value(true)}};
            for (auto& field : fields) answer.push_back(std::move(field));
            say(name, value(std::move(answer)));
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

    static void write(const value& v) { std::cout << openair::json::dump(v) << '\n' << std::flush; }

private:
    void say(const std::string& name, value answer) const {
        write(hooks_.answer ? hooks_.answer(name, std::move(answer)) : answer);
    }

    void fail(const std::string& name, std::int64_t seq, const std::string& code,
              const std::string& text) const {
        say(name, value(object{
                      {"seq", value(seq)},
                      {"ok", value(false)},
                      {"error", value(object{{"code", value(code)}, {"message", value(text)}})}}));
    }

    openair::client& connected() {
        if (!client_) throw openair::error(openair::errc::api_misuse, "connect first");
        return *client_;
    }

    bool run(const std::string& name, const value& cmd, object& out) {
        if (name == "connect") return connect(cmd, out);
        if (name == "register") return subscribe(cmd);
        if (name == "post" || name == "post-noreply") return post(name, cmd, out);
        if (name == "retrieve") return retrieve(cmd, out);
        if (name == "await-wakeup") return await_wakeup(cmd, out);
        if (name == "close") {
            if (client_) client_->close();
            return false;
        }
        throw openair::error(openair::errc::api_misuse, "unknown command " + name);
    }

    bool connect(const value& cmd, object& out) {
        openair::client_options options;
        options.host = cmd.get_string("host", "127.0.0.1");
        options.port = static_cast<std::uint16_t>(cmd.get_int("port", 10000));
        options.name = cmd.get_string("name");
        options.bind = cmd.get_bool("bind", true);
        options.listen = cmd.get_bool("listen", true);
        options.callback = cmd.get_bool("callback", true);
        if (cmd.find("extensions") != nullptr) {
            std::vector<std::string> known;
            for (const std::string& e : strings(cmd, "extensions")) {
                if (openair::client_extensions().count(e) != 0) known.push_back(e);
            }
            options.extensions = known;
        }
        if (client_) client_->close();
        client_.emplace(openair::client::connect(options));
        client_->on_wakeup([this](const openair::wakeup_event& e) { wakeups_.push_back(e); });
        out.emplace_back("bound_port", value(client_->bound_port()));
        out.emplace_back("legacy", value(client_->legacy()));
        return true;
    }

    bool subscribe(const value& cmd) {
        std::vector<openair::trigger> triggers;
        if (const value* list = cmd.find("triggers")) {
            for (const value& t : list->as_array()) {
                triggers.push_back({t.at("type").as_string(), t.get_string("from"),
                                    static_cast<std::uint64_t>(t.get_int("after", 0)), ""});
            }
        }
        std::vector<openair::retrieve_spec> retrieves;
        if (const value* list = cmd.find("retrieves")) {
            for (const value& r : list->as_array()) retrieves.push_back(spec_from(r));
        }
        connected().subscribe(triggers, retrieves, cmd.get_bool("allowselftriggering", false));
        return true;
    }

    bool post(const std::string& name, const value& cmd, object& out) {
        openair::post_options options;
        options.content_is_xml = cmd.get_bool("xml", false);
        options.cc = strings(cmd, "cc");
        if (const value* p = cmd.find("priority"); p != nullptr && !p->is_null()) {
            options.priority = p->as_double();
        }
        std::string to = cmd.at("to").as_string();
        std::string type = cmd.at("type").as_string();
        std::string content = cmd.get_string("content");
        openair::message sent = name == "post"
                                    ? connected().post(to, type, content, options)
                                    : connected().post_noreply(to, type, content, options);
        out.emplace_back("id", value(sent.id));
        return true;
    }

    bool retrieve(const value& cmd, object& out) {
        std::vector<openair::retrieve_spec> specs;
        for (const value& s : cmd.at("specs").as_array()) specs.push_back(spec_from(s));
        array messages;
        for (const openair::message& m :
             connected().retrieve(specs, cmd.get_string("to", "AIRCentral"))) {
            messages.push_back(message_json(m));
        }
        out.emplace_back("messages", value(std::move(messages)));
        return true;
    }

    bool await_wakeup(const value& cmd, object& out) {
        auto timeout = std::chrono::milliseconds(cmd.get_int("timeout_ms", 10000));
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
        out.emplace_back("wakeup", wakeup_json(wakeups_.front()));
        wakeups_.pop_front();
        return true;
    }

    const hooks& hooks_;
    std::optional<openair::client> client_;
    std::deque<openair::wakeup_event> wakeups_;
};

}  // namespace

int run(const hooks& h) {
    std::ios::sync_with_stdio(false);
    driver::write(value(object{{"event", value("ready")},
                               {"protocol", value("openair-shim/1")},
                               {"library", value(h.library)},
                               {"version", value(library_version)}}));
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
