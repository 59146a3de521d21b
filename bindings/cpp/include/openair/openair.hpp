// Everything of the OpenAIR C++ client in one include.
#pragma once

#include "openair/client.hpp"   // IWYU pragma: export
#include "openair/codec.hpp"    // IWYU pragma: export
#include "openair/content.hpp"  // IWYU pragma: export
#include "openair/errc.hpp"     // IWYU pragma: export
#include "openair/error.hpp"    // IWYU pragma: export
#include "openair/frame.hpp"    // IWYU pragma: export
#include "openair/message.hpp"  // IWYU pragma: export
#include "openair/session.hpp"  // IWYU pragma: export
#include "openair/types.hpp"    // IWYU pragma: export
