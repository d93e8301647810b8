#include "fw_config.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace afm {

int32_t to_i32(double v)
{
    if (!(v == v)) return 0;
    return static_cast<int32_t>(std::llround(std::clamp(v, -2147483648.0, 2147483647.0)));
}

double cn_estimate_nm_per_V(const ProbeSpec &p)
{
    return 3.0 * p.tip_height_um * p.Kn_nm_per_V / (2.0 * p.lever_length_um);
}

double particle_threshold_nN(const Scene &s)
{
    const ContactSpec &ps = s.particle_substrate;
    const double adh = s.has_effect("adhesion") ? ps.adhesion_nN : 0.0;
    return ps.mu * adh + ps.shear_strength_MPa * ps.contact_area_nm2 * 1e-3;
}

fw_board_config_t board_config(const Scene &s)
{
    const ProbeSpec &p = s.probe;
    fw_board_config_t c{};
    c.adc_bits = s.adc_bits;
    c.kn_Kn_pn_per_v = to_i32(p.kn_N_per_m * p.Kn_nm_per_V * 1e3);
    c.lat_pn_per_v = to_i32(p.lateral_nN_per_V * 1e3);
    c.Kn_pm_per_v = to_i32(p.Kn_nm_per_V * 1e3);
    c.tip_height_nm = to_i32(p.tip_height_um * 1e3);
    c.lever_length_nm = to_i32(p.lever_length_um * 1e3);
    c.cn_pm_per_v = to_i32(cn_estimate_nm_per_V(p) * 1e3);
    c.cl_pm_per_v = to_i32(cn_estimate_nm_per_V(p) * 1e3);
    c.scan_angle_mdeg = to_i32(p.scan_angle_deg * 1e3);
    c.mu_ppm = to_i32(s.tip_substrate.mu * 1e6);
    c.adhesion_pn = to_i32((s.has_effect("adhesion") ? s.tip_substrate.adhesion_nN : 0.0) * 1e3);
    c.scan_center_pm[0] = to_i32(s.field_center_nm.x * 1e3);
    c.scan_center_pm[1] = to_i32(s.field_center_nm.y * 1e3);
    c.scan_half_range_pm = to_i32(s.field_nm / 2 * 1e3);
    c.kappa_q16 = to_i32(s.op.kappa * 65536.0);
    return c;
}

std::string board_config_refusal(const Scene &s)
{
    const fw_board_config_t c = board_config(s);
    fw_board_t b;
    const fw_status_t st = fw_board_init(&b, &c);
    if (st == FW_OK) return "";
    const ProbeSpec &p = s.probe;
    const double two_h_over_l = 2.0 * p.tip_height_um / p.lever_length_um;
    std::ostringstream m;
    m.precision(7);
    if (c.cn_pm_per_v > FW_COMP_C_MAX_PM_PER_V) {
        m << "probe: the firmware's bending compensation holds C_n = 3 h K_n / (2 l) up to "
          << FW_COMP_C_MAX_PM_PER_V / 1e3 << " nm/V, got " << cn_estimate_nm_per_V(p) << " nm/V (tip_height_um "
          << p.tip_height_um << ", Kn_nm_per_V " << p.Kn_nm_per_V << ", lever_length_um " << p.lever_length_um << ")";
    } else if (!(two_h_over_l < 2.0)) {
        m << "probe: the firmware's force model (eq. 1c) needs 2 h / l < 2, got 2 tip_height_um / lever_length_um = "
          << two_h_over_l << " (tip_height_um " << p.tip_height_um << ", lever_length_um " << p.lever_length_um << ")";
    } else if (s.tip_substrate.mu * two_h_over_l > 0.5) {
        m << "sample.tip_substrate.mu: the firmware's friction fallback needs mu 2h/l <= 1/2, got mu "
          << s.tip_substrate.mu << " with 2h/l = " << two_h_over_l << " (probe.tip_height_um " << p.tip_height_um
          << ", probe.lever_length_um " << p.lever_length_um << ")";
    } else {
        m << "probe: the firmware refuses the scene's probe configuration (fw_board_init status " << st << ")";
    }
    return m.str();
}

}  // namespace afm
