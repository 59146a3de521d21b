// openair-shim: the conformance shim of the C++ client (protocol `openair-shim/1`), as is.
#include "shim.hpp"

int main() {
    return openair::shim::run();
}
