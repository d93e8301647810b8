/*
 * fw_acq.h - acquisition of one photodiode channel: ADC quantisation of the
 * +-10 V card input, optional moving-average decimation filter, zero-force
 * baseline, saturation detection. Plus the virtual normal output of
 * physics.md section 3.
 *
 * Units and formats
 *   input      int32 microvolts at the card's input (the analog wire)
 *   code       ADC code, signed, [-2^(bits-1), 2^(bits-1) - 1]
 *   signal     9.23 volts (q23_t), range [-256 V, 256 V)
 *
 * Quantisation (bits = 8 to 16, full scale FW_ACQ_FS_UV = 10 V):
 *   code = round(uv * 2^(bits-1) / 10 V), half away from zero, clamped to the
 *   code range. Code to volts is exact: v = code * 20 V / 2^bits, i.e.
 *   code * (20 << (23 - bits)) in 9.23.
 *
 * Saturation: an input with |uv| >= 10 V (at or past the rail) is saturated:
 * the sample's flag is set, the sticky flag latches until reset, and the
 * counter counts saturated samples (it saturates at UINT32_MAX). Saturation
 * is not an error: the step returns FW_OK and the clamped code.
 *
 * Filter: moving average over 2^filter_log2 samples (filter_log2 in 0..4,
 * 0 = off). Until the window is full, the average is over the samples seen.
 * The baseline (zero-force offset, 9.23 V) is subtracted after the filter.
 */
#ifndef FW_ACQ_H
#define FW_ACQ_H

#include "fw_types.h"
#include "fw_math.h"
#include "fw_rules.h"

#define FW_ACQ_FS_UV 10000000          /* +-10 V card input range, microvolts */
/* ADC widths: the reciprocal quantiser below needs bits >= 8 (G = M 2^(bits-8))
 * and stays exact up to 16 (the proof's largest n). */
#define FW_ACQ_BITS_MIN 8
#define FW_ACQ_BITS_MAX 16
#define FW_ACQ_FILTER_LOG2_MAX 4
#define FW_ACQ_FILTER_LEN_MAX (1 << FW_ACQ_FILTER_LOG2_MAX)

/* The quantiser divides by 78125 = 10^7 / 2^7 with a reciprocal multiply:
 * floor(n / 78125) = (n * M) >> 47 with M = ceil(2^47 / 78125) =
 * 1801439851, exact for 0 <= n < 2^47 / e = 3.48e10, where
 * e = M 78125 - 2^47 = 4047: n M / 2^47 = n / 78125 + n e / (78125 2^47)
 * and n e < 2^47 keeps the excess below 1 / 78125, too small to reach the
 * next integer. The largest n is 2 FS 2^8 + 39062 = 5.12e9 (16 bits), and
 * n M < 1.0000077 2^63 < 2^64 then, so the product never wraps in uint64.
 * tests/firmware/test_acq.c checks every input from -FS to FS. */
#define FW_ACQ_RCP_MUL 1801439851u
#define FW_ACQ_RCP_SHIFT 47
#define FW_ACQ_RCP_ODD_UV 78125u          /* 10^7 / 2^7 */
#define FW_ACQ_RCP_POW2 7

typedef struct {
    int32_t bits;                 /* FW_ACQ_BITS_MIN..FW_ACQ_BITS_MAX */
    int32_t filter_log2;          /* 0..FW_ACQ_FILTER_LOG2_MAX */
    q23_t lsb_v;                  /* one code in 9.23 volts (exact) */
    uint64_t rcp_gain;            /* FW_ACQ_RCP_MUL 2^(bits-8), set by init */
    uint64_t rcp_bias;            /* FW_ACQ_RCP_MUL (78125 - 1) / 2, set by init */
    int32_t half_codes;           /* 2^(bits-1) */
    int64_t rcp_bias_uv;          /* K = FS G + B - half_codes 2^47: the kernel on uv itself */
    int32_t fast_lo_uv;           /* fast range [fast_lo_uv, fast_lo_uv + fast_span_uv): */
    uint32_t fast_span_uv;        /*   unsaturated and below the top code's clamp */
    q23_t baseline_v;             /* subtracted zero-force offset, 9.23 V */
    int32_t hist[FW_ACQ_FILTER_LEN_MAX]; /* last codes, ring */
    int32_t hist_pos;
    int32_t hist_fill;
    int32_t hist_sum;             /* sum of the codes in hist */
    q23_t last_v;                 /* latest filtered signal before the baseline */
    bool sat_sticky;              /* any saturated sample since reset */
    uint32_t sat_count;           /* saturated samples since reset */
} fw_acq_t;

/* The first rule broken: bits outside 8..16 (FW_RULE_ADC_BITS),
 * filter_log2 outside 0..4 (FW_RULE_ADC_FILTER). */
fw_rule_t fw_acq_check(int32_t bits, int32_t filter_log2);

/* Validates with fw_acq_check (FW_ERR_ARG, instance untouched); zeroes the
 * state and the baseline. */
