// flood.cpp -- a non-real process that writes far more than irpd forwards: one over-long line,
// then --lines N short lines as fast as it can, then exits 0.
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

int main(int argc, char *argv[]) {
    long lines = 100000, long_line = 0;
    for (int i = 1; i + 1 < argc; ++i) {
        if (!std::strcmp(argv[i], "--lines"))
            lines = std::atol(argv[++i]);
        else if (!std::strcmp(argv[i], "--long-line"))
            long_line = std::atol(argv[++i]);
    }
    if (long_line > 0) std::printf("%s\n", std::string(static_cast<std::size_t>(long_line), 'L').c_str());
    for (long i = 0; i < lines; ++i) std::printf("flood line %ld\n", i);
    return 0;
}
