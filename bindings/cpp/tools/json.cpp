#include "json.hpp"

#include <charconv>
#include <cmath>
#include <cstdio>

namespace openair::json {

// -- value -----------------------------------------------------------------------------------

namespace {
[[noreturn]] void wrong(const char* wanted) {
    throw json_error(std::string("JSON value is not ") + wanted);
}
}  // namespace

bool value::as_bool() const {
    if (kind_ != kind::boolean) wrong("a boolean");
    return bool_;
}

std::int64_t value::as_int() const {
    if (kind_ == kind::integer) return int_;
    if (kind_ == kind::number && std::floor(num_) == num_ && std::fabs(num_) < 9.2e18) {
        return static_cast<std::int64_t>(num_);
    }
    wrong("an integer");
}

double value::as_double() const {
    if (kind_ == kind::integer) return static_cast<double>(int_);
    if (kind_ != kind::number) wrong("a number");
    return num_;
}

const std::string& value::as_string() const {
    if (kind_ != kind::string) wrong("a string");
    return str_;
}

const array& value::as_array() const {
    if (kind_ != kind::array) wrong("an array");
    return *arr_;
}

const object& value::as_object() const {
    if (kind_ != kind::object) wrong("an object");
    return *obj_;
}

const value* value::find(std::string_view key) const {
    if (kind_ != kind::object) return nullptr;
    for (const auto& [k, v] : *obj_) {
        if (k == key) return &v;
    }
    return nullptr;
}

const value& value::at(std::string_view key) const {
    const value* v = find(key);
    if (v == nullptr) throw json_error("missing member '" + std::string(key) + "'");
    return *v;
}

std::string value::get_string(std::string_view key, const std::string& dflt) const {
    const value* v = find(key);
    return v == nullptr || v->is_null() ? dflt : v->as_string();
}

bool value::get_bool(std::string_view key, bool dflt) const {
    const value* v = find(key);
    return v == nullptr || v->is_null() ? dflt : v->as_bool();
}

std::int64_t value::get_int(std::string_view key, std::int64_t dflt) const {
    const value* v = find(key);
    return v == nullptr || v->is_null() ? dflt : v->as_int();
}

// -- parsing ---------------------------------------------------------------------------------

namespace {

class parser {
public:
    explicit parser(std::string_view text) : s_(text) {}

    value document() {
        value v = parse_value(0);
        skip_ws();
        if (i_ != s_.size()) fail("trailing characters");
        return v;
    }

private:
    [[noreturn]] void fail(const std::string& why) const {
        throw json_error("JSON: " + why + " at offset " + std::to_string(i_));
    }

    void skip_ws() {
        while (i_ < s_.size() &&
               (s_[i_] == ' ' || s_[i_] == '\t' || s_[i_] == '\n' || s_[i_] == '\r')) {
            ++i_;
        }
    }

    bool literal(std::string_view word) {
        if (s_.substr(i_, word.size()) != word) return false;
        i_ += word.size();
        return true;
    }

    value parse_value(int depth) {
        if (depth > 200) fail("nesting too deep");
        skip_ws();
        if (i_ >= s_.size()) fail("unexpected end");
        char c = s_[i_];
        if (c == '{') return parse_object(depth);
        if (c == '[') return parse_array(depth);
        if (c == '"') return value(parse_string());
        if (literal("true")) return value(true);
        if (literal("false")) return value(false);
        if (literal("null")) return value(nullptr);
        return parse_number();
    }

    value parse_object(int depth) {
        ++i_;
        object members;
        skip_ws();
        if (i_ < s_.size() && s_[i_] == '}') {
            ++i_;
            return value(std::move(members));
        }
        while (true) {
            skip_ws();
            if (i_ >= s_.size() || s_[i_] != '"') fail("expected a member name");
            std::string key = parse_string();
            skip_ws();
            if (i_ >= s_.size() || s_[i_] != ':') fail("expected ':'");
            ++i_;
            members.emplace_back(std::move(key), parse_value(depth + 1));
            skip_ws();
            if (i_ < s_.size() && s_[i_] == ',') {
                ++i_;
                continue;
            }
            if (i_ < s_.size() && s_[i_] == '}') {
                ++i_;
                return value(std::move(members));
            }
            fail("expected ',' or '}'");
        }
    }

    value parse_array(int depth) {
        ++i_;
        array items;
        skip_ws();
        if (i_ < s_.size() && s_[i_] == ']') {
            ++i_;
            return value(std::move(items));
        }
        while (true) {
            items.push_back(parse_value(depth + 1));
            skip_ws();
            if (i_ < s_.size() && s_[i_] == ',') {
                ++i_;
                continue;
            }
            if (i_ < s_.size() && s_[i_] == ']') {
                ++i_;
                return value(std::move(items));
            }
            fail("expected ',' or ']'");
        }
    }

    unsigned hex4() {
        if (i_ + 4 > s_.size()) fail("short \\u escape");
        unsigned v = 0;
        for (int k = 0; k < 4; ++k) {
            char c = s_[i_++];
            v <<= 4;
            if (c >= '0' && c <= '9')
                v |= static_cast<unsigned>(c - '0');
            else if (c >= 'a' && c <= 'f')
                v |= static_cast<unsigned>(c - 'a' + 10);
            else if (c >= 'A' && c <= 'F')
                v |= static_cast<unsigned>(c - 'A' + 10);
            else
                fail("bad \\u escape");
        }
        return v;
    }

