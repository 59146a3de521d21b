// Reading `AIR.Instruct.Wakeup` (spec 8.7) and phase updates (spec 8.8), whether this kit or
// Psyclone 1.1.7 wrote them.
#include <map>

#include "codec_internal.hpp"
#include "numbers.hpp"
#include "openair/content.hpp"
#include "openair/error.hpp"
#include "xml.hpp"

namespace openair {

namespace {

[[noreturn]] void invalid(const std::string& detail) {
    throw error(errc::content_invalid, detail);
}

/// The objects of an objectdictionary by name; an empty object maps to nullptr.
std::map<std::string, const xmlNode*> objects(const xmlNode* dict) {
    std::map<std::string, const xmlNode*> found;
    for (const xmlNode* obj : detail::child_elements(dict)) {
        if (detail::local_name(obj) != "object") {
            invalid("<objectdictionary> holds <" + detail::local_name(obj) + ">");
        }
        auto name = detail::attr(obj, "name");
        if (!name) invalid("wakeup object without a name");
        std::vector<xmlNode*> inner = detail::child_elements(obj);
        if (inner.size() > 1) invalid("object '" + *name + "' must hold exactly one element");
        if (!found.emplace(*name, inner.empty() ? nullptr : inner.front()).second) {
            invalid("wakeup object '" + *name + "' appears twice");
        }
    }
    return found;
}

std::optional<message> read_trigger(const xmlNode* el, detail::chunk_cursor& cursor) {
    if (el == nullptr) return std::nullopt;
    if (detail::local_name(el) != "message") {
        invalid("TriggerMessage holds <" + detail::local_name(el) + ">, not a message");
    }
    std::vector<std::string> chunks = cursor.take(el);  // OA-WAKE-10: the trigger's come first
    try {
        return detail::decode_element(el, std::move(chunks));  // OA-WAKE-2: the stored copy
    } catch (const error& e) {
        invalid("TriggerMessage: " + e.detail());
    }
}

/// Read the PhaseSpec `<phase>` leniently: a server may echo patterns this kit would refuse.
std::optional<phase_spec> read_phase(const xmlNode* el) {
    if (el == nullptr) return std::nullopt;
    if (detail::local_name(el) != "phase") {
        invalid("PhaseSpec holds <" + detail::local_name(el) + ">, not a phase");
    }
    phase_spec p;
    p.name = detail::attr(el, "name").value_or(detail::attr(el, "id").value_or(""));
    p.module = detail::attr(el, "module").value_or("");
    p.context = detail::attr(el, "context").value_or(std::string(default_context));
    p.lasttrigger = detail::attr(el, "lasttrigger").value_or("");  // OA-WAKE-4
    for (const xmlNode* group : detail::child_elements(el)) {
        if (detail::local_name(group) != "triggers") continue;
        std::string group_from = detail::attr(group, "from").value_or("");
        for (const xmlNode* t : detail::child_elements(group)) {
            if (detail::local_name(t) != "trigger") continue;
            trigger trig;
            trig.type = detail::attr(t, "type").value_or("");
            trig.from = detail::attr(t, "from").value_or(group_from);
            std::string lowered = detail::ascii_lower(trig.from);
            if (lowered == "any" || lowered == "*") trig.from.clear();  // OA-TRIG-2
            auto after = detail::attr(t, "after");
            if (!after) after = detail::attr(t, "delay");  // OA-TRIG-3
            trig.after_ms = detail::parse_uint64(after.value_or("0")).value_or(0);
            trig.alias = detail::attr(t, "alias").value_or("");
            p.triggers.push_back(std::move(trig));
        }
    }
    return p;
}

}  // namespace

wakeup parse_wakeup(const message& msg) {
    if (msg.type != wakeup_type) invalid("'" + msg.type + "' is not AIR.Instruct.Wakeup");
    detail::fragment frag;
    try {
        frag = detail::parse_fragment(msg.content);
    } catch (const error& e) {
        invalid("wakeup content is not well-formed XML: " + e.detail());
    }
    wakeup w;
    detail::chunk_cursor cursor(msg.binary);  // attachments (OA-WAKE-10, OA-MSG-21)
    if (frag.elements.empty()) {
        cursor.finish();
        return w;  // a phase update without a phase (spec 8.8)
    }
    if (frag.elements.size() != 1 ||
        detail::local_name(frag.elements.front()) != "objectdictionary") {
        invalid("wakeup content must be one <objectdictionary>");  // OA-WAKE-1
    }
    auto found = objects(frag.elements.front());
    auto get = [&found](const char* name) -> const xmlNode* {
        auto it = found.find(name);
        return it == found.end() ? nullptr : it->second;
    };
    w.trigger = read_trigger(get("TriggerMessage"), cursor);
    if (const xmlNode* retrieved = get("RetrievedMessages")) {
        w.retrieved = detail::read_message_collection(retrieved, &cursor);  // OA-WAKE-3
    }
    cursor.finish();
    w.phase = read_phase(get("PhaseSpec"));
    if (w.phase) w.lasttrigger = w.phase->lasttrigger;
    return w;
}

}  // namespace openair
