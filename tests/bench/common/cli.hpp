// cli.hpp -- the benchmark programs' checked integer options.
#pragma once

#include <cerrno>
#include <cinttypes>
#include <cstdint>
#include <cstdio>
#include <cstdlib>

namespace bench {

// text as an integer in [min, max], else a message naming program and option, and exit 2.
inline int64_t number(const char *program, const char *option, const char *text, int64_t min, int64_t max) {
    char *end = nullptr;
    errno = 0;
    long long v = std::strtoll(text, &end, 10);
    if (errno || !end || *end || v < min || v > max) {
        std::fprintf(stderr, "%s: %s: '%s' is not an integer from %" PRId64 " to %" PRId64 "\n", program, option, text,
                     min, max);
        std::exit(2);
    }
    return v;
}

}  // namespace bench
