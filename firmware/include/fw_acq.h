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
 * Quantisation (bits = 12, 14 or 16, full scale FW_ACQ_FS_UV = 10 V):
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

#define FW_ACQ_FS_UV 10000000          /* +-10 V card input range, microvolts */
#define FW_ACQ_FILTER_LOG2_MAX 4
#define FW_ACQ_FILTER_LEN_MAX (1 << FW_ACQ_FILTER_LOG2_MAX)

typedef struct {
    int32_t bits;                 /* 12, 14 or 16 */
    int32_t filter_log2;          /* 0..FW_ACQ_FILTER_LOG2_MAX */
    q23_t lsb_v;                  /* one code in 9.23 volts (exact) */
    q23_t baseline_v;             /* subtracted zero-force offset, 9.23 V */
    int32_t hist[FW_ACQ_FILTER_LEN_MAX]; /* last codes, ring */
    int32_t hist_pos;
    int32_t hist_fill;
    int32_t hist_sum;             /* sum of the codes in hist */
    q23_t last_v;                 /* latest filtered signal before the baseline */
    bool sat_sticky;              /* any saturated sample since reset */
    uint32_t sat_count;           /* saturated samples since reset */
} fw_acq_t;

/* Validates bits (12, 14, 16) and filter_log2 (0..4); zeroes the state and
 * the baseline. FW_ERR_ARG otherwise (instance untouched). */
fw_status_t fw_acq_init(fw_acq_t *a, int32_t bits, int32_t filter_log2);

/* Clears the filter, the sticky flag and the counter; keeps bits, filter
 * and the baseline. */
void fw_acq_reset(fw_acq_t *a);

/* Pure quantiser. Returns the code; *sat (may be NULL) = |uv| >= 10 V.
 * Scaling and overflow: uv is clamped to +-10 V first, then
 * |uv| * 2^(bits-8) < 2^32 is divided by 78125 (= 10^7 / 2^7) in unsigned
 * 32-bit arithmetic, exactly; the top code clamps to 2^(bits-1) - 1.
 * bits outside {12, 14, 16} is a caller bug: the result is 0. */
int32_t fw_acq_quantize_code(int32_t bits, int32_t uv, bool *sat);

/* Code to 9.23 volts, exact (see above). */
q23_t fw_acq_code_to_q23(int32_t bits, int32_t code);

/* One sample: quantise, filter, subtract the baseline.
 * *code_out: the raw code of this sample; *v_out: filtered, baseline
 * corrected signal, 9.23 V; *sat_out: this sample saturated.
 * Scaling and overflow: the filter sums at most 16 codes of at most 16 bits
 * in int32; the baseline difference (at most 20 V) fits 9.23. */
fw_status_t fw_acq_step_q23(fw_acq_t *a, int32_t uv, int32_t *code_out,
                            q23_t *v_out, bool *sat_out);

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
                                  int32_t kn_pm_per_v, q23_t *sn_virtual_v, bool *sat);

#endif /* FW_ACQ_H */
