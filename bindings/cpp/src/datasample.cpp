// The datasample chunk codec (spec 11.2): 4-byte little-endian payload length, the payload,
// `key%equals%value%sep%…` in ASCII, one NUL. No I/O.
#include "openair/datasample.hpp"

#include <limits>

#include "numbers.hpp"
#include "openair/error.hpp"

namespace openair {

namespace {

constexpr std::string_view sep = "%sep%";
constexpr std::string_view equals = "%equals%";
constexpr std::size_t min_chunk = 5;  // the length field and the NUL

bool ends_with(std::string_view s, std::string_view end) {
    return s.size() >= end.size() && s.substr(s.size() - end.size()) == end;
}

bool starts_with(std::string_view s, std::string_view start) {
    return s.substr(0, start.size()) == start;
}

std::string clip(std::string_view s) {
    return std::string(s.substr(0, 80));
}

std::string text_problem(std::string_view text, const char* what) {
    for (char ch : text) {
        auto byte = static_cast<unsigned char>(ch);
        if (byte >= 0x80) return std::string(what) + " '" + clip(text) + "' is not ASCII";
        if (byte == 0) return std::string(what) + " '" + clip(text) + "' holds a NUL";
    }
    if (text.find(sep) != std::string_view::npos || text.find(equals) != std::string_view::npos) {
        return std::string(what) + " '" + clip(text) + "' holds a separator (%sep% or %equals%)";
    }
    return {};
}

std::optional<std::int64_t> integer_param(const data_sample& s, std::string_view key) {
    auto value = s.param(key);
    if (!value) return std::nullopt;
    return detail::parse_int64(*value, true, false);
}

}  // namespace

std::string param_problem(std::string_view key, std::string_view value) {
    if (key.empty()) return "empty key";
    if (std::string p = text_problem(key, "key"); !p.empty()) return p;
    if (std::string p = text_problem(value, "value"); !p.empty()) return p;
    // A '%' at an edge would run into the separator beside it (spec/vectors/samples/README.md).
    if (ends_with(key, "%sep") || ends_with(key, "%equals")) {
        return "key '" + clip(key) + "' ends with '%sep' or '%equals'";
    }
    if (value == "sep" || starts_with(value, "sep%") || ends_with(value, "%sep")) {
        return "value '" + clip(value) + "' is 'sep', starts with 'sep%' or ends with '%sep'";
    }
    return {};
}

std::string encode_params(const sample_params& params) {
    std::string out;
    for (const auto& [key, value] : params) {
        std::string problem = param_problem(key, value);  // OA-STREAM-2
        if (!problem.empty()) throw error(errc::api_misuse, "sample parameter: " + problem);
        if (!out.empty()) out += sep;
        out += key;
        out += equals;
        out += value;
    }
    return out;
}

sample_params decode_params(std::string_view text, std::size_t max_params) {
    sample_params out;
    if (text.empty()) return out;
    for (char ch : text) {
        if (static_cast<unsigned char>(ch) >= 0x80) {  // OA-STREAM-10
            throw error(errc::sample_invalid, "sample parameters are not ASCII");
        }
        if (ch == '\0') {  // OA-STREAM-2: one NUL, at the very end
            throw error(errc::sample_invalid, "sample parameters hold a NUL before the last byte");
        }
    }
    std::size_t start = 0;
    while (true) {
        std::size_t end = text.find(sep, start);
        std::size_t length = end == std::string_view::npos ? end : end - start;
        std::string_view pair = text.substr(start, length);
        if (out.size() >= max_params) {
            throw error(errc::sample_invalid,
                        "more than " + std::to_string(max_params) + " sample parameters");
        }
        std::size_t eq = pair.find(equals);
        if (eq == std::string_view::npos) {  // OA-STREAM-10: key%equals%value pairs
            throw error(errc::sample_invalid,
                        "sample parameter '" + clip(pair) + "' has no %equals%");
        }
        std::string_view key = pair.substr(0, eq);
        std::string_view value = pair.substr(eq + equals.size());
        std::string problem = param_problem(key, value);  // OA-STREAM-10
        if (!problem.empty()) throw error(errc::sample_invalid, "sample parameter: " + problem);
        out.emplace_back(std::string(key), std::string(value));
        if (end == std::string_view::npos) break;
        start = end + sep.size();
    }
    return out;
}

chunk_parts make_chunk_parts(bytes_view payload, const sample_params& params) {
    if (payload.size() > std::numeric_limits<std::uint32_t>::max()) {  // OA-STREAM-2
        throw error(errc::api_misuse, "a sample payload of " + std::to_string(payload.size()) +
                                          " bytes does not fit the 32-bit length");
    }
    chunk_parts parts;
    auto n = static_cast<std::uint32_t>(payload.size());
    for (int i = 0; i < 4; ++i) parts.head += static_cast<char>((n >> (8 * i)) & 0xFF);
    parts.payload = payload;
    parts.tail = encode_params(params);
    parts.tail += '\0';
    return parts;
}

std::string encode_chunk(bytes_view payload, const sample_params& params) {
    chunk_parts parts = make_chunk_parts(payload, params);
    std::string out;
    out.reserve(parts.size());
    out += parts.head;
    out += payload.chars();
    out += parts.tail;
    return out;
}

data_sample data_sample::decode(std::string chunk, std::size_t max_params) {
    std::size_t total = chunk.size();
    if (total < min_chunk) {  // OA-STREAM-10
        throw error(errc::sample_invalid, "datasample chunk of " + std::to_string(total) +
                                              " bytes is shorter than 5 bytes");
    }
    std::uint64_t size = 0;
    for (int i = 3; i >= 0; --i) size = (size << 8) | static_cast<unsigned char>(chunk[i]);
    if (size > total - min_chunk) {  // OA-STREAM-10: shorter than 5 + N
        throw error(errc::sample_invalid, "datasample chunk of " + std::to_string(total) +
                                              " bytes is too short for its payload length " +
                                              std::to_string(size));
    }
    if (chunk.back() != '\0') {  // OA-STREAM-10: the last byte is NUL
        throw error(errc::sample_invalid, "datasample chunk does not end with a NUL byte");
    }
    data_sample s;
    std::string_view params(chunk.data() + payload_offset + size,
                            total - payload_offset - size - 1);
    s.params_ = decode_params(params, max_params);
    s.payload_size_ = static_cast<std::size_t>(size);
    s.chunk_ = std::move(chunk);
    return s;
}

std::optional<std::string> data_sample::param(std::string_view key) const {
    for (const auto& [k, v] : params_) {
        if (k == key) return v;
    }
    return std::nullopt;
}

std::optional<std::int64_t> data_sample::id() const { return integer_param(*this, builtin_id); }

std::optional<std::int64_t> data_sample::timestamp_ms() const {
    return integer_param(*this, builtin_timestamp);
}

std::optional<std::int64_t> data_sample::seq() const { return integer_param(*this, builtin_seq); }

}  // namespace openair
