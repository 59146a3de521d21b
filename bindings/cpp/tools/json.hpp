// The tests' JSON values (the vector manifests of spec/vectors): a small read-only value tree,
// parsed and written by nlohmann/json (json.cpp). Not part of the client library; the shim uses
// nlohmann/json directly.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace openair::json {

class value;
using array = std::vector<value>;
/// Members in document order (lookups are linear; the objects here are small).
using object = std::vector<std::pair<std::string, value>>;

/// A malformed document, or a value of the wrong kind.
struct json_error : std::runtime_error {
    using std::runtime_error::runtime_error;
};

class value {
public:
    enum class kind { null, boolean, integer, number, string, array, object };

    value() = default;
    value(std::nullptr_t) {}
    value(bool b) : kind_(kind::boolean), bool_(b) {}
    value(int i) : kind_(kind::integer), int_(i) {}
    value(std::int64_t i) : kind_(kind::integer), int_(i) {}
    value(std::uint64_t i) : kind_(kind::integer), int_(static_cast<std::int64_t>(i)) {}
    value(double d) : kind_(kind::number), num_(d) {}
    value(const char* s) : kind_(kind::string), str_(s) {}
    value(std::string s) : kind_(kind::string), str_(std::move(s)) {}
    value(std::string_view s) : kind_(kind::string), str_(s) {}
    value(array a) : kind_(kind::array), arr_(std::make_shared<array>(std::move(a))) {}
    value(object o) : kind_(kind::object), obj_(std::make_shared<object>(std::move(o))) {}

    [[nodiscard]] kind type() const noexcept { return kind_; }
    [[nodiscard]] bool is_null() const noexcept { return kind_ == kind::null; }
    [[nodiscard]] bool is_string() const noexcept { return kind_ == kind::string; }
    [[nodiscard]] bool is_number() const noexcept {
        return kind_ == kind::integer || kind_ == kind::number;
    }

    [[nodiscard]] bool as_bool() const;
    [[nodiscard]] std::int64_t as_int() const;
    [[nodiscard]] double as_double() const;
    [[nodiscard]] const std::string& as_string() const;
    [[nodiscard]] const array& as_array() const;
    [[nodiscard]] const object& as_object() const;

    /// The member `key` of an object, or nullptr when absent (or this is not an object).
    [[nodiscard]] const value* find(std::string_view key) const;
    /// The member `key`; throws json_error when absent.
    [[nodiscard]] const value& at(std::string_view key) const;
    /// Shorthands for optional members with defaults.
    [[nodiscard]] std::string get_string(std::string_view key, const std::string& dflt = "") const;
    [[nodiscard]] bool get_bool(std::string_view key, bool dflt) const;
    [[nodiscard]] std::int64_t get_int(std::string_view key, std::int64_t dflt) const;

private:
    kind kind_ = kind::null;
    bool bool_ = false;
    std::int64_t int_ = 0;
    double num_ = 0.0;
    std::string str_;
    std::shared_ptr<const array> arr_;
    std::shared_ptr<const object> obj_;
};

/// Parse one JSON document (RFC 8259, surrounding white space allowed); throws json_error.
/// Integers that fit std::int64_t are integers, other numbers doubles.
[[nodiscard]] value parse(std::string_view text);
/// Write `v` compactly on one line; non-ASCII characters are written as UTF-8, control
/// characters as escapes. Bytes that are not UTF-8 are written as U+FFFD.
[[nodiscard]] std::string dump(const value& v);

}  // namespace openair::json
