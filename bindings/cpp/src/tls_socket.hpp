// Internal: TLS over the client's non-blocking TCP sockets (OpenSSL), for secure mode
// (OA-AUTH-10). No OpenSSL type appears here: the library's users never see libssl.
#pragma once

#include <chrono>
#include <cstddef>
#include <memory>
#include <string>
#include <string_view>

#include "socket.hpp"

namespace openair::detail {

/// How to check the server: the CA file (empty: the system's trust store) and whether the
/// certificate must name the host connected to.
struct tls_settings {
    std::string ca_file;
    bool verify_host = true;
};

/// The TLS configuration shared by a client's connections (one SSL_CTX). Move-only.
class tls_context {
public:
    /// TLS 1.2 or later, the server's certificate verified (OA-AUTH-10). Throws
    /// CONNECTION_CLOSED when the CA file cannot be read.
    explicit tls_context(const tls_settings& settings);
    tls_context(tls_context&&) noexcept;
    tls_context& operator=(tls_context&&) noexcept;
    ~tls_context();

private:
    friend class tls_stream;
    struct state;
    std::unique_ptr<state> state_;
    bool verify_host_ = true;
};

/// One TLS session on a connected non-blocking socket it does not own (the caller keeps the
/// fd_handle, and must destroy the stream before closing it).
class tls_stream {
public:
    /// Run the handshake on `fd` within `timeout`, checking the certificate against `host`.
    /// Throws CONNECTION_CLOSED with OpenSSL's reason when it fails.
    tls_stream(tls_context& context, int fd, const std::string& host,
               std::chrono::milliseconds timeout);
    tls_stream(tls_stream&&) noexcept;
    tls_stream& operator=(tls_stream&&) noexcept;
    ~tls_stream();

    [[nodiscard]] io_result read_some(char* buf, std::size_t size);
    [[nodiscard]] io_result write_some(std::string_view data);
    /// Decrypted bytes already buffered: poll(2) does not see them.
    [[nodiscard]] bool pending() const;

private:
    struct state;
    std::unique_ptr<state> state_;
};

}  // namespace openair::detail
