// fig8_probe.cpp -- lets the test see what Figure 8's program reads without changing the figure:
// linked with -Wl,--wrap for libindurop's read(channel::Handle&, ...), it prints each read's
// path, result and value, then returns what the real read returned.
#include <indurop/indurop.h>

#include <cstdio>
#include <cstring>

// The mangled name of ::read(channel::Handle&, const char*, std::size_t, void*) on x86-64.
extern "C" int __real__Z4readRN7channel6HandleEPKcmPv(channel::Handle &, const char *, std::size_t, void *);

extern "C" int __wrap__Z4readRN7channel6HandleEPKcmPv(channel::Handle &handle, const char *path, std::size_t size,
                                                      void *out) {
    const int rc = __real__Z4readRN7channel6HandleEPKcmPv(handle, path, size, out);
    if (rc == static_cast<int>(sizeof(double)) && size == sizeof(double)) {
        double v;
        std::memcpy(&v, out, sizeof v);
        std::printf("fig8 read %s rc=%d value=%g\n", path, rc, v);
    } else {
        std::printf("fig8 read %s rc=%d: %s\n", path, rc, channel::lastError(handle));
    }
    std::fflush(stdout);
    return rc;
}
