// The shim driver (protocol `openair-shim/1`), shared by openair-shim and the test-only
// openair-shim-broken. Not part of the client library.
#pragma once

#include <functional>
#include <string>

#include <nlohmann/json.hpp>

namespace openair::shim {

/// A protocol object; ordered, so answers keep their members in the order they were written.
using json = nlohmann::ordered_json;

/// How a shim binary changes what the driver says. The real shim uses the defaults (no
/// change); openair-shim-broken rewrites commands or answers to break one behaviour on purpose.
struct hooks {
    /// The library name of the ready line (a report's column label).
    std::string library = "openair-cpp";
    /// Rewrite a command (its `cmd` name, the whole object) before it runs.
    std::function<json(const std::string& cmd, json command)> command;
    /// Rewrite an answer (success or failure, `seq` included) before it is written.
    std::function<json(const std::string& cmd, json answer)> answer;
};

/// Speak openair-shim/1 on stdin/stdout until `close` or end of input; return the exit code.
int run(const hooks& h = {});

}  // namespace openair::shim
