/*
 * fw_board16.h - the signal chain of fw_board (acquisition -> compensation
 * -> direction -> force -> frame A, physics.md sections 1, 3, 4) on a
 * 16-bit data path: the card's cheaper alternative (firmware.word_bits:
 * 16), and what it costs in accuracy (./afm sweep, ./afm bench firmware).
 *
 * "16-bit" means: every signal, gain, coefficient and direction is an
 * int16 (1.15, or an int16 mantissa with a fixed shift), every multiply is
 * 16 x 16 -> 32, divisions are 32 / 16, sums and shifts are 32-bit (a
 * 16-bit DSP's accumulator). Positions and forces that need more than 16
 * bits (scanner pm, pN) are int32 and are only added, shifted, or
 * multiplied by a 1.15 value as two 16 x 16 products (fw_board16_mul_i32).
 *
 * Formats
 *   S_n, S_l     1.15 of 10 V: the ADC code (fw_acq, adc_bits) << (16 - bits)
 *   gains        value = S mant >> (15 - k), mant int16, k fixed per gain
 *   offset       int16 in units of 2^off_k pm
 *   cos/sin a    1.15 (cos 0 = 32767)
 *   direction    (cx, cy): the window displacement in frame C, normalised
 *                into [2^13, 2^14) by shifts, not a unit vector
 *   cot theta    4.12, |cot| <= 8 where it is used
 *   mu, 2h/l     1.15; the fallback's denominator 2.14
 *
 * The same model as fw_board with these differences (the price of 16 bits):
 *   - |sin theta| and cos theta are formed only where the fallback needs
 *     them (|sin| < 1/4), from t = tan theta by the series
 *     cos = 1 - t^2/2 + 3t^4/8, sin = t cos (error < 2e-5 for |t| <= 0.26);
 *     elsewhere the zone tests use squares and F_x = F_y cx / cy;
 *   - the friction fallback's |mu cos (N + F_adh)| saturates at 131071 pN
 *     (FW_BOARD16_FALLBACK_MAX_PN; FW_FLAG_SAT_FORCE);
 *   - no ADC filter and no baseline (the card uses neither), no virtual S_n:
 *     a saturated S_n stays at the rail (FW_FLAG_SAT_SN).
 * Flags raised: FW_FLAG_SAT_SN, FW_FLAG_SAT_SL, FW_FLAG_THETA_UNKNOWN,
 * FW_FLAG_FX_UNOBSERVABLE (|sin theta| < 1/4), FW_FLAG_SAT_FORCE,
 * FW_FLAG_SAT_POS (the apex clamped to int32).
 *
 * Domain (fw_board16_check, FW_RULE_WORD16_RANGE): the full scales k_n K_n
 * 10 V and k_theta K_l / h 10 V at most 2^20 pN (1.05 uN; the paper's lever
 * has 107 nN and 379 nN), C_n, C_l at most 2^21 pm/V, F_adh at most 2^26 pN;
 * inside it no product leaves its width (the Scaling and overflow notes of
 * fw_board16.c).
 *
 * Error contract: against the reference model of the same equations fed the
 * same ADC codes, the force in frame A is within 0.5 % of k_n K_n 10 V in
 * the worst case and 0.05 % RMS over tests/firmware/test_board16.c's sweep
 * (friction loops at every direction, both scan angles, the blend zone
 * included), which asserts both and prints what it measures; ./afm bench
 * firmware prints it beside the 32-bit path's.
 */
#ifndef FW_BOARD16_H
#define FW_BOARD16_H

#include "fw_types.h"
#include "fw_rules.h"
#include "fw_board.h"
#include "fw_acq.h"

#define FW_BOARD16_GAIN_FS_MAX_PN ((int32_t)1 << 20)
#define FW_BOARD16_DISP_MAX_PM_PER_V ((int32_t)1 << 21)
#define FW_BOARD16_ADHESION_MAX_PN ((int32_t)1 << 26)
#define FW_BOARD16_FALLBACK_MAX_PN 131071

typedef struct {
    fw_acq_t acq;          /* the ADC's quantiser (its width), shared with fw_board */
    int16_t code_shift;    /* 16 - adc_bits: the code to 1.15 of 10 V */
    int16_t n_mant;        /* k_n K_n 10 V = n_mant 2^n_k, pN */
    int16_t n_k;
    int16_t lat_mant;      /* k_theta K_l / h 10 V = lat_mant 2^lat_k, pN */
    int16_t lat_k;
    int16_t cn_mant;       /* C_n 10 V / 2^off_k, pm */
    int16_t cl_mant;       /* C_l 10 V / 2^off_k, pm */
    int16_t off_k;
    int16_t cos_a;         /* 1.15 */
    int16_t sin_a;
    int16_t two_h_over_l;  /* 1.15 */
    int16_t mu;            /* 1.15 */
    int32_t adhesion_pn;
    int32_t min_disp2_pm2; /* (minimum displacement)^2, < 2^28 */
    int32_t x_pm[FW_THETA_WINDOW];
    int32_t y_pm[FW_THETA_WINDOW];
    int32_t pos;
    int32_t fill;
    int16_t cx;            /* latest direction, frame C, normalised */
    int16_t cy;
    bool known;
    int16_t last_sn;       /* the latest sample's signals, 1.15 of 10 V */
    int16_t last_sl;
} fw_board16_t;

/* fw_board_check's rules, then the 16-bit domain (FW_RULE_WORD16_RANGE)
 * and no ADC filter (FW_RULE_ADC_FILTER). */
fw_rule_t fw_board16_check(const fw_board_config_t *cfg);
/* Validates with fw_board16_check (its rule's status; FW_ERR_ARG for a NULL
 * b); the configuration's theta_min_disp_pm (0: 1000 pm) must be below
 * 2^14 pm (FW_RULE_WORD16_RANGE). */
fw_status_t fw_board16_init(fw_board16_t *b, const fw_board_config_t *cfg);
void fw_board16_reset(fw_board16_t *b);
/* n samples (the DMA block), as fw_board_step_block: out[i] belongs to
 * in[i]. FW_ERR_ARG (nothing done) for a NULL b, or a NULL in or out with
 * n > 0. */
fw_status_t fw_board16_step_block(fw_board16_t *b, const fw_sample_in_t *in, fw_sample_out_t *out, size_t n);
/* The bending offset of the latest sample, frame A, pm (the card's piezo
 * command subtracts it). */
void fw_board16_offset_pm(const fw_board16_t *b, int32_t off_pm[2]);

#endif /* FW_BOARD16_H */
