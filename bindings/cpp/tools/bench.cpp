// openair-bench: the C++ client's side of bench/bench_bindings.py (never part of the tests).
//
//   openair-bench post HOST PORT N SIZE   bind with BIND_NOLISTEN, require the server to
//       advertise `noreply`, send N noreply posts whose XML is about SIZE bytes, then one PING
//       (answered in order, OA-SESS-2: the server has read every post); print
//       {"posts": N, "seconds": S, "send_seconds": T}, S from the first post to the PING reply,
//       T until the last post was handed to the socket.
//   openair-bench decode FILE N   decode the message XML in FILE (a wakeup; a framed message is
//       accepted too) N times per round, best of 5 rounds; print
//       {"per_decode_us": X, "per_wakeup_us": Y}: decode_message alone, and decode_message
//       followed by parse_wakeup.
//   openair-bench stream HOST PORT STREAM SIZE RATE N   subscribe to STREAM (push), then write
//       N samples of SIZE bytes at RATE per second (ADD_SAMPLE, each stamped with its send time
//       in the parameter bench:ns) while receiving them on the push connection, on one thread;
//       print {"sent", "received", "dropped", "p50_ms", "p99_ms", "cpu_s", "seconds"}: the
//       write-to-receive latency and the process's CPU time (bench/bench_bindings_streams.py).
//
// Exit status: 0 on success, 2 on a bad command line or an error (printed on stderr).
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cstddef>
#include <fstream>
#include <iostream>
#include <iterator>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "cli.hpp"
#include "openair/client.hpp"
#include "openair/codec.hpp"
#include "openair/content.hpp"
#include "openair/frame.hpp"
#include "openair/stream.hpp"

