// The open-loop scanner's piezo (physics.md section 17): its hysteresis and
// its creep, per axis, as the effects piezo_hysteresis and piezo_creep build
// them. Pure models: no scene, no clock; the World feeds them its commanded
// (speed-limited) position each sample and takes their output as where the
// piezo is.
//
// Hysteresis (PlayHysteresis): a Prandtl-Ishlinskii model, rate-independent,
//   y = x0 + g [(1 - a) (x - x0) + (a / n) sum_i (F_ri[x] - x0)],
// F_r the play operator of threshold r (its output moves only when the input
// is more than r from it: F_r = max(x - r, min(x + r, F_r before))), started
// at the first input x0 (every play's output x0, so y(x0) = x0). The n
// thresholds are r_i = (i + 1/2) / n * S / 2 (n even; S: the span, the
// peak-to-peak excursion the width refers to). Over a symmetric cycle of
// amplitude A = S / 2 every play turns, each opening a loop widest at the
// cycle's middle (2 min(r_i, A - r_i)), so the loop's widest vertical
// opening, against the output's peak-to-peak range, is exactly
// w = a / (4 - 2 a): a = 4 w / (1 + 2 w). The gain g = 1 / (1 - a / 2) makes
// that cycle's output span its input (a scanner calibrated at that
// excursion). Smaller cycles open narrower loops (fewer plays turn): at a
// fifth of the span 2.5 % where the span's cycle opens 10 % (the tests' figures).
//
// Creep (LogCreep): after a step D of its input at t = 0 the output keeps
// moving as D gamma log10(t / t0) for t >= t0 (Jung and Gweon 2000), a
// superposition over steps. Realised as K first-order relaxers s_k (time
// constants tau_k log-spaced from t0 to T, T the run's span, one more than
// the decades of [t0, T], at least 2), each following the input:
//   out = y + gamma [sum_k c_k (s_k - y(0)) - b (y - y(0))],
// so that a step's response is D (1 + gamma [sum_k c_k (1 - exp(-t / tau_k)) - b]);
// c_k and b are the least-squares fit of sum_k c_k (1 - exp(-t / tau_k)) - b
// to log10(t / t0) over 64 times log-spaced in [t0, T]. The step's output is
// D at t0 (as the law has it), D (1 - gamma b) at once (b about 0.7: the
// part of the creep before t0). fit_error() is the fit's worst deviation
// over those times, in decades (a fraction of gamma D). Past T the relaxers
// run out: the creep slows and stops, about half a decade later.
//
// PiezoXY: the scanner's x and y, each through hysteresis then creep (either
// may be absent), as the World builds it from the scene (make_piezo).
//
// A scan's raster (raster_line; its timing common/scan_raster.hpp) is taken
// through a copy of the models, from their present state: the hysteresis
// to the first line, to this one, to the line's end and back along the
// retrace to its start, then along the line; the creep on the raster's
// timeline, so that each line carries the creep of every step before it
// at its time (the tip's before the scan, the step to the scan's start,
// the slow axis's lines before: gamma log10(t / t0) of each), the fast
// axis's input held at the line's start.
#pragma once

#include <Eigen/Core>

#include <memory>
#include <optional>
#include <vector>

#include "scene.hpp"

namespace afm::sim {

class PlayHysteresis {
public:
    static constexpr int kPlays = 16;
    // width: the loop's opening over the output's range for a full cycle of
    // span_nm peak to peak (0.1: 10 %), in [0, 1); x0_nm: the first input.
    PlayHysteresis(double width, double span_nm, double x0_nm);
    double step(double x_nm);                 // the output for the next input, nm
    double output() const { return y_; }
    // The model's mixing weight a and gain g (header), for the tests.
    double weight() const { return a_; }
    double gain() const { return g_; }

private:
    double x0_ = 0, a_ = 0, g_ = 1, y_ = 0;
    double r_[kPlays] = {};
    double play_[kPlays] = {};
};

class LogCreep {
public:
    // gamma: per decade (0.015: 1.5 %); t0_s > 0; span_s: the time over
    // which the law is fitted (the run's duration; at least 10 t0); dt_s:
    // the step between inputs; y0_nm: the first input.
    LogCreep(double gamma, double t0_s, double span_s, double dt_s, double y0_nm);
    double step(double y_nm);                 // the output for the next input, nm
    double fit_error() const { return fit_error_; }
    const std::vector<double> &taus_s() const { return tau_; }
    const std::vector<double> &weights() const { return c_; }
    double offset() const { return b_; }

    // The relaxers' states (the raster's copies start from them), each one's
    // decay exp(-dt / tau_k) over dt_s, and the output for input y_nm with
    // the relaxers at s (step's formula, nothing stepped).
    const std::vector<double> &relaxers() const { return s_; }
    std::vector<double> decay(double dt_s) const;
    double output(const std::vector<double> &s, double y_nm) const;

private:
    std::vector<double> tau_, c_, keep_, s_;   // keep_: exp(-dt / tau) per relaxer
    double gamma_ = 0, b_ = 0, y0_ = 0, fit_error_ = 0;
};

// One line of a raster, commanded: x_i = x0 + i dx (i < n) at y; the
// raster's first line at y_first, its lines dy apart (0: this line is the
// raster's first in time).
struct RasterLine {
    double x0_nm = 0, dx_nm = 0;
    int n = 0;
    double y_nm = 0, y_first_nm = 0, dy_nm = 0;
};

class PiezoXY {
public:
    std::optional<PlayHysteresis> hx, hy;
    std::optional<LogCreep> cx, cy;
    // Where the piezo is after the next commanded position, nm (frame A).
    Eigen::Vector2d step(const Eigen::Vector2d &drive_nm);
    // Where the scanner puts each point of the line, from the models'
    // present state (header), into x_nm[0..n) and y_nm[0..n); nothing stepped.
    void raster_line(const RasterLine &l, double *x_nm, double *y_nm) const;
};

// The scanner's model for the scene's piezo_hysteresis and piezo_creep
// (afm.hysteresis, afm.creep), started at start_nm; null with neither. The
// creep's law is fitted over the run and a full scan after it (the
// display's check scans the field at the end).
std::unique_ptr<PiezoXY> make_piezo(const Scene &s, const Eigen::Vector2d &start_nm);

}  // namespace afm::sim
