#include "auth.hpp"

#include <openssl/evp.h>
#include <openssl/hmac.h>

#include "openair/error.hpp"

namespace openair::detail {

std::string auth_proof(std::string_view secret, std::string_view nonce, std::string_view name) {
    std::string data = "OpenAIR-auth/1\n";
    data.append(nonce).append("\n").append(name);
    unsigned char mac[EVP_MAX_MD_SIZE];
    unsigned int size = 0;
    // An empty key is a valid (if useless) HMAC key; give OpenSSL a non-null pointer for it.
    static const unsigned char empty = 0;
    const void* key = secret.empty() ? static_cast<const void*>(&empty) : secret.data();
    if (HMAC(EVP_sha256(), key, static_cast<int>(secret.size()),
             reinterpret_cast<const unsigned char*>(data.data()), data.size(), mac,
             &size) == nullptr) {
        throw error(errc::api_misuse, "HMAC-SHA256 is not available");
    }
    static const char digits[] = "0123456789abcdef";
    std::string hex;
    hex.reserve(size * 2);
    for (unsigned int i = 0; i < size; ++i) {
        hex += digits[mac[i] >> 4];
        hex += digits[mac[i] & 0x0f];
    }
    return hex;
}

}  // namespace openair::detail