fw_status_t fw_acq_init(fw_acq_t *a, int32_t bits, int32_t filter_log2);

/* Clears the filter, the sticky flag and the counter; keeps bits, filter
 * and the baseline. */
void fw_acq_reset(fw_acq_t *a);

/* Pure quantiser. Returns the code; *sat (may be NULL) = |uv| >= 10 V.
 * Scaling and overflow: uv is clamped to +-10 V first and offset to
 * t = uv + 10 V in [0, 2 10^7]; then
 *   code = floor((t 2^(bits-8) + 39062) / 78125) - 2^(bits-1)
 * which is round(uv 2^(bits-1) / 10^7) exactly: 78125 is odd, so no exact
 * half occurs and adding the integer 2^(bits-1) commutes with rounding. The
 * division is the reciprocal multiply above, (t G + B) >> 47 with
 * G = M 2^(bits-8), B = M 39062, in uint64 (< 2^64); exact over the whole
 * clamped range. The top code clamps to 2^(bits-1) - 1.
 * bits outside 8..16 is a caller bug: the result is 0. */
int32_t fw_acq_quantize_code(int32_t bits, int32_t uv, bool *sat);

/* The reciprocal quantiser's kernel for |uv| <= FW_ACQ_FS_UV (the caller
 * clamps; see fw_acq_quantize_code): gain, bias and half_codes as in
 * fw_acq_t. */
static inline int32_t fw_acq_code_rcp(int32_t uv, uint64_t gain, uint64_t bias,
                                      int32_t half_codes)
{
    uint64_t t = (uint64_t)(uint32_t)(uv + FW_ACQ_FS_UV);
    int32_t c = (int32_t)((t * gain + bias) >> FW_ACQ_RCP_SHIFT) - half_codes;
    return (c < half_codes) ? c : half_codes - 1;
}

/* The fast range of an instance: the inputs that are not saturated
 * (|uv| < FS) and whose code needs no clamp at the top, i.e.
 * uv in [-(FS - 1), uv_top - 1] with uv_top the smallest input that
 * rounds to 2^(bits-1): t = uv_top + FS is the smallest t with
 * t 2^(bits-8) + 39062 >= 2^bits 78125 (uv_top = 9999848 at 16 bits,
 * 9999390 at 14, 9997559 at 12). One unsigned compare, as the saturation
 * test. Inline (per sample). */
static inline bool fw_acq_in_fast_range(const fw_acq_t *a, int32_t uv)
{
    return (uint32_t)uv - (uint32_t)a->fast_lo_uv < a->fast_span_uv;
}

/* The code of an input in the fast range (fw_acq_in_fast_range): the
 * kernel of fw_acq_code_rcp with the offset t = uv + FS and the
 * subtraction of 2^(bits-1) folded into one constant,
 *   code = floor((uv G + K) / 2^47),  K = FS G + B - 2^(bits-1) 2^47,
 * which equals floor((t G + B) / 2^47) - 2^(bits-1) exactly (subtracting
 * an integer multiple of 2^47 commutes with the floor).
 * Scaling and overflow: FS G = 2^(bits-1) (2^47 + e) (e = 4047, above),
 * so K = 2^(bits-1) e + B < 2^47; |uv G| <= 10^7 M 2^8 < 2^62.1 (16 bits),
 * the sum < 2^63 in int64, no wrap; no clamp needed in the fast range.
 * Same code as fw_acq_code_rcp there (tests/firmware/test_acq.c checks
 * every input of the range). Inline (per sample). */
static inline int32_t fw_acq_code_fast(const fw_acq_t *a, int32_t uv)
{
    return (int32_t)fw_math_asr_i64((int64_t)uv * (int64_t)a->rcp_gain + a->rcp_bias_uv,
                                    FW_ACQ_RCP_SHIFT);
}

/* Code to 9.23 volts, exact (see above). */
q23_t fw_acq_code_to_q23(int32_t bits, int32_t code);

/* The moving average of fw_acq_step_q23 (filter_log2 > 0): pushes code,
 * returns the mean of the codes in the window in 9.23 V, rounded. */
q23_t fw_acq_filter_q23(fw_acq_t *a, int32_t code);

/* One sample: quantise, filter, subtract the baseline.
 * *code_out: the raw code of this sample; *v_out: filtered, baseline
 * corrected signal, 9.23 V; *sat_out: this sample saturated.
 * Scaling and overflow: the filter sums at most 16 codes of at most 16 bits
 * in int32; the baseline difference (at most 20 V) fits 9.23.
 * Inline (per-sample path). The saturation test is one unsigned compare:
 * |uv| >= FS <=> (uint32)(uv + FS - 1) >= 2 FS - 1. */
