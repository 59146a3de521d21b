// Stream requests and replies as values, without I/O (spec section 11); see stream_wire.hpp.
#include "stream_wire.hpp"

#include "codec_internal.hpp"
#include "numbers.hpp"
#include "openair/client.hpp"
#include "openair/error.hpp"
#include "test_faults.hpp"
#include "xml.hpp"

namespace openair::detail {

namespace {

constexpr std::string_view alarm_prefix = "AIR.Stream.Alarm.";

fragment content_of(std::string_view content) {
    try {
        return parse_fragment(content);
    } catch (const error& e) {
        throw error(errc::content_invalid, "content is not well-formed XML: " + e.detail());
    }
}

const xmlNode* root_of(const fragment& frag, std::string_view name) {
    if (frag.elements.size() != 1 || local_name(frag.elements.front()) != name) {
        throw error(errc::content_invalid, "content must be one <" + std::string(name) + ">");
    }
    return frag.elements.front();
}

std::size_t count_datasamples(const xmlNode* n) {
    std::size_t found = local_name(n) == "datasample" ? 1 : 0;
    for (const xmlNode* child : child_elements(n)) found += count_datasamples(child);
    return found;
}

void set_builtin(sample_params& params, std::string_view key, std::int64_t value) {
    if (value < 0) throw error(errc::api_misuse, std::string(key) + " must not be negative");
    std::string text = std::to_string(value);
    bool done = false;
    for (auto it = params.begin(); it != params.end();) {
        if (it->first != key) {
            ++it;
        } else if (!done) {
            it->second = text;  // in place of the first of that key
            done = true;
            ++it;
        } else {
            it = params.erase(it);  // further ones removed
        }
    }
    if (!done) params.emplace_back(std::string(key), text);
}

}  // namespace

message media_request(const std::string& target, const std::string& sender,
                      const std::string& type, std::string content, bool xml) {
    message m = make_message(type, sender, target);
    m.content = std::move(content);
    m.content_is_xml = xml;
    if (xml) m.language = "xml";
    return m;
}

message add_request(const std::string& target, const std::string& sender, std::size_t count) {
    if (count == 0) throw error(errc::api_misuse, "adding samples needs at least one sample");
    if (count == 1) return media_request(target, sender, "ADD_SAMPLE", datasample_xml, true);
    std::string body = "<objectcollection>";
    for (std::size_t i = 0; i < count; ++i) body += "<object><datasample/></object>";
    body += "</objectcollection>";
    return media_request(target, sender, "ADD_SAMPLES", std::move(body), true);
}

sample_params params_for(const sample_options& options) {
    sample_params params = options.params;
    if (OPENAIR_FAULT(builtins_first)) params.clear();  // test-only fault: builtins go first
    if (options.timestamp_ms) set_builtin(params, builtin_timestamp, *options.timestamp_ms);
    if (options.seq) set_builtin(params, builtin_seq, *options.seq);  // OA-XSTREAM-8
    if (OPENAIR_FAULT(builtins_first)) {
        params.insert(params.end(), options.params.begin(), options.params.end());
    }
    return params;
}

std::string wait_type(bool by_id, bool last, std::int64_t timeout_ms) {
    if (timeout_ms < 0) throw error(errc::api_misuse, "a wait timeout must not be negative");
    return std::string("WAIT_FOR_") + (last ? "LAST_" : "FIRST_") +
           (by_id ? "AFTERID " : "SAMPLE ") + std::to_string(timeout_ms);
}

std::string time_content(std::int64_t ms) {
    if (ms < 0) throw error(errc::api_misuse, "a time must not be negative");
    return "<time sec=\"" + std::to_string(ms / 1000) + "\" msec=\"" + std::to_string(ms % 1000) +
           "\"/>";
}

std::string range_content(std::int64_t from_ms, std::int64_t until_ms) {
    return "<objectcollection><object>" + time_content(from_ms) + "</object><object>" +
           time_content(until_ms) + "</object></objectcollection>";
}

std::string search_content(const sample_search& query) {
    std::string out;
    xml_writer w(out);
    w.open("samplesearch");
    if (query.after_ms) w.text_element("afterTime", std::to_string(*query.after_ms));
    if (query.until_ms) w.text_element("untilTime", std::to_string(*query.until_ms));
    for (const auto& [key, glob] : query.params) {
        w.open("param");
        w.attribute("name", key, "search parameter name");
        w.text(glob, "search parameter glob");
        w.close();
    }
    if (query.latest != 0) w.text_element("latest", std::to_string(query.latest));
    w.close();
    return out;
}

void raise_for(const message& sent, const message& reply) {
    request_failed failed(sent, reply);
    if (auto code = failed.condition()) {  // OA-ERR-2: `NAME: detail`
        std::string_view content = reply.content;
        std::size_t colon = content.find(':');
        std::string detail_text = colon == std::string_view::npos
                                      ? std::string()
                                      : std::string(strip_ws(content.substr(colon + 1)));
        throw error(*code, detail_text.empty() ? reply.type : detail_text);
    }
    if (reply.type == "UNKNOWN_COMMAND") throw error(errc::command_unknown, reply.content);
    throw failed;
}

const message& expect_reply(const message& sent, const message& reply, const char* type) {
    if (reply.type != type) raise_for(sent, reply);
    return reply;
}

std::uint64_t integer_of(const message& reply, const char* what) {
    auto value = parse_uint64(reply.content);
    if (!value) {
        throw error(errc::content_invalid, reply.type + ": " + what + " '" +
                                               reply.content.substr(0, 40) + "' is not a count");
    }
    return *value;
}

std::vector<std::uint64_t> ids_of(const std::string& content) {
    fragment frag = content_of(content);
    std::vector<std::uint64_t> ids;
    for (const xmlNode* entry : child_elements(root_of(frag, "collection"))) {
        auto id = parse_uint64(inner_text(entry));
        if (local_name(entry) != "entry" || !id) {
            throw error(errc::content_invalid, "DATA_ACCEPTED: a bad collection entry");
        }
        ids.push_back(*id);
    }
    return ids;
}

std::int64_t timestamp_of(const message& reply) {
    fragment frag = content_of(reply.content);
    if (frag.elements.size() != 1) {
        throw error(errc::content_invalid, "TIMESTAMP: one time element");
    }
    return read_time(frag.elements.front()).ms();
}

namespace {

stream_info info_of(const xmlNode* el);

}  // namespace

stream_info stream_info_of(const std::string& content) {
    fragment frag = content_of(content);
    return info_of(root_of(frag, "streaminfo"));
}

std::vector<stream_info> stream_list_of(const std::string& content) {
    std::vector<stream_info> out;
    if (is_blank(content)) return out;
    fragment frag = content_of(content);
    for (const xmlNode* el : child_elements(root_of(frag, "streams"))) {
        if (local_name(el) != "streaminfo") {
            throw error(errc::content_invalid, "<streams> holds <" + local_name(el) + ">");
        }
        out.push_back(info_of(el));
    }
    return out;
}

namespace {

stream_info info_of(const xmlNode* el) {
    stream_info info;
    auto name = attr(el, "name");
    if (!name || name->empty()) throw error(errc::content_invalid, "<streaminfo> without a name");
    info.name = *name;
    info.whiteboard = attr(el, "whiteboard").value_or("");
    info.type = attr(el, "type").value_or("");
    auto number = [&](const char* key) -> std::optional<std::uint64_t> {
        auto text = attr(el, key);
        if (!text) return std::nullopt;
        auto value = parse_uint64(*text);
        if (!value) {
            throw error(errc::content_invalid,
                        std::string("<streaminfo ") + key + "> is not a non-negative integer");
        }
        return value;
    };
    info.count = number("count").value_or(0);
    info.size = number("size").value_or(0);
    info.oldest = number("oldest");
    info.newest = number("newest");
    info.maxsize = number("maxsize").value_or(0);
    info.maxcount = number("maxcount").value_or(0);
    info.softsize = number("softsize");
    info.softcount = number("softcount");
    info.hardsize = number("hardsize");
    info.hardcount = number("hardcount");
    info.idle = number("idle");
    info.subscribers = number("subscribers").value_or(0);
    info.writers = number("writers").value_or(0);
    info.locked = number("locked").value_or(0);
    return info;
}

}  // namespace

data_sample sample_of(message msg) {
    if (msg.binary.size() != 1) {
        throw error(errc::sample_invalid, msg.type + " carries " +
                                              std::to_string(msg.binary.size()) + " chunks, not 1");
    }
    return data_sample::decode(std::move(msg.binary.front()));
}

std::vector<data_sample> samples_of(message msg) {
    std::size_t marked = 0;
    if (!is_blank(msg.content)) {
        marked = count_datasamples(root_of(content_of(msg.content), "objectcollection"));
    }
    if (marked != msg.binary.size()) {
        throw error(errc::content_invalid, msg.type + " names " + std::to_string(marked) +
                                               " datasample(s) but carries " +
                                               std::to_string(msg.binary.size()) + " chunk(s)");
    }
    std::vector<data_sample> out;
    out.reserve(msg.binary.size());
    for (std::string& chunk : msg.binary) out.push_back(data_sample::decode(std::move(chunk)));
    return out;
}

received_sample received_sample_of(message msg, std::int64_t received_ns) {
    std::uint64_t dropped = 0;
    if (const slot* s = msg.extra("dropped")) {  // OA-STREAM-8
        auto value = parse_uint64(s->value);
        if (!value) throw error(errc::content_invalid, "dropped '" + s->value + "' is not a count");
        dropped = *value;
    }
    std::string from = msg.sender;
    return received_sample{std::move(from), sample_of(std::move(msg)), dropped, received_ns};
}

bool is_alarm(const message& msg) {
    return msg.type.size() > alarm_prefix.size() &&
           std::string_view(msg.type).substr(0, alarm_prefix.size()) == alarm_prefix;
}

stream_alarm alarm_of(const message& msg) {
    if (!is_alarm(msg)) throw error(errc::content_invalid, msg.type + " is not a stream alarm");
    stream_alarm alarm;
    alarm.kind = msg.type.substr(alarm_prefix.size());
    alarm.msg = msg;
    if (!is_blank(msg.content)) {
        fragment frag = content_of(msg.content);
        for (const xmlNode* entry : child_elements(root_of(frag, "dictionary"))) {
            auto name = attr(entry, "name");
            if (local_name(entry) != "entry" || !name) {
                throw error(errc::content_invalid, "an alarm's dictionary holds a bad entry");
            }
            alarm.entries.emplace(*name, inner_text(entry));
        }
    }
    auto named = alarm.entries.find("stream");
    bool given = named != alarm.entries.end() && !named->second.empty();
    alarm.stream = given ? named->second : msg.sender;
    return alarm;
}

}  // namespace openair::detail
