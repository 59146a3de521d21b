#include "socket.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>
#include <cerrno>
#include <cstring>

#include <memory>

#include "openair/error.hpp"

namespace openair::detail {

namespace {

[[noreturn]] void fail(const std::string& what, int err) {
    throw error(errc::connection_closed, what + ": " + std::strerror(err));
}

void set_nonblocking(int fd) {
    int flags = fcntl(fd, F_GETFL, 0);
    if (flags < 0 || fcntl(fd, F_SETFL, flags | O_NONBLOCK) < 0) fail("fcntl", errno);
    fcntl(fd, F_SETFD, FD_CLOEXEC);
}

struct addrinfo_deleter {
    void operator()(addrinfo* ai) const noexcept { freeaddrinfo(ai); }
};

std::unique_ptr<addrinfo, addrinfo_deleter> resolve(const std::string& host, std::uint16_t port,
                                                    bool passive) {
    addrinfo hints{};
    hints.ai_family = AF_UNSPEC;
    hints.ai_socktype = SOCK_STREAM;
    hints.ai_flags = passive ? AI_PASSIVE : 0;
    addrinfo* found = nullptr;
    std::string service = std::to_string(port);
    int rc = getaddrinfo(host.empty() ? nullptr : host.c_str(), service.c_str(), &hints, &found);
    if (rc != 0) {
        throw error(errc::connection_closed, "cannot resolve " + host + ": " + gai_strerror(rc));
    }
    return std::unique_ptr<addrinfo, addrinfo_deleter>(found);
}

/// Wait for a non-blocking connect to finish; returns 0 or the errno of the failure.
int finish_connect(int fd, std::chrono::milliseconds timeout) {
    pollfd p{fd, POLLOUT, 0};
    int rc;
    do {
        rc = ::poll(&p, 1, static_cast<int>(timeout.count()));
    } while (rc < 0 && errno == EINTR);
    if (rc == 0) return ETIMEDOUT;
    if (rc < 0) return errno;
    int err = 0;
    socklen_t len = sizeof err;
    if (getsockopt(fd, SOL_SOCKET, SO_ERROR, &err, &len) < 0) return errno;
    return err;
}

}  // namespace

fd_handle& fd_handle::operator=(fd_handle&& other) noexcept {
    if (this != &other) {
        reset();
        fd_ = other.release();
    }
    return *this;
}

fd_handle::~fd_handle() {
    reset();
}

int fd_handle::release() noexcept {
    int fd = fd_;
    fd_ = -1;
    return fd;
}

void fd_handle::reset() noexcept {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
}

fd_handle connect_tcp(const std::string& host, std::uint16_t port,
                      std::chrono::milliseconds timeout) {
    auto list = resolve(host, port, false);
    int last = ECONNREFUSED;
    for (addrinfo* ai = list.get(); ai != nullptr; ai = ai->ai_next) {
        fd_handle fd(::socket(ai->ai_family, ai->ai_socktype, ai->ai_protocol));
        if (!fd.valid()) {
            last = errno;
            continue;
        }
        set_nonblocking(fd.get());
        int one = 1;
        setsockopt(fd.get(), IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
        int rc = ::connect(fd.get(), ai->ai_addr, ai->ai_addrlen);
        int err = rc == 0 ? 0 : errno == EINPROGRESS ? finish_connect(fd.get(), timeout) : errno;
        if (err == 0) return fd;
        last = err;
    }
    fail("cannot connect to " + host + ":" + std::to_string(port), last);
}

fd_handle listen_tcp(const std::string& host, std::uint16_t port) {
    auto list = resolve(host, port, true);
    int last = EADDRNOTAVAIL;
    for (addrinfo* ai = list.get(); ai != nullptr; ai = ai->ai_next) {
        fd_handle fd(::socket(ai->ai_family, ai->ai_socktype, ai->ai_protocol));
        if (!fd.valid()) {
            last = errno;
            continue;
        }
        int one = 1;
        setsockopt(fd.get(), SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
        if (::bind(fd.get(), ai->ai_addr, ai->ai_addrlen) == 0 && ::listen(fd.get(), 64) == 0) {
            set_nonblocking(fd.get());
            return fd;
        }
        last = errno;
    }
    fail("cannot listen on " + host + ":" + std::to_string(port), last);
}

fd_handle accept_tcp(int listen_fd) {
    int fd;
    do {
        fd = ::accept(listen_fd, nullptr, nullptr);
    } while (fd < 0 && errno == EINTR);
    if (fd < 0) return fd_handle();
    fd_handle handle(fd);
    set_nonblocking(fd);
    int one = 1;
    setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    return handle;
}

std::string local_host(int fd) {
    sockaddr_storage addr{};
    socklen_t len = sizeof addr;
    if (getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len) < 0) return "127.0.0.1";
    char text[INET6_ADDRSTRLEN] = {};
    if (addr.ss_family == AF_INET) {
        inet_ntop(AF_INET, &reinterpret_cast<sockaddr_in*>(&addr)->sin_addr, text, sizeof text);
    } else if (addr.ss_family == AF_INET6) {
        inet_ntop(AF_INET6, &reinterpret_cast<sockaddr_in6*>(&addr)->sin6_addr, text, sizeof text);
    }
    return text[0] != '\0' ? std::string(text) : std::string("127.0.0.1");
}

std::uint16_t local_port(int fd) {
    sockaddr_storage addr{};
    socklen_t len = sizeof addr;
    if (getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len) < 0) return 0;
    if (addr.ss_family == AF_INET) return ntohs(reinterpret_cast<sockaddr_in*>(&addr)->sin_port);
    if (addr.ss_family == AF_INET6) return ntohs(reinterpret_cast<sockaddr_in6*>(&addr)->sin6_port);
    return 0;
}

io_result read_some(int fd, char* buf, std::size_t size) {
    io_result r;
    ssize_t n;
    do {
        n = ::recv(fd, buf, size, 0);
    } while (n < 0 && errno == EINTR);
    if (n > 0) {
        r.bytes = static_cast<std::size_t>(n);
    } else if (n == 0) {
        r.closed = true;
    } else if (errno == EAGAIN || errno == EWOULDBLOCK) {
        r.would_block = true;
    } else {
        r.closed = true;
        r.reason = std::strerror(errno);
    }
    return r;
}

io_result write_some(int fd, std::string_view data) {
    io_result r;
    ssize_t n;
    do {
        n = ::send(fd, data.data(), data.size(), MSG_NOSIGNAL);  // no SIGPIPE
    } while (n < 0 && errno == EINTR);
    if (n >= 0) {
        r.bytes = static_cast<std::size_t>(n);
    } else if (errno == EAGAIN || errno == EWOULDBLOCK) {
        r.would_block = true;
    } else {
        r.closed = true;
        r.reason = std::strerror(errno);
    }
    return r;
}

}  // namespace openair::detail
