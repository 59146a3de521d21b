// poster: post one message to a whiteboard and wait for its acknowledgement.
//
//   poster [--host 127.0.0.1] [--port 10000] [--name Poster] [--to WB1]
//          [--type Test.Ping.A] [--content "hello ping"] [--no-bind]
//
// Exit status: 0 when the post was acknowledged, 2 on an error.
#include <iostream>
#include <string>

#include "openair/client.hpp"

int main(int argc, char** argv) {
    try {
        openair::client_options options;
        options.name = "Poster";
        std::string to = "WB1";
        std::string type = "Test.Ping.A";
        std::string content = "hello ping";
        for (int i = 1; i < argc; ++i) {
            std::string key = argv[i];
            auto value = [&]() -> std::string {
                if (i + 1 >= argc) throw std::runtime_error(key + " needs a value");
                return argv[++i];
            };
            if (key == "--host")
                options.host = value();
            else if (key == "--port")
                options.port = static_cast<std::uint16_t>(std::stoi(value()));
            else if (key == "--name")
                options.name = value();
            else if (key == "--to")
                to = value();
            else if (key == "--type")
                type = value();
            else if (key == "--content")
                content = value();
            else if (key == "--no-bind")
                options.bind = false;
            else
                throw std::runtime_error("unknown option " + key);
        }
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