    static void put_utf8(std::string& out, unsigned cp) {
        if (cp < 0x80) {
            out += static_cast<char>(cp);
        } else if (cp < 0x800) {
            out += static_cast<char>(0xC0 | (cp >> 6));
            out += static_cast<char>(0x80 | (cp & 0x3F));
        } else if (cp < 0x10000) {
            out += static_cast<char>(0xE0 | (cp >> 12));
            out += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
            out += static_cast<char>(0x80 | (cp & 0x3F));
        } else {
            out += static_cast<char>(0xF0 | (cp >> 18));
            out += static_cast<char>(0x80 | ((cp >> 12) & 0x3F));
            out += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
            out += static_cast<char>(0x80 | (cp & 0x3F));
        }
    }

    std::string parse_string() {
        ++i_;  // the opening quote
        std::string out;
        while (true) {
            if (i_ >= s_.size()) fail("unterminated string");
            char c = s_[i_++];
            if (c == '"') return out;
            if (static_cast<unsigned char>(c) < 0x20) fail("control character in a string");
            if (c != '\\') {
                out += c;
                continue;
            }
            if (i_ >= s_.size()) fail("unterminated escape");
            char e = s_[i_++];
            switch (e) {
                case '"': out += '"'; break;
                case '\\': out += '\\'; break;
                case '/': out += '/'; break;
                case 'b': out += '\b'; break;
                case 'f': out += '\f'; break;
                case 'n': out += '\n'; break;
                case 'r': out += '\r'; break;
                case 't': out += '\t'; break;
                case 'u': {
                    unsigned cp = hex4();
                    if (cp >= 0xD800 && cp <= 0xDBFF && s_.substr(i_, 2) == "\\u") {
                        std::size_t save = i_;
                        i_ += 2;
                        unsigned low = hex4();
                        if (low >= 0xDC00 && low <= 0xDFFF) {
                            cp = 0x10000 + ((cp - 0xD800) << 10) + (low - 0xDC00);
                        } else {
                            i_ = save;
                        }
                    }
                    put_utf8(out, cp);
                    break;
                }
                default: fail("bad escape");
            }
        }
    }

    value parse_number() {
        std::size_t start = i_;
        if (i_ < s_.size() && s_[i_] == '-') ++i_;
        bool integral = true;
        while (i_ < s_.size()) {
            char c = s_[i_];
            if (c >= '0' && c <= '9') {
                ++i_;
            } else if (c == '.' || c == 'e' || c == 'E' || c == '+' || c == '-') {
                integral = false;
                ++i_;
            } else {
                break;
            }
        }
        std::string_view text = s_.substr(start, i_ - start);
        if (text.empty() || text == "-") fail("unexpected character");
        if (integral) {
            std::int64_t v = 0;
            auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
            if (ec == std::errc() && end == text.data() + text.size()) return value(v);
        }
        double d = 0.0;
        auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), d);
        if (ec != std::errc() || end != text.data() + text.size()) fail("bad number");
        return value(d);
    }

    std::string_view s_;
    std::size_t i_ = 0;
};

void dump_string(std::string& out, const std::string& s) {
    out += '"';
    for (std::size_t i = 0; i < s.size(); ++i) {
        auto b = static_cast<unsigned char>(s[i]);
        switch (b) {
            case '"': out += "\\\""; continue;
            case '\\': out += "\\\\"; continue;
            case '\n': out += "\\n"; continue;
            case '\r': out += "\\r"; continue;
            case '\t': out += "\\t"; continue;
            default: break;
        }
        if (b < 0x20 || b == 0x7F) {
            char esc[8];
            std::snprintf(esc, sizeof esc, "\\u%04x", b);
            out += esc;
            continue;
        }
        if (b < 0x80) {
            out += static_cast<char>(b);
            continue;
        }
        // Copy a valid UTF-8 sequence; replace anything else with U+FFFD.
        std::size_t len = b >= 0xF0 ? 4 : b >= 0xE0 ? 3 : b >= 0xC2 ? 2 : 0;
        bool ok = len != 0 && b <= 0xF4 && i + len <= s.size();
        for (std::size_t k = 1; ok && k < len; ++k)
            ok = (static_cast<unsigned char>(s[i + k]) & 0xC0) == 0x80;
        if (ok) {
            out.append(s, i, len);
            i += len - 1;
        } else {
            out += "\xEF\xBF\xBD";
        }
    }
    out += '"';
}

void dump_into(std::string& out, const value& v) {
    switch (v.type()) {
        case value::kind::null: out += "null"; break;
        case value::kind::boolean: out += v.as_bool() ? "true" : "false"; break;
        case value::kind::integer: out += std::to_string(v.as_int()); break;
        case value::kind::number: {
            double d = v.as_double();
            if (!std::isfinite(d)) {
                out += "null";
                break;
            }
            char buf[64];
            auto [end, ec] = std::to_chars(buf, buf + sizeof buf, d);
            std::string text(buf, ec == std::errc() ? end : buf);
            if (text.find_first_of(".eE") == std::string::npos) text += ".0";
            out += text;
            break;
        }
        case value::kind::string: dump_string(out, v.as_string()); break;
        case value::kind::array: {
            out += '[';
            bool first = true;
            for (const value& item : v.as_array()) {
                if (!first) out += ", ";
                first = false;
                dump_into(out, item);
            }
            out += ']';
            break;
        }
        case value::kind::object: {
            out += '{';
            bool first = true;
            for (const auto& [key, item] : v.as_object()) {
                if (!first) out += ", ";
                first = false;
                dump_string(out, key);
                out += ": ";
                dump_into(out, item);
            }
            out += '}';
            break;
        }
    }
}

}  // namespace

value parse(std::string_view text) {
    return parser(text).document();
}

std::string dump(const value& v) {
    std::string out;
    dump_into(out, v);
    return out;
}

}  // namespace openair::json
