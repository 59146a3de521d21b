// Internal: the proof of secure mode (extension `auth`, spec 14.3), HMAC-SHA256 with OpenSSL.
#pragma once

#include <string>
#include <string_view>

namespace openair::detail {

inline constexpr std::string_view auth_extension = "auth";
inline constexpr std::string_view auth_challenge = "AUTH_CHALLENGE";
inline constexpr std::string_view auth_nonce = "AUTH_NONCE";
inline constexpr std::string_view auth_response = "AUTH_RESPONSE";
inline constexpr std::string_view auth_accept = "AUTH_ACCEPT";

/// The proof of `name` for the server's `nonce`: HMAC-SHA256(key = secret, data =
/// `OpenAIR-auth/1` LF nonce LF name) as 64 lowercase hex digits (OA-AUTH-3).
[[nodiscard]] std::string auth_proof(std::string_view secret, std::string_view nonce,
                                     std::string_view name);

}  // namespace openair::detail
