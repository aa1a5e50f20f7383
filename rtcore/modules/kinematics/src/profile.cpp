// profile.cpp -- the trapezoidal velocity profile and its stop ramp.
#include <indurop/kinematics/profile.hpp>

#include <algorithm>
#include <cmath>

namespace irp::kin {

void Trapezoid::plan(double distance, double vmax, double amax) noexcept {
    *this = Trapezoid{};
    d_ = std::max(distance, 0.0);
    a_ = amax;
    if (d_ == 0.0) return;
    if (vmax * vmax / amax < d_) {  // reaches vmax: accelerate, cruise, decelerate
        vpeak_ = vmax;
        t1_ = vmax / amax;
        t2_ = d_ / vmax;
        T_ = t2_ + t1_;
    } else {  // triangular
        t1_ = std::sqrt(d_ / amax);
        vpeak_ = amax * t1_;
        t2_ = t1_;
        T_ = 2 * t1_;
    }
}

void Trapezoid::planStop(double v0, double decel) noexcept {
    *this = Trapezoid{};
    a_ = decel;
    vpeak_ = v0;
    stopping_ = true;
    vs_ = std::max(v0, 0.0);
    ds_ = decel;
    d_ = vs_ * vs_ / (2 * ds_);
}

ProfileState Trapezoid::at(double t) const noexcept {
    if (stopping_ && t >= ts_) {
        double tau = std::min(t - ts_, vs_ / ds_);
        return {ss_ + vs_ * tau - 0.5 * ds_ * tau * tau, vs_ - ds_ * tau, tau < vs_ / ds_ ? -ds_ : 0.0};
    }
    if (t <= 0) return {0, 0, d_ > 0 ? a_ : 0};
    if (t >= T_) return {d_, 0, 0};
    if (t < t1_) return {0.5 * a_ * t * t, a_ * t, a_};
    double s1 = 0.5 * a_ * t1_ * t1_;
    if (t < t2_) return {s1 + vpeak_ * (t - t1_), vpeak_, 0};
    double r = T_ - t;  // time left: the deceleration mirrors the acceleration
    return {d_ - 0.5 * a_ * r * r, a_ * r, -a_};
}

void Trapezoid::stopAt(double t, double decel) noexcept {
    if (stopping_) return;
    t = std::max(t, 0.0);
    ProfileState now = at(t);
    stopping_ = true;
    ts_ = t;
    ss_ = now.s;
    vs_ = now.v;
    ds_ = std::max(decel, a_);
    if (!(ds_ > 0)) ds_ = 1.0, vs_ = 0;  // nothing planned: stop where it is
}

double Trapezoid::duration() const noexcept { return stopping_ ? ts_ + vs_ / ds_ : T_; }

double Trapezoid::finalPosition() const noexcept { return stopping_ ? ss_ + vs_ * vs_ / (2 * ds_) : d_; }

}  // namespace irp::kin
