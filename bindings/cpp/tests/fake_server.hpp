// A scripted fake OpenAIR server for socket tests: blocking sockets on its own thread (the
// library under test starts none), frames read with the library's own frame reader.
#pragma once

#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <stdexcept>
#include <string>

#include "openair/codec.hpp"

namespace openair::test {

/// One blocking connection on the fake server's side; every read gives up after 5 s.
class peer {
public:
    explicit peer(int fd) : fd_(fd) {
        timeval tv{5, 0};
        setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
    }
    peer(peer&& other) noexcept : fd_(other.fd_), reader_(std::move(other.reader_)) {
        other.fd_ = -1;
    }
    peer(const peer&) = delete;
    peer& operator=(const peer&) = delete;
    ~peer() { close(); }

    void close() {
        if (fd_ >= 0) ::close(fd_);
        fd_ = -1;
    }

    frame read_frame() {
        while (true) {
            if (auto f = reader_.next()) return *f;
            char buf[4096];
            ssize_t n = ::recv(fd_, buf, sizeof buf, 0);
            if (n <= 0) throw std::runtime_error("fake server: the client sent nothing more");
            reader_.feed(std::string_view(buf, static_cast<std::size_t>(n)));
        }
    }

    message read() { return from_frame(read_frame()); }

    /// Read the next message and check its type.
    message expect(const std::string& type) {
        message m = read();
        if (m.type != type)
            throw std::runtime_error("fake server: expected " + type + ", got " + m.type);
        return m;
    }

    void send_raw(const std::string& bytes) {
        std::size_t at = 0;
        while (at < bytes.size()) {
            ssize_t n = ::send(fd_, bytes.data() + at, bytes.size() - at, MSG_NOSIGNAL);
            if (n <= 0) throw std::runtime_error("fake server: send failed");
            at += static_cast<std::size_t>(n);
        }
    }

    void send(const message& m, frame_tag tag = frame_tag::message) {
        message stamped = m;
        if (!stamped.posted) stamped.posted = air_time{1795328371, 1, std::nullopt};
        send_raw(encode_frame(to_frame(stamped, tag)));
    }

    /// Answer `request` with `type` (and text content).
    void reply(const message& request, const std::string& type, const std::string& content = "",
               const std::string& from = "CNS") {
        send(request.reply(type, from, content));
    }

    /// True once the client closed its end (reads nothing more).
    bool wait_closed() {
        char buf[256];
        while (true) {
            ssize_t n = ::recv(fd_, buf, sizeof buf, 0);
            if (n == 0) return true;
            if (n < 0) return false;
        }
    }

private:
    int fd_;
    frame_reader reader_;
};

/// A listening socket on 127.0.0.1 with an ephemeral port.
class fake_server {
public:
    fake_server() {
        fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
        int one = 1;
        setsockopt(fd_, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
        sockaddr_in addr{};
        addr.sin_family = AF_INET;
        addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
        if (::bind(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0 ||
            ::listen(fd_, 16) != 0) {
            throw std::runtime_error("fake server: cannot listen");
        }
        socklen_t len = sizeof addr;
        getsockname(fd_, reinterpret_cast<sockaddr*>(&addr), &len);
        port_ = ntohs(addr.sin_port);
        timeval tv{5, 0};
        setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
    }
    fake_server(const fake_server&) = delete;
    fake_server& operator=(const fake_server&) = delete;
    ~fake_server() { ::close(fd_); }

    [[nodiscard]] std::uint16_t port() const { return port_; }

    peer accept() {
        int fd = ::accept(fd_, nullptr, nullptr);
        if (fd < 0) throw std::runtime_error("fake server: no connection came");
        return peer(fd);
    }

    /// Connect to a module's listening port, as a server delivering to it (OA-DELIV-1).
    static peer connect_to(std::uint16_t port) {
        int fd = ::socket(AF_INET, SOCK_STREAM, 0);
        sockaddr_in addr{};
        addr.sin_family = AF_INET;
        addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
        addr.sin_port = htons(port);
        if (::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
            ::close(fd);
            throw std::runtime_error("fake server: cannot reach the module's port");
        }
        return peer(fd);
    }

    /// A port that was free a moment ago (for a BIND_ACCEPT).
    static std::uint16_t free_port() {
        fake_server probe;
        return probe.port();
    }

private:
    int fd_ = -1;
    std::uint16_t port_ = 0;
};

}  // namespace openair::test
