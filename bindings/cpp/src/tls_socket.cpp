#include "tls_socket.hpp"

#include <arpa/inet.h>
#include <openssl/err.h>
#include <openssl/ssl.h>
#include <openssl/x509v3.h>
#include <poll.h>
#include <sys/socket.h>

#include <cerrno>
#include <cstdint>
#include <climits>
#include <cstring>

#include "openair/error.hpp"

namespace openair::detail {

namespace {

struct ctx_deleter {
    void operator()(SSL_CTX* ctx) const noexcept { SSL_CTX_free(ctx); }
};
struct ssl_deleter {
    void operator()(SSL* ssl) const noexcept { SSL_free(ssl); }
};
struct bio_deleter {
    void operator()(BIO* bio) const noexcept { BIO_free(bio); }
};
struct method_deleter {
    void operator()(BIO_METHOD* method) const noexcept { BIO_meth_free(method); }
};

// A socket BIO that writes with MSG_NOSIGNAL: OpenSSL's own uses write(2), whose SIGPIPE on a
// closed connection would kill the caller's process.
int socket_of(BIO* bio) {
    return static_cast<int>(reinterpret_cast<std::intptr_t>(BIO_get_data(bio)));
}

int bio_write(BIO* bio, const char* data, int size) {
    BIO_clear_retry_flags(bio);
    ssize_t n;
    do {
        n = ::send(socket_of(bio), data, static_cast<std::size_t>(size), MSG_NOSIGNAL);
    } while (n < 0 && errno == EINTR);
    if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) BIO_set_retry_write(bio);
    return static_cast<int>(n);
}

int bio_read(BIO* bio, char* buf, int size) {
    BIO_clear_retry_flags(bio);
    ssize_t n;
    do {
        n = ::recv(socket_of(bio), buf, static_cast<std::size_t>(size), 0);
    } while (n < 0 && errno == EINTR);
    if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) BIO_set_retry_read(bio);
    return static_cast<int>(n);
}

long bio_ctrl(BIO*, int cmd, long, void*) {
    return cmd == BIO_CTRL_FLUSH ? 1 : 0;
}

int bio_create(BIO* bio) {
    BIO_set_init(bio, 1);
    return 1;
}

/// The reason of the last OpenSSL failure (and the error queue emptied for the next call).
std::string ssl_reason(const std::string& what) {
    unsigned long code = ERR_get_error();
    std::string text = what;
    if (code != 0) {
        char buf[256];
        ERR_error_string_n(code, buf, sizeof buf);
        text += ": ";
        text += buf;
    }
    ERR_clear_error();
    return text;
}

[[noreturn]] void fail(const std::string& what) {
    throw error(errc::connection_closed, "TLS: " + ssl_reason(what));
}

bool is_ip_literal(const std::string& host) {
    unsigned char buf[sizeof(in6_addr)];
    return inet_pton(AF_INET, host.c_str(), buf) == 1 ||
           inet_pton(AF_INET6, host.c_str(), buf) == 1;
}

}  // namespace

struct tls_context::state {
    std::unique_ptr<SSL_CTX, ctx_deleter> ctx;
    std::unique_ptr<BIO_METHOD, method_deleter> method;
};

tls_context::tls_context(const tls_settings& settings)
    : state_(std::make_unique<state>()), verify_host_(settings.verify_host) {
    state_->ctx.reset(SSL_CTX_new(TLS_client_method()));
    if (!state_->ctx) fail("cannot create a context");
    SSL_CTX* ctx = state_->ctx.get();
    // OA-AUTH-10: TLS 1.2 or later, and the server's certificate verified.
    if (SSL_CTX_set_min_proto_version(ctx, TLS1_2_VERSION) != 1) fail("cannot require TLS 1.2");
    SSL_CTX_set_verify(ctx, SSL_VERIFY_PEER, nullptr);
    int ok = settings.ca_file.empty()
                 ? SSL_CTX_set_default_verify_paths(ctx)
                 : SSL_CTX_load_verify_locations(ctx, settings.ca_file.c_str(), nullptr);
    if (ok != 1) fail("cannot load the CA certificates '" + settings.ca_file + "'");
    // The connection's buffer of unsent bytes moves and grows between retries of a write.
    SSL_CTX_set_mode(ctx, SSL_MODE_ENABLE_PARTIAL_WRITE | SSL_MODE_ACCEPT_MOVING_WRITE_BUFFER);
    state_->method.reset(BIO_meth_new(BIO_get_new_index() | BIO_TYPE_SOURCE_SINK, "openair"));
    BIO_METHOD* m = state_->method.get();
    if (m == nullptr || BIO_meth_set_write(m, bio_write) != 1 ||
        BIO_meth_set_read(m, bio_read) != 1 || BIO_meth_set_ctrl(m, bio_ctrl) != 1 ||
        BIO_meth_set_create(m, bio_create) != 1) {
        fail("cannot create the socket BIO");
    }
}

