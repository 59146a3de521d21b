// Internal: the fault selected for the deliberately broken shim (see test_faults.hpp). Built
// only into the test library openair_client_faults.
#ifndef OPENAIR_TEST_FAULTS
#error "test_faults.cpp belongs to the test library only (OPENAIR_TEST_FAULTS)"
#endif

#include "test_faults.hpp"

#include <atomic>
#include <utility>

namespace openair::detail::faults {

namespace {

std::atomic<fault> selected{fault::none};

constexpr std::pair<std::string_view, fault> table[] = {
    {"lowercase-postedtime", fault::lowercase_postedtime},
    {"no-posted-time", fault::no_posted_time},
    {"no-ack", fault::no_ack},
    {"wrong-isresponse", fault::wrong_isresponse},
    {"ping-accept", fault::ping_accept},
    {"no-callback", fault::no_callback},
    {"noreply-to-legacy", fault::noreply_to_legacy},
    {"pipelining-to-legacy", fault::pipelining_to_legacy},
    {"crash-on-malformed", fault::crash_on_malformed},
    {"accept-malformed", fault::accept_malformed},
    {"push-no-ack", fault::push_no_ack},
    {"wait-timeout-error", fault::wait_timeout_error},
    {"push-end-silent", fault::push_end_silent},
    {"builtins-first", fault::builtins_first},
    {"registration-samples-lost", fault::registration_samples_lost},
    {"attachments-dropped", fault::attachments_dropped},
};

}  // namespace

fault active() noexcept {
    return selected.load(std::memory_order_relaxed);
}

bool select(std::string_view name) noexcept {
    for (const auto& [known, which] : table) {
        if (known == name) {
            selected.store(which, std::memory_order_relaxed);
            return true;
        }
    }
    return false;
}

std::vector<std::string_view> names() {
    std::vector<std::string_view> out;
    for (const auto& entry : table) out.push_back(entry.first);
    return out;
}

}  // namespace openair::detail::faults
