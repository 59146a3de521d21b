// poster: post one message to a whiteboard and wait for its acknowledgement.
//
//   poster [--host 127.0.0.1] [--port 10000] [--name Poster] [--to WB1]
//          [--type Test.Ping.A] [--content "hello ping"] [--no-bind]
//          [--secret-file FILE] [--tls] [--tls-ca CA.pem]
//
// --secret-file: secure mode (spec 14.3), the module's secret is the file's content less a
// trailing line break; --tls-ca implies --tls (TLS, the certificate checked against the CA).
// Exit status: 0 when the post was acknowledged, 1 when the server refused the proof of the
// name or does not run in secure mode, 2 on a bad command line or another error.
#include <fstream>
#include <iostream>
#include <sstream>
#include <stdexcept>
#include <string>

#include "cli.hpp"
#include "openair/client.hpp"
#include "openair/version.hpp"

namespace {

/// The secret in `path`: its bytes, less one trailing line break.
std::string read_secret(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw std::runtime_error("cannot read the secret file " + path);
    std::ostringstream text;
    text << in.rdbuf();
    std::string secret = text.str();
    if (!secret.empty() && secret.back() == '\n') secret.pop_back();
    if (!secret.empty() && secret.back() == '\r') secret.pop_back();
    return secret;
}

}  // namespace

int main(int argc, char** argv) {
    openair::client_options options;
    options.name = "Poster";
    std::string to = "WB1";
    std::string type = "Test.Ping.A";
    std::string content = "hello ping";
    bool no_bind = false;
    std::string secret_file;

    CLI::App app{"Post one message to a whiteboard and wait for its acknowledgement.", "poster"};
    app.set_version_flag("--version", std::string("openair ") + openair::version);
    app.add_option("--host", options.host, "Server host")->capture_default_str();
    openair_cli::add_port(app, options.port, "Server port");
    app.add_option("--name", options.name, "Module name")->capture_default_str();
    app.add_option("--to", to, "Whiteboard to post to")->capture_default_str();
    app.add_option("--type", type, "Message type")->capture_default_str();
    app.add_option("--content", content, "Text content")->capture_default_str();
    app.add_flag("--no-bind", no_bind, "Do not bind a module name (a plain client)");
    app.add_option("--secret-file", secret_file, "Prove the name with the secret in this file");
    app.add_flag("--tls", options.tls.enabled, "Connect over TLS (the system's CAs)");
    app.add_option("--tls-ca", options.tls.ca_file, "Connect over TLS, trusting this CA (PEM)")
        ->check(CLI::ExistingFile);
    if (auto status = openair_cli::parse(app, argc, argv)) return *status;

    try {
        options.bind = !no_bind;
        options.listen = false;  // a poster takes no deliveries: BIND_NOLISTEN
        if (!secret_file.empty()) options.secret = read_secret(secret_file);
        if (!options.tls.ca_file.empty()) options.tls.enabled = true;
        openair::client poster = openair::client::connect(options);
        openair::message sent = poster.post(to, type, content);
        std::cout << "posted " << sent.type << " to " << sent.to << " id " << sent.id << std::endl;
        poster.close();
        return 0;
    } catch (const openair::error& e) {
        std::cerr << "poster: " << e.what() << std::endl;
        bool refused = e.code() == openair::errc::auth_failed ||
                       e.code() == openair::errc::auth_required;
        return refused ? 1 : 2;
    } catch (const std::exception& e) {
        std::cerr << "poster: " << e.what() << std::endl;
        return 2;
    }
}
