// openair-shim: the conformance shim of the C++ client (protocol `openair-shim/1`), as is.
// It takes no options but --help and --version; the protocol runs on stdin/stdout.
#include <string>

#include "cli.hpp"
#include "openair/version.hpp"
#include "shim.hpp"

int main(int argc, char** argv) {
    CLI::App app{"The conformance shim of the OpenAIR C++ client: speaks openair-shim/1 "
                 "(JSON lines) on stdin/stdout.",
                 "openair-shim"};
    app.set_version_flag("--version", std::string("openair-shim ") + openair::version);
    if (auto status = openair_cli::parse(app, argc, argv)) return *status;
    return openair::shim::run();
}
