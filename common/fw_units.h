/*
 * fw_units.h - the host's one conversion between doubles in physical units
 * and the firmware's integers (firmware/include/fw_types.h): pm, pN, uV,
 * ppm, mdeg and the Q formats, and back. Every host program that talks to
 * the firmware converts here (fw_node and replay through card_node, the
 * launcher's probe check through card_setup, the lever calculator).
 *
 * To the firmware: round half away from zero, saturate to int32; NaN is 0
 * (a host validates its inputs before; the conversion stays total).
 * From the firmware: exact (int32 and the Q formats' LSBs are exact in a
 * double).
 *
 * C99 and C++17; header only.
 */
#ifndef FW_UNITS_H
#define FW_UNITS_H

#include <math.h>
#include <stdint.h>

#include "fw_types.h"

#ifdef __cplusplus
extern "C" {
#endif

/* round(v), saturated to int32; NaN gives 0. */
static inline int32_t fwu_i32(double v)
{
    if (v != v) {
        return 0;
    }
    if (v >= 2147483647.0) {
        return INT32_MAX;
    }
    if (v <= -2147483648.0) {
        return INT32_MIN;
    }
    return (int32_t)lround(v);
}

/* v 2^frac, rounded and saturated: a Q format with frac fraction bits. */
static inline int32_t fwu_q(double v, int frac) { return fwu_i32(ldexp(v, frac)); }
static inline double fwu_from_q(int64_t q, int frac) { return ldexp((double)q, -frac); }

/* lengths */
static inline int32_t fwu_pm_from_nm(double nm) { return fwu_i32(nm * 1e3); }
static inline int32_t fwu_nm_from_um(double um) { return fwu_i32(um * 1e3); }
static inline double fwu_nm_from_pm(int64_t pm) { return (double)pm * 1e-3; }
/* forces */
static inline int32_t fwu_pn_from_nn(double nn) { return fwu_i32(nn * 1e3); }
static inline double fwu_nn_from_pn(int64_t pn) { return (double)pn * 1e-3; }
static inline double fwu_n_from_un(int64_t un) { return (double)un * 1e-6; }
static inline int32_t fwu_un_from_n(double n) { return fwu_i32(n * 1e6); }
/* the haptic gain: N of stylus force per nN of tip force = 10^3 uN/pN */
static inline int32_t fwu_un_per_pn_from_n_per_nn(double n_per_nn) { return fwu_i32(n_per_nn * 1e3); }
static inline double fwu_n_per_nn_from_un_per_pn(int64_t un_per_pn) { return (double)un_per_pn * 1e-3; }
/* voltages and gains per volt */
static inline int32_t fwu_uv_from_v(double v) { return fwu_i32(v * 1e6); }
static inline q23_t fwu_q23_from_v(double v) { return fwu_q(v, FW_Q23_FRAC); }
static inline int32_t fwu_pm_per_v_from_nm_per_v(double nm_per_v) { return fwu_i32(nm_per_v * 1e3); }
static inline int32_t fwu_pn_per_v_from_nn_per_v(double nn_per_v) { return fwu_i32(nn_per_v * 1e3); }
static inline double fwu_nn_per_v_from_pn_per_v(int64_t pn_per_v) { return (double)pn_per_v * 1e-3; }
static inline double fwu_nm_per_v_from_pm_per_v(int64_t pm_per_v) { return (double)pm_per_v * 1e-3; }
/* ratios and angles */
static inline int32_t fwu_ppm(double ratio) { return fwu_i32(ratio * 1e6); }
static inline int32_t fwu_mdeg_from_deg(double deg) { return fwu_i32(deg * 1e3); }
/* a binary angle (2^32 per turn) in degrees, [0, 360) */
static inline double fwu_deg_from_bam(fw_bam_t a) { return (double)a / 4294967296.0 * 360.0; }
static inline q15_t fwu_q15_from_unit(double v)
{
    int32_t q = fwu_q(v, FW_Q15_FRAC);
    return (q15_t)(q > FW_Q15_MAX ? FW_Q15_MAX : (q < FW_Q15_MIN ? FW_Q15_MIN : q));
}
static inline q16_t fwu_q16(double v) { return fwu_q(v, FW_Q16_FRAC); }
static inline q24_t fwu_q24(double v) { return fwu_q(v, FW_Q24_FRAC); }
static inline q30_t fwu_q30(double v) { return fwu_q(v, FW_Q30_FRAC); }
static inline double fwu_from_q30(int64_t q) { return fwu_from_q(q, FW_Q30_FRAC); }
/* friction per length: pN/um from nN/um */
static inline int32_t fwu_pn_per_um_from_nn_per_um(double nn_per_um) { return fwu_i32(nn_per_um * 1e3); }
/* pressures: kPa from MPa */
static inline int32_t fwu_kpa_from_mpa(double mpa) { return fwu_i32(mpa * 1e3); }

#ifdef __cplusplus
}
#endif

#endif /* FW_UNITS_H */
