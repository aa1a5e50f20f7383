// iec.cpp -- TON, the on-delay timer of IEC 61131-3 (iec.h).
#include <indurop/plcopen/iec.h>

namespace plcopen {

bool TON::operator()(Time now) {
    if (!IN) {
        running_ = false;
        Q = false;
        ET = Time{0};
        return Q;
    }
    if (!running_) {  // IN went TRUE: the delay starts with this call
        running_ = true;
        start_ = now;
    }
    const Time elapsed = now - start_;
    ET = elapsed < PT ? elapsed : PT;
    Q = elapsed >= PT;
    return Q;
}

}  // namespace plcopen
