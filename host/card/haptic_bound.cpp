#include "haptic_bound.hpp"

extern "C" {
#include "fw_calib.h"
#include "fw_units.h"
}

#include <algorithm>
#include <cmath>
#include <sstream>

namespace afm {

namespace {

constexpr double kAutoGainFraction = 0.8;   // force_gain_N_per_nN auto: this much of the largest gain inside the bound

double stylus_scale(const Scene &s) { return s.op.kappa * s.field_nm / 2 * 1e-9 / (s.op.haptic.half_range_mm * 1e-3); }

double bound_N_per_m(const Scene &s, double period_s, double delay_blocks)
{
    return s.op.haptic.damping_Ns_per_m / (period_s * (0.5 + delay_blocks));
}

}  // namespace

double lever_stiffness_N_per_m(const fw_board_config_t &b)
{
    int32_t c_pm_per_v = 0;   // the firmware's own estimate C = 3 h K_n / (2 l)
    if (fw_calib_disp_estimate(b.tip_height_nm, b.lever_length_nm, b.deflection_pm_per_v, &c_pm_per_v) != FW_OK || c_pm_per_v <= 0)
        return 0;
    return std::max(b.lateral_gain_pn_per_v, b.normal_gain_pn_per_v) / static_cast<double>(c_pm_per_v);   // pN/pm = N/m
}

HapticBound haptic_bound(const Scene &s, const fw_card_config_t &card)
{
    HapticBound h;
    h.lever_N_per_m = lever_stiffness_N_per_m(card.board);
    if (h.lever_N_per_m <= 0) return h;   // the card refuses this lever anyway (card_refusal names why)
    h.gain_N_per_N = fwu_n_per_nn_from_un_per_pn(card.haptic_un_per_pn) * 1e9;   // as the card renders it
    h.scale = stylus_scale(s);
    h.rendered_N_per_m = h.gain_N_per_N * h.lever_N_per_m * h.scale;
    h.rendered_z_N_per_m = h.gain_N_per_N * s.op.haptic.load_span_nN * 1e-9 / (s.op.haptic.half_range_mm * 1e-3);
    const double stiffest = std::max(h.rendered_N_per_m, h.rendered_z_N_per_m);
    h.period_s = 1.0 / s.block_hz;
    h.max_rendered_N_per_m = bound_N_per_m(s, h.period_s, h.delay_blocks);
    const double limit = std::min(h.max_rendered_N_per_m, s.op.haptic.max_stiffness_N_per_m);
    // The largest whole 0.001 N/nN strictly inside, for the stiffer axis.
    const double per_gain = std::max(h.lever_N_per_m * h.scale, s.op.haptic.load_span_nN * 1e-9 / (s.op.haptic.half_range_mm * 1e-3));
    h.max_gain_N_per_nN = (std::ceil(limit / per_gain * 1e-9 * 1e3) - 1) * 1e-3;
    h.passive = stiffest < h.max_rendered_N_per_m;
    h.within_device = stiffest <= s.op.haptic.max_stiffness_N_per_m;
    return h;
}

int32_t haptic_auto_gain_un_per_pn(const Scene &s, const fw_board_config_t &b)
{
    const double k = lever_stiffness_N_per_m(b);
    if (k <= 0) return 1;
    const HapticBound h;
    const double limit = std::min(bound_N_per_m(s, 1.0 / s.block_hz, h.delay_blocks), s.op.haptic.max_stiffness_N_per_m);
    const double per_gain = std::max(k * stylus_scale(s), s.op.haptic.load_span_nN * 1e-9 / (s.op.haptic.half_range_mm * 1e-3));
    const double g_N_per_nN = kAutoGainFraction * limit / per_gain * 1e-9;
    return std::max<int32_t>(1, static_cast<int32_t>(std::floor(g_N_per_nN * 1e3)));
}

std::string haptic_refusal(const Scene &s, const fw_card_config_t &card)
{
    if (!s.op.haptic.passivity_check || s.op.plan.enabled) return "";
    const HapticBound h = haptic_bound(s, card);
    if (h.lever_N_per_m <= 0 || (h.passive && h.within_device)) return "";
    std::ostringstream m;
    m.precision(4);
    m << "operator.haptic.force_gain_N_per_nN: the force loop is outside its stability bound: the card renders up to K_r = g k_c s = "
      << h.rendered_N_per_m << " N/m on the stylus (gain " << fwu_n_per_nn_from_un_per_pn(card.haptic_un_per_pn)
      << " N/nN, the lever's in-plane stiffness k_c " << h.lever_N_per_m << " N/m, s = operator.kappa " << s.op.kappa
      << " x sample.field_nm / 2 " << s.field_nm / 2 << " nm / operator.haptic.half_range_mm " << s.op.haptic.half_range_mm << " = "
      << h.scale << ")";
    if (h.rendered_z_N_per_m > 0)
        m << " and K_z = g operator.haptic.load_span_nN " << s.op.haptic.load_span_nN << " nN / half_range = " << h.rendered_z_N_per_m
          << " N/m on its z axis";
    m << ", ";
    if (!h.passive)
        m << "not below the passivity bound K_max = b / (T (1/2 + d)) = " << h.max_rendered_N_per_m << " N/m (operator.haptic.damping_Ns_per_m "
          << s.op.haptic.damping_Ns_per_m << ", T = 1 / block_hz = " << h.period_s << " s, d = 2 blocks)";
    else
        m << "above the device's operator.haptic.max_stiffness_N_per_m " << s.op.haptic.max_stiffness_N_per_m;
    m << "; the largest gain that passes is " << h.max_gain_N_per_nN
      << " N/nN (or leave the gain out: auto; or give the device more damping; or set operator.haptic.passivity_check: false to run "
         "with the passivity controller clamping)";
    return m.str();
}

}  // namespace afm
