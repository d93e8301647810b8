/*
 * fw_acq.c - see fw_acq.h.
 */
#include "fw_acq.h"
#include "fw_math.h"

#define ACQ_SPAN_V (2 * (FW_ACQ_FS_UV / FW_UV_PER_V))   /* 20 V from -10 V to +10 V */
#define ACQ_RCP_BIAS ((uint64_t)FW_ACQ_RCP_MUL * ((FW_ACQ_RCP_ODD_UV - 1u) / 2u))

static bool acq_bits_valid(int32_t bits)
{
    return bits >= FW_ACQ_BITS_MIN && bits <= FW_ACQ_BITS_MAX;
}

/* G = M 2^(bits-8) of fw_acq_quantize_code, bits valid. */
static uint64_t acq_rcp_gain(int32_t bits)
{
    return (uint64_t)FW_ACQ_RCP_MUL << (bits - 1 - FW_ACQ_RCP_POW2);
}

int32_t fw_acq_quantize_code(int32_t bits, int32_t uv, bool *sat)
{
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
    return fw_acq_code_rcp(uv, acq_rcp_gain(bits), ACQ_RCP_BIAS, (int32_t)1 << (bits - 1));
}

q23_t fw_acq_code_to_q23(int32_t bits, int32_t code)
{
    if (!acq_bits_valid(bits)) {
        return 0;
    }
    return code * (ACQ_SPAN_V << (FW_Q23_FRAC - bits));
}

/* uv_top - 1 of fw_acq_in_fast_range: t_top = ceil((2^bits 78125 - 39062)
 * / 2^(bits-8)), all in int64 (< 2^33). */
static int32_t acq_fast_hi_uv(int32_t bits)
{
    int64_t num = ((int64_t)FW_ACQ_RCP_ODD_UV << bits) - (int64_t)((FW_ACQ_RCP_ODD_UV - 1u) / 2u);
    int64_t den = (int64_t)1 << (bits - 1 - FW_ACQ_RCP_POW2);
    return (int32_t)((num + den - 1) / den) - FW_ACQ_FS_UV - 1;
}

fw_rule_t fw_acq_check(int32_t bits, int32_t filter_log2)
{
    if (!acq_bits_valid(bits)) {
        return FW_RULE_ADC_BITS;
    }
    if (filter_log2 < 0 || filter_log2 > FW_ACQ_FILTER_LOG2_MAX) {
        return FW_RULE_ADC_FILTER;
    }
    return FW_RULE_OK;
}

fw_status_t fw_acq_init(fw_acq_t *a, int32_t bits, int32_t filter_log2)
{
    fw_rule_t rule = fw_acq_check(bits, filter_log2);
    if (a == NULL) {
        return FW_ERR_ARG;
    }
    if (rule != FW_RULE_OK) {
        return fw_rule_status(rule);
    }
    a->bits = bits;
    a->filter_log2 = filter_log2;
    a->lsb_v = fw_acq_code_to_q23(bits, 1);
    a->rcp_gain = acq_rcp_gain(bits);
    a->rcp_bias = ACQ_RCP_BIAS;
    a->half_codes = (int32_t)1 << (bits - 1);
    /* K = FS G + B - 2^(bits-1) 2^47 (fw_acq_code_fast), formed in uint64:
     * FS G < 2^64, and the difference is positive and < 2^47 */
    a->rcp_bias_uv = (int64_t)((uint64_t)FW_ACQ_FS_UV * a->rcp_gain + a->rcp_bias
                               - ((uint64_t)a->half_codes << FW_ACQ_RCP_SHIFT));
    a->fast_lo_uv = -(FW_ACQ_FS_UV - 1);
    a->fast_span_uv = (uint32_t)(acq_fast_hi_uv(bits) - a->fast_lo_uv) + 1u;
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

q23_t fw_acq_filter_q23(fw_acq_t *a, int32_t code)
{
    int32_t len = (int32_t)1 << a->filter_log2;
    a->hist_sum += code - a->hist[a->hist_pos];
    a->hist[a->hist_pos] = code;
    a->hist_pos = (a->hist_pos + 1) & (len - 1);
    if (a->hist_fill < len) {
        a->hist_fill++;
    }
    return (q23_t)fw_math_div_round_i64((int64_t)a->hist_sum * a->lsb_v, a->hist_fill);
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
                                  int32_t deflection_pm_per_v, q23_t *sn_virtual_v, bool *sat)
{
    int64_t dz;
    int64_t dv;
    if (sn_virtual_v == NULL || deflection_pm_per_v <= 0) {
        return FW_ERR_ARG;
    }
    dz = (int64_t)z_ref_pm - z_pm;
    dv = fw_math_div_round_i64(dz * FW_Q23_ONE, deflection_pm_per_v);
    *sn_virtual_v = fw_math_sat_i32((int64_t)sn_ref_v + dv, sat);
    return FW_OK;
}
