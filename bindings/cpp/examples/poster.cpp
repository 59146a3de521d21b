// poster: post one message to a whiteboard and wait for its acknowledgement.
//
//   poster [--host 127.0.0.1] [--port 10000] [--name Poster] [--to WB1]
//          [--type Test.Ping.A] [--content "hello ping"] [--no-bind]
//
// Exit status: 0 when the post was acknowledged, 2 on a bad command line or an error.
#include <iostream>
#include <string>

#include "cli.hpp"
#include "openair/client.hpp"
#include "openair/version.hpp"

int main(int argc, char** argv) {
    openair::client_options options;
    options.name = "Poster";
    std::string to = "WB1";
    std::string type = "Test.Ping.A";
    std::string content = "hello ping";
    bool no_bind = false;

    CLI::App app{"Post one message to a whiteboard and wait for its acknowledgement.", "poster"};
    app.set_version_flag("--version", std::string("openair ") + openair::version);
    app.add_option("--host", options.host, "Server host")->capture_default_str();
    openair_cli::add_port(app, options.port, "Server port");
    app.add_option("--name", options.name, "Module name")->capture_default_str();
    app.add_option("--to", to, "Whiteboard to post to")->capture_default_str();
    app.add_option("--type", type, "Message type")->capture_default_str();
    app.add_option("--content", content, "Text content")->capture_default_str();
    app.add_flag("--no-bind", no_bind, "Do not bind a module name (a plain client)");
    if (auto status = openair_cli::parse(app, argc, argv)) return *status;

    try {
        options.bind = !no_bind;
        options.listen = false;  // a poster takes no deliveries: BIND_NOLISTEN
        openair::client poster = openair::client::connect(options);
        openair::message sent = poster.post(to, type, content);
        std::cout << "posted " << sent.type << " to " << sent.to << " id " << sent.id << std::endl;
        poster.close();
        return 0;
    } catch (const std::exception& e) {
        std::cerr << "poster: " << e.what() << std::endl;
        return 2;
    }
}
