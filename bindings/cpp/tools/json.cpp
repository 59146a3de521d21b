#include "json.hpp"

#include <cmath>
#include <cstdint>

#include <nlohmann/json.hpp>

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

// -- parsing and writing, by nlohmann/json ------------------------------------------------------

namespace {

using njson = nlohmann::ordered_json;

value from_njson(const njson& j) {
    switch (j.type()) {
        case njson::value_t::null: return value(nullptr);
        case njson::value_t::boolean: return value(j.get<bool>());
        case njson::value_t::number_integer: return value(j.get<std::int64_t>());
        case njson::value_t::number_unsigned: {
            auto u = j.get<std::uint64_t>();
            // Beyond std::int64_t: a double, as any other number that is not an integer.
            if (u > static_cast<std::uint64_t>(INT64_MAX)) return value(static_cast<double>(u));
            return value(static_cast<std::int64_t>(u));
        }
        case njson::value_t::number_float: return value(j.get<double>());
        case njson::value_t::string: return value(j.get_ref<const std::string&>());
        case njson::value_t::array: {
            array items;
            items.reserve(j.size());
            for (const njson& item : j) items.push_back(from_njson(item));
            return value(std::move(items));
        }
        case njson::value_t::object: {
            object members;
            members.reserve(j.size());
            for (const auto& [key, item] : j.items()) members.emplace_back(key, from_njson(item));
            return value(std::move(members));
        }
        default: throw json_error("JSON: not a JSON value");
    }
}

njson to_njson(const value& v) {
    switch (v.type()) {
        case value::kind::null: return nullptr;
        case value::kind::boolean: return v.as_bool();
        case value::kind::integer: return v.as_int();
        case value::kind::number: return v.as_double();
        case value::kind::string: return v.as_string();
        case value::kind::array: {
            njson items = njson::array();
            for (const value& item : v.as_array()) items.push_back(to_njson(item));
            return items;
        }
        case value::kind::object: {
            njson members = njson::object();
            for (const auto& [key, item] : v.as_object()) members[key] = to_njson(item);
            return members;
        }
    }
    return nullptr;
}

}  // namespace

value parse(std::string_view text) {
    try {
        return from_njson(njson::parse(text));
    } catch (const njson::parse_error& e) {
        throw json_error(std::string("JSON: ") + e.what());
    }
}

std::string dump(const value& v) {
    return to_njson(v).dump(-1, ' ', false, njson::error_handler_t::replace);
}

}  // namespace openair::json
