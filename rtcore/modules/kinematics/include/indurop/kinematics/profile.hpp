// profile.hpp -- the one-dimensional trapezoidal velocity profile that times every motion: a
// path parameter goes from standstill at 0 to standstill at `distance` with |velocity| <= vmax
// and |acceleration| <= amax, in minimum time.  A stop replaces the rest of it by a constant
// deceleration to standstill; a profile may also start moving (a stop from a given velocity).
// Plain arithmetic: no allocation, safe in run().
#pragma once

namespace irp::kin {

struct ProfileState {
    double s = 0;  // position along the path
    double v = 0;  // ds/dt
    double a = 0;  // d2s/dt2
};

class Trapezoid {
public:
    // From rest at 0 to rest at distance (>= 0); vmax, amax > 0.  Triangular when the distance
    // is too short to reach vmax.
    void plan(double distance, double vmax, double amax) noexcept;

    // Only the deceleration: from s = 0 at velocity v0 (> 0) to rest, at `decel`.
    void planStop(double v0, double decel) noexcept;

    // The state at time t (seconds from the start); before 0 the start, after the end the end.
    ProfileState at(double t) const noexcept;

    // From the state at time t, decelerate at `decel` (raised to the planned acceleration if
    // below it, so a stop never ends beyond the planned end).  A second stop keeps the first.
    void stopAt(double t, double decel) noexcept;

    double duration() const noexcept;  // the end, after a stop if one was asked
    double finalPosition() const noexcept;
    bool stopping() const noexcept { return stopping_; }
    double peakVelocity() const noexcept { return vpeak_; }
    double acceleration() const noexcept { return a_; }

private:
    double d_ = 0, vpeak_ = 0, a_ = 0;  // the planned profile: distance, peak velocity, acceleration
    double t1_ = 0, t2_ = 0, T_ = 0;    // end of acceleration, end of cruise, end
    bool stopping_ = false;
    double ts_ = 0, ss_ = 0, vs_ = 0, ds_ = 0;  // the stop: start time, position, velocity, deceleration
};

}  // namespace irp::kin
