// The one exception type of the OpenAIR C++ client (spec section 13).
#pragma once

#include <stdexcept>
#include <string>

#include "openair/errc.hpp"

namespace openair {

/// Every failure the library reports: a condition of the error table plus a human-readable detail.
///
/// `code()` tells which condition; `blame()` tells a remote protocol violation from a refusal by
/// the peer and from local misuse (OA-GEN-3). `what()` is `NAME: detail`, the form a
/// RECEIVE_ERROR carries on the wire (OA-ERR-2).
class error : public std::runtime_error {
public:
    error(errc code, const std::string& detail);

    [[nodiscard]] errc code() const noexcept { return code_; }
    [[nodiscard]] const std::string& detail() const noexcept { return detail_; }
    [[nodiscard]] openair::blame blame() const noexcept { return errc_blame(code_); }
    /// Whether the connection that carried the condition must be closed (spec 13.1).
    [[nodiscard]] bool closes() const noexcept { return errc_closes(code_); }
    /// `NAME: detail`, or just `NAME` when the detail is empty (OA-ERR-2).
    [[nodiscard]] std::string wire_text() const { return what(); }

private:
    errc code_;
    std::string detail_;
};

}  // namespace openair