namespace {

using clock_type = std::chrono::steady_clock;

constexpr const char* post_type = "Bench.Flow.Data";
constexpr const char* whiteboard = "WB1";
constexpr int decode_rounds = 5;

// Content that makes the post's XML about `size` bytes (its envelope measured by encoding it).
std::string padding(const std::string& sender, std::size_t size) {
    openair::message probe = openair::make_message(post_type, sender, whiteboard);
    probe.posted = openair::air_time::from_ns(0);
    probe.noreply = true;
    std::size_t envelope = openair::encode_message(probe).size();
    return std::string(size > envelope ? size - envelope : 0, 'x');
}

int post(const std::string& host, std::uint16_t port, std::size_t n, std::size_t size) {
    openair::client_options options;
    options.host = host;
    options.port = port;
    options.name = "BenchCpp";
    options.listen = false;  // BIND_NOLISTEN: deliveries (none expected) on the callback
    options.announce = false;
    options.reconnect = false;
    openair::client module = openair::client::connect(options);
    const auto& caps = module.server_capabilities();
    if (!caps || !caps->has_extension("noreply") || module.extensions().count("noreply") == 0) {
        throw std::runtime_error("the server does not advertise noreply");
    }
    const std::string content = padding(options.name, size);
    auto start = clock_type::now();
    for (std::size_t i = 0; i < n; ++i) {
        (void)module.post_noreply(whiteboard, post_type, content);
    }
    std::chrono::duration<double> sending = clock_type::now() - start;
    openair::message pong = module.request(openair::make_message("PING", "", openair::cns));
    std::chrono::duration<double> seconds = clock_type::now() - start;
    if (pong.type != "PING_SUCCESS") throw std::runtime_error("PING answered " + pong.type);
    module.close();
    std::cout << "{\"posts\": " << n << ", \"seconds\": " << seconds.count()
              << ", \"send_seconds\": " << sending.count() << "}" << std::endl;
    return 0;
}

// The message XML in `path`: the file as is, or the XML of the one frame it holds.
std::string read_xml(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw std::runtime_error("cannot read " + path);
    std::string data((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (!data.empty() && data.front() == '<') return data;
    openair::frame_reader reader;
    reader.feed(data);
    auto f = reader.next();
    if (!f) throw std::runtime_error(path + " holds neither XML nor a whole frame");
    return f->xml;
}

template <typename Fn>
double best_us(std::size_t n, Fn&& fn) {
    double best = std::numeric_limits<double>::infinity();
    for (int round = 0; round < decode_rounds; ++round) {
        auto start = clock_type::now();
        for (std::size_t i = 0; i < n; ++i) fn();
        std::chrono::duration<double, std::micro> spent = clock_type::now() - start;
        best = std::min(best, spent.count() / static_cast<double>(n));
    }
    return best;
}

int decode(const std::string& path, std::size_t n) {
    const std::string xml = read_xml(path);
    std::size_t sink = 0;  // results are used, so no decode can be optimised away
    double per_decode = best_us(n, [&] { sink += openair::decode_message(xml).content.size(); });
    double per_wakeup = best_us(n, [&] {
        openair::wakeup w = openair::parse_wakeup(openair::decode_message(xml));
        sink += w.lasttrigger.size() + (w.trigger ? w.trigger->content.size() : 0);
    });
    if (sink == 0) throw std::runtime_error("the wakeup in " + path + " decoded to nothing");
    std::cout << "{\"per_decode_us\": " << per_decode << ", \"per_wakeup_us\": " << per_wakeup
              << "}" << std::endl;
    return 0;
}

double cpu_seconds() {
    rusage use{};
    getrusage(RUSAGE_SELF, &use);
    auto secs = [](const timeval& tv) { return tv.tv_sec + tv.tv_usec / 1e6; };
    return secs(use.ru_utime) + secs(use.ru_stime);
}

std::int64_t wall_ns() {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(
               std::chrono::system_clock::now().time_since_epoch())
        .count();
}

double percentile(std::vector<double> values, double fraction) {
    if (values.empty()) return 0.0;
    std::sort(values.begin(), values.end());
    auto index = static_cast<std::size_t>(fraction * static_cast<double>(values.size() - 1));
    return values[index];
}

struct receiver {
    std::vector<double> latencies_ms;
    std::uint64_t dropped = 0;

    void take(const openair::received_sample& got) {
        dropped += got.dropped;
        if (auto sent = got.sample.param("bench:ns")) {
            latencies_ms.push_back(static_cast<double>(got.received_ns - std::stoll(*sent)) / 1e6);
        }
    }
};

int stream_flow(const std::string& host, std::uint16_t port, const std::string& target,
                std::size_t size, double rate, std::size_t n) {
    openair::client_options options;
    options.host = host;
    options.port = port;
    options.name = "BenchCppStream";
    options.bind = false;
    options.reconnect = false;
    openair::client module = openair::client::connect(options);
    openair::stream& s = module.stream(target);
    openair::stream_subscription& sub = module.subscribe_stream(target);
    const std::vector<std::byte> payload(size, std::byte{0x5A});
    receiver got;
    double cpu0 = cpu_seconds();
    auto start = clock_type::now();
    auto period = std::chrono::duration<double>(1.0 / rate);
    for (std::size_t i = 0; i < n; ++i) {
        auto due = start + std::chrono::duration_cast<clock_type::duration>(period * i);
        while (clock_type::now() < due) {  // receive while waiting for the next tick
            // Rounded up: a wait of 0 ms before the tick would spin.
            auto left = std::chrono::ceil<std::chrono::milliseconds>(due - clock_type::now());
            if (auto r = sub.next(std::max(left, std::chrono::milliseconds(1)))) got.take(*r);
        }
        openair::sample_options o;
        o.params = {{"bench:ns", std::to_string(wall_ns())}};
        (void)s.add(payload, o);
    }
    auto drain_until = clock_type::now() + std::chrono::seconds(5);
    while (got.latencies_ms.size() + got.dropped < n && clock_type::now() < drain_until) {
        if (auto r = sub.next(std::chrono::milliseconds(100))) got.take(*r);
    }
    std::chrono::duration<double> seconds = clock_type::now() - start;
    double cpu = cpu_seconds() - cpu0;
    module.close();
    std::cout << "{\"sent\": " << n << ", \"received\": " << got.latencies_ms.size()
              << ", \"dropped\": " << got.dropped
              << ", \"p50_ms\": " << percentile(got.latencies_ms, 0.5)
              << ", \"p99_ms\": " << percentile(got.latencies_ms, 0.99) << ", \"cpu_s\": " << cpu
              << ", \"seconds\": " << seconds.count() << "}" << std::endl;
    return 0;
}

struct args {
    std::string host;
    std::uint16_t port = 0;
    std::string file;
    std::size_t n = 0;
    std::size_t size = 0;
    std::string stream;
    double rate = 0;
};

void describe(CLI::App& app, args& a) {
    app.require_subcommand(1);
    CLI::App* post_cmd = app.add_subcommand("post", "Time N noreply posts of about SIZE bytes");
    post_cmd->add_option("HOST", a.host, "Server host")->required();
    post_cmd->add_option("PORT", a.port, "Server port")->required()->check(CLI::Range(1, 65535));
    post_cmd->add_option("N", a.n, "Posts")->required()->check(openair_cli::at_least(1));
    post_cmd->add_option("SIZE", a.size, "XML bytes a post")
        ->required()
        ->check(openair_cli::at_least(1));
    CLI::App* decode_cmd = app.add_subcommand("decode", "Time decoding the message XML in FILE");
    decode_cmd->add_option("FILE", a.file, "A wakeup's XML or frame")->required();
    decode_cmd->add_option("N", a.n, "Decodes a round")
        ->required()
        ->check(openair_cli::at_least(1));
    CLI::App* stream_cmd = app.add_subcommand("stream", "Write N samples at RATE and receive them");
    stream_cmd->add_option("HOST", a.host, "Server host")->required();
    stream_cmd->add_option("PORT", a.port, "Server port")->required()->check(CLI::Range(1, 65535));
    stream_cmd->add_option("STREAM", a.stream, "Stream name")->required();
    stream_cmd->add_option("SIZE", a.size, "Payload bytes")->required();
    stream_cmd->add_option("RATE", a.rate, "Samples per second")
        ->required()
        ->check(CLI::PositiveNumber);
    stream_cmd->add_option("N", a.n, "Samples")->required()->check(openair_cli::at_least(1));
}

}  // namespace

int main(int argc, char** argv) {
    args a;
    CLI::App app{"The C++ client's side of bench/bench_bindings.py.", "openair-bench"};
    describe(app, a);
    if (auto status = openair_cli::parse(app, argc, argv)) return *status;
    try {
        if (app.got_subcommand("post")) return post(a.host, a.port, a.n, a.size);
        if (app.got_subcommand("stream")) {
            return stream_flow(a.host, a.port, a.stream, a.size, a.rate, a.n);
        }
        return decode(a.file, a.n);
    } catch (const std::exception& e) {
        std::cerr << "openair-bench: " << e.what() << std::endl;
        return 2;
    }
}
