// The stream commands of the shim driver (PROTOCOL.md, "Streams and attachments"): each turns
// one command into calls of the stream API (openair/stream.hpp). Payloads travel as base64, or
// as {"fill", "size"} so that a scenario can ask for a sample of several MiB.
#include "shim_streams.hpp"

#include <array>
#include <chrono>
#include <utility>
#include <vector>

namespace openair::shim {

namespace {

constexpr std::string_view alphabet =
    "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
constexpr std::int64_t max_fill = 64LL << 20;  // max-frame-binary

[[noreturn]] void misuse(const std::string& what) {
    throw openair::error(openair::errc::api_misuse, what);
}

[[noreturn]] void timed_out(const std::string& what) {
    throw openair::error(openair::errc::request_timeout, what);
}

const json* member(const json& v, std::string_view key) {
    auto it = v.find(key);
    return it == v.end() || it->is_null() ? nullptr : &*it;
}

std::string text(const json& v, std::string_view key, const std::string& dflt = "") {
    const json* m = member(v, key);
    return m == nullptr ? dflt : m->get<std::string>();
}

std::optional<std::int64_t> optional_int(const json& v, std::string_view key) {
    const json* m = member(v, key);
    if (m == nullptr) return std::nullopt;
    if (!m->is_number_integer()) misuse(std::string(key) + " must be an integer");
    return m->get<std::int64_t>();
}

std::int64_t integer(const json& v, std::string_view key, std::optional<std::int64_t> dflt = {}) {
    auto value = optional_int(v, key);
    if (!value && !dflt) misuse(std::string(key) + " is required");
    return value ? *value : *dflt;
}

bool flag(const json& v, std::string_view key, bool dflt) {
    const json* m = member(v, key);
    return m == nullptr ? dflt : m->get<bool>();
}

std::chrono::milliseconds timeout_of(const json& cmd) {
    return std::chrono::milliseconds(std::max<std::int64_t>(0, integer(cmd, "timeout_ms", 5000)));
}

std::string payload_of(const json* spec) {
    if (spec == nullptr) return {};
    if (spec->is_string()) return base64_decode(spec->get<std::string>());
    if (!spec->is_object()) misuse("a payload is base64 text or {fill, size}");
    std::string unit = base64_decode(text(*spec, "fill"));
    std::int64_t size = integer(*spec, "size");
    if (size < 0 || size > max_fill) {
        misuse("a fill size must be in 0.." + std::to_string(max_fill));
    }
    if (size > 0 && unit.empty()) misuse("a fill needs at least one byte");
    std::string out;
    out.reserve(static_cast<std::size_t>(size));
    while (out.size() < static_cast<std::size_t>(size)) {
        out.append(unit, 0, std::min(unit.size(), static_cast<std::size_t>(size) - out.size()));
    }
    return out;
}

openair::sample_options options_of(const json& v) {
    openair::sample_options o;
    if (const json* params = member(v, "params")) {
        for (const json& pair : params->get_ref<const json::array_t&>()) {
            if (!pair.is_array() || pair.size() != 2) misuse("params are [key, value] pairs");
            o.params.emplace_back(pair.at(0).get<std::string>(), pair.at(1).get<std::string>());
        }
    }
    o.timestamp_ms = optional_int(v, "timestamp_ms");
    o.seq = optional_int(v, "sample_seq");
    return o;
}

json natural(std::optional<std::int64_t> v) {
    return v && *v >= 0 ? json(*v) : json(nullptr);
}

json sample_json(const openair::data_sample& s, bool payloads) {
    json params = json::array();
    for (const auto& [k, v] : s.params()) params.push_back(json::array({k, v}));
    return json{{"id", natural(s.id())},
                {"timestamp", natural(s.timestamp_ms())},
                {"size", s.size()},
                {"payload", payloads ? json(base64_encode(s.payload())) : json(nullptr)},
                {"params", std::move(params)}};
}

json received_json(const openair::received_sample& r, bool payloads) {
    return json{{"stream", r.stream},
                {"sample", sample_json(r.sample, payloads)},
                {"dropped", r.dropped},
                {"received_ns", r.received_ns}};
}

json info_json(const openair::stream_info& i) {
    auto id = [](const std::optional<std::uint64_t>& v) { return v ? json(*v) : json(nullptr); };
    return json{{"name", i.name},         {"whiteboard", i.whiteboard}, {"type", i.type},
                {"count", i.count},       {"size", i.size},             {"oldest", id(i.oldest)},
                {"newest", id(i.newest)}, {"maxsize", i.maxsize},       {"maxcount", i.maxcount},
                {"subscribers", i.subscribers}, {"locked", i.locked}};
}

openair::stream& stream_of(openair::client& c, const json& cmd) {
    std::string target = text(cmd, "stream");
    if (target.empty()) misuse("stream must name a stream or a stream type");
    return c.stream(target);
}

json samples_json(const std::vector<openair::data_sample>& found, bool payloads) {
    json out = json::array();
    for (const openair::data_sample& s : found) out.push_back(sample_json(s, payloads));
    return out;
}

}  // namespace

std::string base64_encode(bytes_view bytes) {
    std::string out;
    out.reserve((bytes.size() + 2) / 3 * 4);
    std::size_t i = 0;
    auto at = [&](std::size_t k) { return static_cast<std::uint32_t>(bytes[k]); };
    for (; i + 2 < bytes.size(); i += 3) {
        std::uint32_t n = (at(i) << 16) | (at(i + 1) << 8) | at(i + 2);
        for (int shift : {18, 12, 6, 0}) out += alphabet[(n >> shift) & 0x3F];
    }
    if (i + 1 == bytes.size()) {
        std::uint32_t n = at(i) << 16;
        out += alphabet[(n >> 18) & 0x3F];
        out += alphabet[(n >> 12) & 0x3F];
        out += "==";
    } else if (i + 2 == bytes.size()) {
        std::uint32_t n = (at(i) << 16) | (at(i + 1) << 8);
        for (int shift : {18, 12, 6}) out += alphabet[(n >> shift) & 0x3F];
        out += '=';
    }
    return out;
}

std::string base64_decode(std::string_view text) {
    if (text.size() % 4 != 0) misuse("not base64: the length is not a multiple of 4");
    std::array<int, 256> value{};
    value.fill(-1);
    for (std::size_t k = 0; k < alphabet.size(); ++k) {
        value[static_cast<unsigned char>(alphabet[k])] = static_cast<int>(k);
    }
    std::string out;
    out.reserve(text.size() / 4 * 3);
    for (std::size_t i = 0; i < text.size(); i += 4) {
        std::uint32_t n = 0;
        int pad = 0;
        for (std::size_t k = 0; k < 4; ++k) {
            char ch = text[i + k];
            int v = value[static_cast<unsigned char>(ch)];
            bool last = i + 4 == text.size();
            if (ch == '=' && last && k >= 2 && (k == 3 || text[i + 3] == '=')) {
                ++pad;
                v = 0;
            } else if (v < 0 || pad > 0) {
                misuse("not base64");
            }
            n = (n << 6) | static_cast<std::uint32_t>(v);
        }
        out += static_cast<char>((n >> 16) & 0xFF);
        if (pad < 2) out += static_cast<char>((n >> 8) & 0xFF);
        if (pad < 1) out += static_cast<char>(n & 0xFF);
    }
    return out;
}

json attachments_json(const openair::message& m) {
    json out = json::array();
    for (const std::string& chunk : m.binary) out.push_back(base64_encode(chunk));
    return out;
}

void stream_commands::attach(openair::client& c) {
    auto queue = samples_;
    c.on_sample([queue](const openair::received_sample& r) { queue->push_back(r); });
}

openair::stream_subscription& stream_commands::subscription(const json& cmd) {
    auto it = subscriptions_.find(integer(cmd, "subscription"));
    if (it == subscriptions_.end()) misuse("no such subscription");
    return *it->second;
}

json stream_commands::add(openair::client& c, const json& cmd) {
    openair::stream& s = stream_of(c, cmd);
    std::string payload = payload_of(member(cmd, "payload"));
    openair::sample_options o = options_of(cmd);
    std::string mode = text(cmd, "mode", "message");
    if (mode == "message") return s.add(payload, o);
    if (mode == "binary") return s.add_binary(payload, o);
    if (mode == "noreply") {
        s.add_noreply(payload, o);
        return nullptr;
    }
    misuse("unknown add mode " + mode);
}

json stream_commands::add_many(openair::client& c, const json& cmd) {
    openair::stream& s = stream_of(c, cmd);
    const json* rows = member(cmd, "samples");
    if (rows == nullptr || !rows->is_array() || rows->empty()) {
        misuse("samples must be a non-empty list");
    }
    std::vector<std::string> payloads;
    std::vector<openair::sample_options> options;
    for (const json& row : *rows) {
        payloads.push_back(payload_of(member(row, "payload")));
        options.push_back(options_of(row));
    }
    std::vector<openair::bytes_view> views(payloads.begin(), payloads.end());
    std::string mode = text(cmd, "mode", "batch");
    if (mode == "batch") return s.add_many(views, options);
    if (mode == "pipelined") return s.add_pipelined(views, options);
    misuse("unknown add-many mode " + mode);
}

json stream_commands::read(openair::client& c, const json& cmd) {
    openair::stream& s = stream_of(c, cmd);
    std::string by = text(cmd, "by");
    std::vector<openair::data_sample> found;
    if (by == "range") {
        found = s.between(integer(cmd, "from_ms"), integer(cmd, "until_ms"));
    } else if (by == "id") {
        found.push_back(s.get(static_cast<std::uint64_t>(integer(cmd, "id"))));
    } else if (by == "time") {
        found.push_back(s.at(integer(cmd, "time_ms")));
    } else if (by == "newest") {
        found.push_back(s.newest());
    } else if (by == "oldest") {
        found.push_back(s.oldest());
    } else {
        misuse("unknown read " + by);
    }
    return samples_json(found, flag(cmd, "payloads", true));
}

json stream_commands::wait(openair::client& c, const json& cmd) {
    openair::stream& s = stream_of(c, cmd);
    auto timeout = std::chrono::milliseconds(integer(cmd, "timeout_ms", 5000));
    bool last = flag(cmd, "last", false);
    auto after_id = optional_int(cmd, "after_id");
    auto after_ms = optional_int(cmd, "after_ms");
    if (after_id.has_value() == after_ms.has_value()) {
        misuse("stream-wait takes exactly one of after_id and after_ms");
    }
    std::optional<openair::data_sample> got =
        after_id ? s.wait_after_id(static_cast<std::uint64_t>(*after_id), timeout, last)
                 : s.wait_sample(*after_ms, timeout, last);
    return got ? sample_json(*got, flag(cmd, "payloads", true)) : json(nullptr);
}

bool stream_commands::run(openair::client& c, const std::string& name, const json& cmd, json& out) {
    bool payloads = flag(cmd, "payloads", true);
    if (name == "stream-open") {
        out["name"] = stream_of(c, cmd).name();
    } else if (name == "stream-add") {
        out["sample_id"] = add(c, cmd);
    } else if (name == "stream-add-many") {
        out["sample_ids"] = add_many(c, cmd);
    } else if (name == "stream-read") {
        out["samples"] = read(c, cmd);
    } else if (name == "stream-wait") {
        out["sample"] = wait(c, cmd);
    } else if (name == "stream-info") {
        out["info"] = info_json(stream_of(c, cmd).info());
    } else if (name == "stream-search") {
        openair::sample_search q;
        q.after_ms = optional_int(cmd, "after_ms");
        q.until_ms = optional_int(cmd, "until_ms");
        if (const json* globs = member(cmd, "params")) {
            for (auto it = globs->begin(); it != globs->end(); ++it) {
                q.params.emplace_back(it.key(), it.value().get<std::string>());
            }
        }
        q.latest = static_cast<std::uint64_t>(integer(cmd, "latest", 0));
        out["samples"] = samples_json(stream_of(c, cmd).search(q), payloads);
    } else if (name == "stream-lock") {
        openair::stream_lock lock = stream_of(c, cmd).lock(
            static_cast<std::uint64_t>(integer(cmd, "first")),
            static_cast<std::uint64_t>(integer(cmd, "last")));
        out["lock"] = lock.release();  // the kit unlocks it with stream-unlock
    } else if (name == "stream-unlock") {
        stream_of(c, cmd).unlock(static_cast<std::uint64_t>(integer(cmd, "lock")));
    } else if (name == "stream-subscribe") {
        auto buffer = static_cast<std::size_t>(integer(cmd, "buffer", 100));
        openair::stream_subscription& sub = c.subscribe_stream(text(cmd, "stream"), buffer);
        subscriptions_[next_handle_] = &sub;
        out["subscription"] = next_handle_++;
    } else if (name == "stream-next") {
        auto got = subscription(cmd).next(timeout_of(cmd));
        if (!got) timed_out("no sample within the timeout");
        out["received"] = received_json(*got, payloads);
    } else if (name == "stream-unsubscribe") {
        openair::stream_subscription& sub = subscription(cmd);
        sub.close();
        subscriptions_.erase(integer(cmd, "subscription"));
        out["received"] = sub.received();
        out["dropped"] = sub.dropped();
    } else if (name == "await-sample") {
        auto deadline = std::chrono::steady_clock::now() + timeout_of(cmd);
        while (samples_->empty()) {
            auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
                deadline - std::chrono::steady_clock::now());
            if (left.count() <= 0) {
                timed_out("no sample within the timeout");
            }
            c.poll(left);
        }
        out["received"] = received_json(samples_->front(), payloads);
        samples_->pop_front();
    } else if (name == "alarms-subscribe") {
        std::string pattern = text(cmd, "pattern", std::string(openair::alarm_pattern));
        alarms_.emplace(next_handle_, c.alarms(pattern, text(cmd, "whiteboard")));
        out["subscription"] = next_handle_++;
    } else if (name == "await-alarm") {
        auto it = alarms_.find(integer(cmd, "subscription"));
        if (it == alarms_.end()) misuse("no such alarm subscription");
        auto alarm = it->second.next(timeout_of(cmd));
        if (!alarm) timed_out("no alarm within the timeout");
        out["alarm"] =
            json{{"kind", alarm->kind}, {"stream", alarm->stream}, {"entries", alarm->entries}};
    } else {
        return false;
    }
    return true;
}

}  // namespace openair::shim
