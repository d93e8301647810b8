#include "fw_config.hpp"

#include <algorithm>
#include <cmath>

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

}  // namespace afm