tls_context::tls_context(tls_context&&) noexcept = default;
tls_context& tls_context::operator=(tls_context&&) noexcept = default;
tls_context::~tls_context() = default;

struct tls_stream::state {
    std::unique_ptr<SSL, ssl_deleter> ssl;
};

tls_stream::tls_stream(tls_context& context, int fd, const std::string& host,
                       std::chrono::milliseconds timeout)
    : state_(std::make_unique<state>()) {
    ERR_clear_error();
    state_->ssl.reset(SSL_new(context.state_->ctx.get()));
    SSL* ssl = state_->ssl.get();
    if (ssl == nullptr) fail("cannot create a session");
    std::unique_ptr<BIO, bio_deleter> bio(BIO_new(context.state_->method.get()));
    if (!bio) fail("cannot create the socket BIO");
    BIO_set_data(bio.get(), reinterpret_cast<void*>(static_cast<std::intptr_t>(fd)));
    SSL_set_bio(ssl, bio.get(), bio.get());
    (void)bio.release();  // the session owns it now
    if (!is_ip_literal(host) && SSL_set_tlsext_host_name(ssl, host.c_str()) != 1) {
        fail("cannot set the server name");
    }
    if (context.verify_host_) {
        // The certificate must name the host (a DNS name, or an IP address in its SAN).
        int ok = is_ip_literal(host) ? X509_VERIFY_PARAM_set1_ip_asc(SSL_get0_param(ssl),
                                                                      host.c_str())
                                     : SSL_set1_host(ssl, host.c_str());
        if (ok != 1) fail("cannot set the host name to verify");
    }
    auto deadline = std::chrono::steady_clock::now() + timeout;
    while (true) {
        int rc = SSL_connect(ssl);
        if (rc == 1) return;
        int err = SSL_get_error(ssl, rc);
        short events = err == SSL_ERROR_WANT_READ    ? POLLIN
                       : err == SSL_ERROR_WANT_WRITE ? POLLOUT
                                                     : 0;
        if (events == 0) {
            long verify = SSL_get_verify_result(ssl);
            if (verify != X509_V_OK) {
                ERR_clear_error();
                throw error(errc::connection_closed,
                            std::string("TLS: the server's certificate is not trusted: ") +
                                X509_verify_cert_error_string(verify));
            }
            fail("handshake with " + host + " failed");
        }
        auto left = std::chrono::ceil<std::chrono::milliseconds>(
            deadline - std::chrono::steady_clock::now());
        if (left.count() <= 0) throw error(errc::connection_closed, "TLS: handshake timed out");
        pollfd p{fd, events, 0};
        int prc = ::poll(&p, 1, static_cast<int>(left.count()));
        if (prc < 0 && errno != EINTR) {
            throw error(errc::connection_closed, std::string("poll: ") + std::strerror(errno));
        }
    }
}

tls_stream::tls_stream(tls_stream&&) noexcept = default;
tls_stream& tls_stream::operator=(tls_stream&&) noexcept = default;
tls_stream::~tls_stream() = default;

namespace {

/// Translate the outcome of SSL_read or SSL_write.
io_result outcome(SSL* ssl, int rc) {
    io_result r;
    if (rc > 0) {
        r.bytes = static_cast<std::size_t>(rc);
        return r;
    }
    int err = SSL_get_error(ssl, rc);
    if (err == SSL_ERROR_WANT_READ || err == SSL_ERROR_WANT_WRITE) {
        r.would_block = true;
    } else if (err == SSL_ERROR_ZERO_RETURN) {
        r.closed = true;  // the peer's close_notify: end of stream
    } else {
        r.closed = true;
        r.reason = err == SSL_ERROR_SYSCALL && errno != 0 ? std::string(std::strerror(errno))
                                                          : ssl_reason("TLS");
        if (r.reason == "TLS") r.reason.clear();  // a plain end of stream
    }
    ERR_clear_error();
    return r;
}

int clamp_size(std::size_t size) {
    return static_cast<int>(size > static_cast<std::size_t>(INT_MAX) ? INT_MAX : size);
}

}  // namespace

io_result tls_stream::read_some(char* buf, std::size_t size) {
    errno = 0;
    int rc = SSL_read(state_->ssl.get(), buf, clamp_size(size));
    return outcome(state_->ssl.get(), rc);
}

io_result tls_stream::write_some(std::string_view data) {
    if (data.empty()) return {};
    errno = 0;
    int rc = SSL_write(state_->ssl.get(), data.data(), clamp_size(data.size()));
    return outcome(state_->ssl.get(), rc);
}

bool tls_stream::pending() const {
    return SSL_pending(state_->ssl.get()) > 0;
}

}  // namespace openair::detail
