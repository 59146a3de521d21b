// Test helpers: the shared vectors folder, files, hex and SHA-256 (for the frame manifest).
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "json.hpp"

namespace openair::test {

/// spec/vectors, as configured by CMake.
[[nodiscard]] std::string vectors_dir();
/// The whole content of a file (throws std::runtime_error when it cannot be read).
[[nodiscard]] std::string read_file(const std::string& path);
/// A manifest under spec/vectors, parsed.
[[nodiscard]] json::value load_manifest(const std::string& relative);
/// Lower-case hex of `bytes`, and back.
[[nodiscard]] std::string to_hex(std::string_view bytes);
[[nodiscard]] std::string from_hex(std::string_view hex);
/// SHA-256 of `bytes`, as lower-case hex.
[[nodiscard]] std::string sha256_hex(std::string_view bytes);

}  // namespace openair::test
