/*
 * fw_acq.c - see fw_acq.h.
 */
#include "fw_acq.h"
#include "fw_math.h"

/* Full scale 10^7 uV = 2^7 * 78125. code = uv * 2^(bits-1) / 10^7
 * = uv * 2^(bits-1-7) / 78125; |uv| * 2^(bits-8) <= 2.56e9 fits uint32. */
#define ACQ_FS_POW2 7
#define ACQ_FS_ODD_UV ((uint32_t)(FW_ACQ_FS_UV >> ACQ_FS_POW2))
#define ACQ_SPAN_V (2 * (FW_ACQ_FS_UV / FW_UV_PER_V))   /* 20 V from -10 V to +10 V */

static bool acq_bits_valid(int32_t bits)
{
    return bits == 12 || bits == 14 || bits == 16;
}

int32_t fw_acq_quantize_code(int32_t bits, int32_t uv, bool *sat)
{
    uint32_t mag;
    uint32_t code_mag;
    uint32_t top;
    bool s = (uv >= FW_ACQ_FS_UV) || (uv <= -FW_ACQ_FS_UV);
    if (sat != NULL) {
        *sat = s;
    }
    if (!acq_bits_valid(bits)) {
        return 0;
    }
    if (uv > FW_ACQ_FS_UV) {
        uv = FW_ACQ_FS_UV;
    }
    if (uv < -FW_ACQ_FS_UV) {
        uv = -FW_ACQ_FS_UV;
    }
    mag = (uint32_t)(uv < 0 ? -uv : uv);
    /* the divisor is odd, so an exact half never occurs: this is round() */
    code_mag = ((mag << (bits - 1 - ACQ_FS_POW2)) + ACQ_FS_ODD_UV / 2u) / ACQ_FS_ODD_UV;
    top = (uint32_t)1 << (bits - 1);
    if (uv >= 0) {
        return (int32_t)((code_mag >= top) ? top - 1u : code_mag);
    }
    return -(int32_t)((code_mag > top) ? top : code_mag);
}

q23_t fw_acq_code_to_q23(int32_t bits, int32_t code)
{
    if (!acq_bits_valid(bits)) {
        return 0;
    }
    return code * (ACQ_SPAN_V << (FW_Q23_FRAC - bits));
}

fw_status_t fw_acq_init(fw_acq_t *a, int32_t bits, int32_t filter_log2)
{
    if (a == NULL || !acq_bits_valid(bits) || filter_log2 < 0
        || filter_log2 > FW_ACQ_FILTER_LOG2_MAX) {
        return FW_ERR_ARG;
    }
    a->bits = bits;
    a->filter_log2 = filter_log2;
    a->lsb_v = fw_acq_code_to_q23(bits, 1);
    a->baseline_v = 0;
    fw_acq_reset(a);
    return FW_OK;
}

void fw_acq_reset(fw_acq_t *a)
{
    int32_t i;
    for (i = 0; i < FW_ACQ_FILTER_LEN_MAX; i++) {
        a->hist[i] = 0;
    }
    a->hist_pos = 0;
    a->hist_fill = 0;
    a->hist_sum = 0;
    a->last_v = 0;
    a->sat_sticky = false;
    a->sat_count = 0;
}

fw_status_t fw_acq_step_q23(fw_acq_t *a, int32_t uv, int32_t *code_out,
                            q23_t *v_out, bool *sat_out)
{
    bool sat = false;
    int32_t code;
    q23_t v;
    if (a == NULL || code_out == NULL || v_out == NULL || sat_out == NULL) {
        return FW_ERR_ARG;
    }
    code = fw_acq_quantize_code(a->bits, uv, &sat);
    if (sat) {
        a->sat_sticky = true;
        if (a->sat_count != UINT32_MAX) {
            a->sat_count++;
        }
    }
    if (a->filter_log2 == 0) {
        v = code * a->lsb_v;
    } else {
        int32_t len = (int32_t)1 << a->filter_log2;
        a->hist_sum += code - a->hist[a->hist_pos];
        a->hist[a->hist_pos] = code;
        a->hist_pos = (a->hist_pos + 1) & (len - 1);
        if (a->hist_fill < len) {
            a->hist_fill++;
        }
        v = (q23_t)fw_math_div_round_i64((int64_t)a->hist_sum * a->lsb_v, a->hist_fill);
    }
    a->last_v = v;
    *code_out = code;
    *v_out = v - a->baseline_v;
    *sat_out = sat;
    return FW_OK;
}

void fw_acq_record_baseline(fw_acq_t *a)
{
    a->baseline_v = a->last_v;
}

fw_status_t fw_acq_set_baseline_q23(fw_acq_t *a, q23_t v)
{
    const q23_t fs_v = (FW_ACQ_FS_UV / FW_UV_PER_V) * FW_Q23_ONE;
    if (a == NULL || v > fs_v || v < -fs_v) {
        return FW_ERR_ARG;
    }
    a->baseline_v = v;
    return FW_OK;
}

fw_status_t fw_acq_virtual_sn_q23(q23_t sn_ref_v, int32_t z_ref_pm, int32_t z_pm,
                                  int32_t kn_pm_per_v, q23_t *sn_virtual_v, bool *sat)
{
    int64_t dz;
    int64_t dv;
    if (sn_virtual_v == NULL || kn_pm_per_v <= 0) {
        return FW_ERR_ARG;
    }
    dz = (int64_t)z_ref_pm - z_pm;
    dv = fw_math_div_round_i64(dz * FW_Q23_ONE, kn_pm_per_v);
    *sn_virtual_v = fw_math_sat_i32((int64_t)sn_ref_v + dv, sat);
    return FW_OK;
}
