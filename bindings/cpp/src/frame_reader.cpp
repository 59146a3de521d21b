// The incremental, sans-I/O frame reader and the frame encoder (spec section 2).
#include <algorithm>
#include <array>
#include <cstring>

#include "numbers.hpp"
#include "openair/frame.hpp"
#include "xml.hpp"

namespace openair {

namespace {

// Compact the buffer once this many consumed bytes sit in front of the unread ones (and they
// are at least half of it): every byte is then moved at most once more, so reading stays O(n).
constexpr std::size_t compact_at = 64 * 1024;
// A size with more digits than this exceeds every receiver's binary limit (the reference
// reader's bound, kept so that both refuse the same input the same way).
constexpr std::size_t max_size_digits = 4000;
constexpr std::uint64_t max_length = 0xFFFFFFFFull;

// The first 8 header bytes of each tag: the tag (7 bytes), then the NUL (OA-FRAME-1).
struct tag_field {
    std::string_view bytes;
    frame_tag tag;
};
constexpr std::array<tag_field, 3> tag_fields{{
    {std::string_view("Message\0", 8), frame_tag::message},
    {std::string_view("Receive\0", 8), frame_tag::receive},
    {std::string_view("BinaryM\0", 8), frame_tag::binary},
}};

std::string clip(std::string_view text) {
    std::string out;
    for (char c : text.substr(0, 60)) {
        auto b = static_cast<unsigned char>(c);
        if (b >= 0x20 && b < 0x7F && c != '\\') {
            out += c;
        } else {
            char hex[8];
            std::snprintf(hex, sizeof hex, "\\x%02x", b);
            out += hex;
        }
    }
    return text.size() > 60 ? out + "..." : out;
}

/// Add two decimal digit strings (sizes may be longer than any integer type holds).
std::string add_decimal(const std::string& a, const std::string& b) {
    std::string out;
    int carry = 0;
    for (std::size_t i = 0; i < std::max(a.size(), b.size()) || carry; ++i) {
        int d = carry;
        if (i < a.size()) d += a[a.size() - 1 - i] - '0';
        if (i < b.size()) d += b[b.size() - 1 - i] - '0';
        out += static_cast<char>('0' + d % 10);
        carry = d / 10;
    }
    std::reverse(out.begin(), out.end());
    return out.empty() ? "0" : out;
}

std::string significant(std::string_view digits) {
    std::size_t first = digits.find_first_not_of('0');
    return first == std::string_view::npos ? "0" : std::string(digits.substr(first));
}

/// `text` without surrounding white space if it is a non-negative integer (OA-FRAME-4).
std::string size_value(std::string_view text, std::string_view whole) {
    std::string_view value = detail::strip_ws(text);
    if (!detail::all_digits(value)) {  // ASCII digits only, no sign (spec 1.4)
        throw error(errc::binary_sizes_invalid,
                    "'" + clip(whole) + "' is not a list of non-negative integers");
    }
    return std::string(value);
}

/// The text of the one direct child called `name` (any case); nullopt when absent.
std::optional<std::string> slot_text(const xmlNode* root, std::string_view name) {
    std::optional<std::string> found;
    for (const xmlNode* child : detail::child_elements(root)) {
        if (detail::local_name(child) != name) continue;
        if (found) {
            throw error(errc::binary_sizes_invalid, "more than one " + std::string(name) + " slot");
        }
        auto text = detail::text_only(child);
        if (!text) {
            throw error(errc::binary_sizes_invalid,
                        std::string(name) + " holds elements, not a number list");  // OA-FRAME-4
        }
        found = std::move(*text);
    }
    return found;
}

std::uint32_t read_le32(const char* p) {
    std::uint32_t v = 0;
    for (int i = 3; i >= 0; --i) v = (v << 8) | static_cast<unsigned char>(p[i]);
    return v;
}

}  // namespace

std::string_view frame_tag_name(frame_tag tag) noexcept {
    for (const tag_field& f : tag_fields) {
        if (f.tag == tag) return f.bytes.substr(0, 7);
    }
    return {};
}

std::string encode_frame(const frame& f) {
    if (f.tag == frame_tag::binary && (!f.xml.empty() || f.chunks.size() != 1)) {
        throw error(errc::api_misuse,
                    "a BinaryM frame carries one chunk and no XML");  // OA-FRAME-5
    }
    const std::string& body = f.tag == frame_tag::binary ? f.chunks.front() : f.xml;
    if (body.size() > max_length) {
        throw error(errc::api_misuse, "a frame body of " + std::to_string(body.size()) +
                                          " bytes does not fit the uint32 length");
    }
    std::string out(frame_tag_name(f.tag));
    out += '\0';  // OA-FRAME-1
    auto length = static_cast<std::uint32_t>(body.size());
    for (int i = 0; i < 4; ++i) out += static_cast<char>((length >> (8 * i)) & 0xFF);  // OA-FRAME-3
    out += body;
    if (f.tag != frame_tag::binary) {
        for (const std::string& chunk : f.chunks) out += chunk;
    }
    return out;
}

std::vector<std::uint64_t> binary_sizes(std::string_view xml, std::uint64_t max_binary) {
    static constexpr std::string_view marker = "binarysizes";
    auto it = std::search(xml.begin(), xml.end(), marker.begin(), marker.end(), [](char a, char b) {
        return (a >= 'A' && a <= 'Z' ? static_cast<char>(a - 'A' + 'a') : a) == b;
    });
    if (it == xml.end()) return {};  // fast path: no slot can exist
    detail::doc_ptr doc;
    try {
        doc = detail::parse_document(
            xml,
            xml_limits{std::max<std::size_t>(xml.size(), default_max_xml), default_max_xml_depth});
    } catch (const error&) {
        return {};  // OA-FRAME-13: unparsable XML announces no chunk
    }
    const xmlNode* root = xmlDocGetRootElement(doc.get());
    if (detail::local_name(root) != "message") return {};  // XML_MALFORMED, so OA-FRAME-13
    auto sizes_text = slot_text(root, "binarysizes");
    if (!sizes_text) return {};
    auto total_text = slot_text(root, "totalbinarysize");
    std::vector<std::string> digits;
    if (!detail::is_blank(*sizes_text)) {  // empty or blank: no chunk
        std::size_t start = 0;
        while (true) {
            std::size_t comma = sizes_text->find(',', start);
            digits.push_back(size_value(std::string_view(*sizes_text).substr(start, comma - start),
                                        *sizes_text));
            if (comma == std::string::npos) break;
            start = comma + 1;
        }
    }
    std::optional<std::string> total;
    if (total_text) total = size_value(*total_text, *total_text);
    std::string sum = "0";
    for (const std::string& d : digits) {
        std::string value = significant(d);
        if (value.size() > max_size_digits) {
            throw error(
                errc::binary_too_large,
                "a chunk size of " + std::to_string(value.size()) + " digits");  // OA-FRAME-7
        }
        sum = add_decimal(sum, value);
    }
    if (total && significant(*total) != sum) {  // OA-FRAME-4
        throw error(
            errc::binary_sizes_invalid,
            "totalbinarysize " + clip(*total) + " is not the sum of '" + clip(*sizes_text) + "'");
    }
    auto total_value = detail::parse_uint64(sum);
    if (!total_value || *total_value > max_binary) {  // OA-FRAME-7, OA-LIM-2: before any chunk
        throw error(errc::binary_too_large,
                    "binarysizes total " + clip(sum) + " exceeds " + std::to_string(max_binary));
    }
    std::vector<std::uint64_t> out;
    for (const std::string& d : digits) out.push_back(*detail::parse_uint64(significant(d)));
    return out;
}

// -- frame_reader ----------------------------------------------------------------------------

void frame_reader::throw_if_failed() const {
    if (error_) throw *error_;  // the same failure every time (OA-FRAME-9)
}

void frame_reader::fail(const error& e) {
    // Record the sticky error and drop every held byte (OA-FRAME-8, OA-FRAME-9).
    error_ = e;
    buf_.clear();
    buf_.shrink_to_fit();
    pos_ = 0;
    tag_.reset();
    sizes_.reset();
    pending_.reset();
    throw e;
}

void frame_reader::feed(std::string_view data) {
    throw_if_failed();
    if (eof_) throw error(errc::api_misuse, "feed after feed_eof");
    buf_.append(data.data(), data.size());
}

std::optional<frame> frame_reader::next() {
    throw_if_failed();
    std::optional<frame> f;
    f.swap(pending_);
    if (!f) {
        try {
            f = advance();
        } catch (const error& e) {
            fail(e);
        }
    }
    if (!f && eof_ && buffered() > 0) {
        fail(error(errc::frame_truncated,
                   std::to_string(buffered()) + " bytes of an unfinished frame"));  // OA-FRAME-8
    }
    return f;
}

void frame_reader::feed_eof() {
    throw_if_failed();
    eof_ = true;
    if (!pending_) {
        try {
            pending_ = advance();  // a complete frame stays available from next()
        } catch (const error& e) {
            fail(e);
        }
    }
    if (!pending_ && buffered() > 0) {
        fail(error(errc::frame_truncated,
                   std::to_string(buffered()) + " bytes of an unfinished frame"));  // OA-FRAME-8
    }
}

std::optional<frame> frame_reader::advance() {
    if (!tag_ && !read_header()) return std::nullopt;
    std::size_t avail = buffered();
    std::uint64_t length = read_le32(buf_.data() + pos_ + 8);
    if (avail < frame_header_size + length) return std::nullopt;
    if (!sizes_) {
        if (*tag_ == frame_tag::binary) {
            sizes_.emplace();  // the body is the chunk (OA-FRAME-5)
        } else {
            // OA-FRAME-4, OA-FRAME-13; totals above the limit refused before any chunk (OA-FRAME-7)
            sizes_ = binary_sizes(std::string_view(buf_).substr(pos_ + frame_header_size, length),
                                  limits_.max_binary);
        }
    }
    std::uint64_t end = frame_header_size + length;
    for (std::uint64_t s : *sizes_) end += s;
    if (avail < end) return std::nullopt;
    return take(length, end);
}

bool frame_reader::read_header() {
    std::size_t avail = buffered();
    std::string_view field(buf_.data() + pos_, std::min<std::size_t>(avail, 8));
    const tag_field* known = nullptr;
    bool possible = false;
    for (const tag_field& f : tag_fields) {
        if (f.bytes == field) known = &f;
        if (f.bytes.substr(0, field.size()) == field) possible = true;
    }
    if (known == nullptr) {
        // Refuse as soon as the bytes can no longer start a tag (OA-FRAME-2, OA-FRAME-6).
        if (field.size() == 8 || !possible) {
            throw error(errc::frame_unknown_tag, "frame header starts '" + clip(field) + "'");
        }
        return false;
    }
    if (avail < frame_header_size) return false;
    std::uint64_t length = read_le32(buf_.data() + pos_ + 8);  // OA-FRAME-1
    if (known->tag == frame_tag::binary && length > limits_.max_binary) {
        throw error(errc::binary_too_large,  // OA-FRAME-7, OA-LIM-2
                    "BinaryM chunk of " + std::to_string(length) + " bytes exceeds " +
                        std::to_string(limits_.max_binary));
    }
    if (known->tag != frame_tag::binary && length > limits_.max_xml) {
        throw error(errc::frame_too_large,  // OA-FRAME-7, OA-LIM-1
                    "XML of " + std::to_string(length) + " bytes exceeds " +
                        std::to_string(limits_.max_xml));
    }
    tag_ = known->tag;
    return true;
}

frame frame_reader::take(std::uint64_t length, std::uint64_t end) {
    frame f;
    f.tag = *tag_;
    std::size_t at = pos_ + frame_header_size;
    std::string body = buf_.substr(at, length);
    at += length;
    if (f.tag == frame_tag::binary) {
        f.chunks.push_back(std::move(body));
    } else {
        f.xml = std::move(body);
        for (std::uint64_t s : *sizes_) {
            f.chunks.push_back(buf_.substr(at, s));
            at += s;
        }
    }
    pos_ += end;
    tag_.reset();
    sizes_.reset();
    if (pos_ == buf_.size()) {
        buf_.clear();
        pos_ = 0;
    } else if (pos_ >= compact_at && pos_ * 2 >= buf_.size()) {
        buf_.erase(0, pos_);
        pos_ = 0;
    }
    return f;
}

}  // namespace openair