static inline fw_status_t fw_acq_step_q23(fw_acq_t *a, int32_t uv, int32_t *code_out,
                                          q23_t *v_out, bool *sat_out)
{
    bool sat;
    int32_t code;
    q23_t v;
    if (a == NULL || code_out == NULL || v_out == NULL || sat_out == NULL) {
        return FW_ERR_ARG;
    }
    sat = (uint32_t)uv + (uint32_t)(FW_ACQ_FS_UV - 1) >= (uint32_t)(2 * FW_ACQ_FS_UV - 1);
    if (sat) {
        uv = (uv < 0) ? -FW_ACQ_FS_UV : FW_ACQ_FS_UV;
        a->sat_sticky = true;
        if (a->sat_count != UINT32_MAX) {
            a->sat_count++;
        }
    }
    code = fw_acq_code_rcp(uv, a->rcp_gain, a->rcp_bias, a->half_codes);
    v = (a->filter_log2 == 0) ? code * a->lsb_v : fw_acq_filter_q23(a, code);
    a->last_v = v;
    *code_out = code;
    *v_out = v - a->baseline_v;
    *sat_out = sat;
    return FW_OK;
}

/* Takes a code of an instance without filter (filter_log2 == 0) as its
 * latest signal: last_v = code lsb_v, returns the baseline-corrected
 * signal (9.23 V). With fw_acq_code_fast, for an input in the fast range
 * (fw_acq_in_fast_range), it is fw_acq_step_q23 without saturation: no
 * flag, counter or clamp, the same code, signal and state (test_acq checks
 * every input of the range). Scaling and overflow: |code lsb_v| <= 10 V (exact in
 * 9.23), the baseline is within +-10 V (fw_acq_set_baseline_q23,
 * fw_acq_record_baseline), so the result lies within +-20 V (< 2^27.33 in
 * 9.23). Inline. */
static inline q23_t fw_acq_take_code_q23(fw_acq_t *a, int32_t code)
{
    q23_t v = code * a->lsb_v;
    a->last_v = v;
    return v - a->baseline_v;
}

/* The baseline-corrected signal of a code (9.23 V), without touching the
 * instance: code lsb_v - baseline_v (the unfiltered signal of that code).
 * Scaling and overflow: as fw_acq_take_code_q23, within +-20 V. */
static inline q23_t fw_acq_signal_of_code_q23(const fw_acq_t *a, int32_t code)
{
    return code * a->lsb_v - a->baseline_v;
}

/* A gain G applied to the baseline-corrected signal of an instance without
 * filter, straight from the code:
 *   round(G (code lsb_v - baseline_v) / 2^shift)
 *     = floor((code mul + add) / 2^shift),
 *   mul = G lsb_v,  add = 2^(shift-1) - G baseline_v,
 * exact (integer algebra: the same value as fw_math_rshift_round_i64(G v,
 * shift) on the signal v that fw_acq_take_code_q23 returns), one multiply
 * and one add per code instead of two of each. Formed once per baseline by
 * fw_board_step_block's fast path; valid until the baseline changes.
 * Scaling and overflow: any int32 G, shift in 1..62; |code lsb_v| and
 * |baseline_v| <= 10 V < 2^26.33 in 9.23, so |mul|, |G baseline_v| <
 * 2^57.33 and |code mul + add| < 2^58.4 in int64. */
typedef struct {
    int64_t mul;
    int64_t add;
} fw_acq_gain_t;

static inline fw_acq_gain_t fw_acq_gain(const fw_acq_t *a, int32_t gain, int shift)
{
    fw_acq_gain_t g;
    g.mul = (int64_t)gain * a->lsb_v;
    g.add = ((int64_t)1 << (shift - 1)) - (int64_t)gain * a->baseline_v;
    return g;
}

static inline int64_t fw_acq_gain_apply(fw_acq_gain_t g, int32_t code, int shift)
{
    return fw_math_asr_i64(code * g.mul + g.add, shift);
}

/* Records the latest filtered signal as the zero-force baseline. */
void fw_acq_record_baseline(fw_acq_t *a);

/* Sets the baseline explicitly (9.23 V); |v| must be <= 10 V else FW_ERR_ARG. */
fw_status_t fw_acq_set_baseline_q23(fw_acq_t *a, q23_t v);

/* ---- virtual normal output (physics.md section 3) ----------------------
 * While S_n is saturated the deflection keeps following the piezo: pushing
 * the piezo down by dz (z up, so dz = z_ref - z) adds dz / K_n volts.
 *   S_n' = S_n,ref + (z_ref - z) / K_n
 * with (S_n,ref, z_ref) the last unsaturated sample.
 * Scaling and overflow: dz in pm (64-bit difference), K_n in pm/V;
 * dz * 2^23 / K_n rounded, the sum saturated to 9.23 (+-256 V).
 * K_n <= 0 returns FW_ERR_ARG. *sat set if clamped. */
fw_status_t fw_acq_virtual_sn_q23(q23_t sn_ref_v, int32_t z_ref_pm, int32_t z_pm,
                                  int32_t deflection_pm_per_v, q23_t *sn_virtual_v, bool *sat);

#endif /* FW_ACQ_H */
