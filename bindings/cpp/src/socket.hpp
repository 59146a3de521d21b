// Internal: thin POSIX TCP helpers for the client (non-blocking sockets, poll(2)).
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace openair::detail {

/// An owned file descriptor; closed on destruction. Move-only.
class fd_handle {
public:
    fd_handle() = default;
    explicit fd_handle(int fd) noexcept : fd_(fd) {}
    fd_handle(fd_handle&& other) noexcept : fd_(other.release()) {}
    fd_handle& operator=(fd_handle&& other) noexcept;
    fd_handle(const fd_handle&) = delete;
    fd_handle& operator=(const fd_handle&) = delete;
    ~fd_handle();

    [[nodiscard]] int get() const noexcept { return fd_; }
    [[nodiscard]] bool valid() const noexcept { return fd_ >= 0; }
    int release() noexcept;
    void reset() noexcept;

private:
    int fd_ = -1;
};

/// Connect to host:port within `timeout`; the socket is non-blocking. Throws
/// CONNECTION_CLOSED with the system's reason when it cannot connect.
[[nodiscard]] fd_handle connect_tcp(const std::string& host, std::uint16_t port,
                                    std::chrono::milliseconds timeout);
/// Listen on host:port (port 0: any free port); non-blocking. Throws CONNECTION_CLOSED.
[[nodiscard]] fd_handle listen_tcp(const std::string& host, std::uint16_t port);
/// Accept one pending connection (non-blocking), or an invalid handle when none is pending.
[[nodiscard]] fd_handle accept_tcp(int listen_fd);
/// The local address and port of a socket.
[[nodiscard]] std::string local_host(int fd);
[[nodiscard]] std::uint16_t local_port(int fd);

/// The outcome of one non-blocking read or write.
struct io_result {
    std::size_t bytes = 0;
    bool closed = false;       ///< end of stream (read) or broken connection
    bool would_block = false;  ///< nothing to do now
    std::string reason;        ///< for a broken connection
};
[[nodiscard]] io_result read_some(int fd, char* buf, std::size_t size);
[[nodiscard]] io_result write_some(int fd, std::string_view data);

}  // namespace openair::detail
