#include "hand_script.hpp"

#include <cmath>

namespace afm {

HandScript::HandScript(const Scene &s)
    : path_(s.op.path_nm), speed_(s.op.speed_nm_per_s), feel_(s.op.mode == "feel"), threshold_N_(s.op.feel_threshold_N),
      aim_(s.op.path_nm.front())
{
}

Vec2 HandScript::advance(double dt_s, Vec2 felt_N)
{
    t_s_ += dt_s;
    if (feel_ && !finished()) {
        const Vec2 to = path_[seg_ + 1];
        const double dx = to.x - aim_.x, dy = to.y - aim_.y, d = std::hypot(dx, dy);
        // The force against the stroke: the sample pushes back on the tip.
        const double against = d > 0 ? -(felt_N.x * dx + felt_N.y * dy) / d : 0.0;
        if (armed_ && against > threshold_N_) {
            contacts_.push_back({t_s_ - dt_s, aim_, against, static_cast<int>(seg_)});
            ++seg_;   // this stroke ends here; the next starts from the aim
            armed_ = false;
        } else if (!armed_ && against < threshold_N_ / 2) {
            armed_ = true;
        }
    }
    double left = speed_ * dt_s;
    while (left > 0 && !finished()) {
        const Vec2 to = path_[seg_ + 1];
        const double d = std::hypot(to.x - aim_.x, to.y - aim_.y);
        if (d <= left) {
            aim_ = to;
            left -= d;
            ++seg_;
        } else {
            aim_ = {aim_.x + (to.x - aim_.x) * left / d, aim_.y + (to.y - aim_.y) * left / d};
            left = 0;
        }
    }
    return aim_;
}

}  // namespace afm
