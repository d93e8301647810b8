/*
 * fw_rules.c - see fw_rules.h.
 */
#include "fw_rules.h"

typedef struct {
    const char *text;
    fw_status_t status;
} rule_row_t;

/* Indexed by fw_rule_t; the limits are the ones the check functions test. */
static const rule_row_t rule_rows[FW_RULE_COUNT] = {
    { "no rule broken", FW_OK },
    { "a required pointer is NULL", FW_ERR_ARG },
    { "the ADC has 8 to 16 bits", FW_ERR_ARG },
    { "the ADC filter averages 2^0 to 2^4 samples (filter_log2 0..4)", FW_ERR_ARG },
    { "the force gains k_n K_n and k_theta K_l / h are > 0 pN/V", FW_ERR_ARG },
    { "the tip height h and the lever length l are > 0 nm", FW_ERR_ARG },
    { "the tip is shorter than the lever (h < l, so 2h/l < 2 in eq. 1c)", FW_ERR_DOMAIN },
    { "the tip-substrate friction coefficient mu lies in [0, 1] (0..1000000 ppm)", FW_ERR_ARG },
    { "the tip-substrate adhesion is >= 0 pN", FW_ERR_ARG },
    { "the friction fallback needs mu 2h/l <= 1/2", FW_ERR_DOMAIN },
    { "the deflection gain K_n is > 0 pm/V", FW_ERR_ARG },
    { "the direction window's minimum displacement is >= 0 pm (0: 1000 pm)", FW_ERR_ARG },
    { "the displacement constants C_n, C_l are >= 0 pm/V", FW_ERR_ARG },
    { "the displacement constants C_n, C_l are at most 4194304 pm/V (2^22, 4194.304 nm/V)", FW_ERR_DOMAIN },
    { "the joystick's half range is >= 0 pm and kappa >= 0", FW_ERR_ARG },
    { "the tip radius lies in [0, 2^30] pm", FW_ERR_ARG },
    { "a particle's radius lies in (0, 2^30] pm; its push threshold, the contact margin, the particle-substrate "
      "adhesion, shear strength and contact area are >= 0; the particle-substrate mu lies in [0, 1]", FW_ERR_ARG },
    { "the card holds no more particles than its storage", FW_ERR_CAPACITY },
    { "a wire's length lies in (0, 2^30] pm, no shorter than its diameter, which is > 0 pm", FW_ERR_ARG },
    { "the wire friction per length is >= 0 pN/um and the wire-substrate mu lies in [0, 2)", FW_ERR_ARG },
    { "the card holds no more wires than its storage", FW_ERR_CAPACITY },
    { "lithography: threshold >= 0 pN, depth gain >= 0 pm/pN, point step > 0 pm", FW_ERR_ARG },
    { "the tip's cone half angle lies in (0, 60) deg", FW_ERR_ARG },
    { "lithography is on but the card has no trench storage", FW_ERR_CAPACITY },
    { "the drift and landmark correction limits are > 0 pm", FW_ERR_ARG },
    { "the landmark list has a count >= 0, and a list when the count is > 0", FW_ERR_ARG },
    { "the haptic gain is >= 0 uN/pN and the haptic force limit >= 0 uN", FW_ERR_ARG },
    { "the signal chain has 16 or 32 bits", FW_ERR_ARG },
    { "the 16-bit chain needs k_n K_n and k_theta K_l / h at most 104857 pN/V (2^20 pN at 10 V), "
      "C_n and C_l at most 2097152 pm/V, adhesion at most 2^26 pN, a direction window below 2^14 pm",
      FW_ERR_DOMAIN },
    { "the calibration surface's slope lies in [0.1, 90) deg (a flat surface carries no information)", FW_ERR_DOMAIN },
    { "the uphill friction-loop slope r_u is > 0", FW_ERR_DOMAIN },
    { "|rho| = |r_u / r_d| exceeds 1 + 2^-10 (the uphill slope is the steeper one; nearly equal slopes carry no "
      "friction information)", FW_ERR_DOMAIN },
    { "the slopes give a real friction angle: B = 2 (rho + 1) / ((rho - 1) sin 2 phi) >= 2 and phi + beta < 90 deg",
      FW_ERR_DOMAIN },
    { "the interlock's normal force limit lies above 0 pN and below the normal channel's full scale k_n K_n 10 V",
      FW_ERR_ARG },
    { "the interlock's lateral force limit lies above 0 pN and below the lateral channel's full scale "
      "k_theta K_l / h 10 V", FW_ERR_ARG },
    { "the scanner's hysteresis model: 1 to 16 play operators, thresholds from 0 strictly increasing up to the "
      "half range, which lies in (0, 2^28] pm, an origin within +-2^30 pm, and every partial sum of the weights "
      "in [1/2, 2]", FW_ERR_ARG },
    { "the scanner's creep law: gamma in [0, 100000] ppm per decade, t0 in [1 ms, 100 s], the period in "
      "(0, t0 / 16]", FW_ERR_ARG },
    { "the drift filter: the period in (0, 1 s], the random walk's variance a second and the velocity's prior "
      "variance >= 0", FW_ERR_ARG },
};

const char *fw_rule_text(fw_rule_t rule)
{
    if ((unsigned)rule >= (unsigned)FW_RULE_COUNT) {
        return "unknown rule";
    }
    return rule_rows[rule].text;
}

fw_status_t fw_rule_status(fw_rule_t rule)
{
    if ((unsigned)rule >= (unsigned)FW_RULE_COUNT) {
        return FW_ERR_ARG;
    }
    return rule_rows[rule].status;
}
