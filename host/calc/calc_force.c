/*
 * afm_calc calc force and calc probe: the firmware's force solver (fw_force)
 * with a probe file or the paper's probe.
 */
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fw_calib.h"
#include "fw_force.h"
#include "fw_math.h"
#include "fw_wire.h"
#include "fw_paper_probe.h"
#include "fw_units.h"

#include "afm_calc.h"
#include "calc_args.h"

/* ---- calc force --------------------------------------------------------- */

typedef struct {
    double spring_n_per_m;
    double deflection_nm_per_v;
    double lateral_gain_nn_per_v;
    double h_um;
    double l_um;
    double mu;
    double adh_nn;
} probe_t;

static void probe_default(probe_t *p)
{
    /* the paper's probe (fw_paper_probe.h), in the calculator's units */
    p->spring_n_per_m = FW_PAPER_KN_MN_PER_M * 1e-3;
    p->deflection_nm_per_v = FW_PAPER_DEFLECTION_PM_PER_V * 1e-3;
    p->lateral_gain_nn_per_v = FW_PAPER_LATERAL_GAIN_PN_PER_V * 1e-3;
    p->h_um = FW_PAPER_TIP_HEIGHT_NM * 1e-3;
    p->l_um = FW_PAPER_LEVER_LENGTH_NM * 1e-3;
    p->mu = FW_PAPER_MU_PPM * 1e-6;
    p->adh_nn = 0.0;
}

static int probe_read(const char *cmd, const char *path, probe_t *p)
{
    FILE *fp = fopen(path, "r");
    char line[256];
    int lineno = 0;
    if (fp == NULL) {
        return calc_refuse("%s: --probe %s: cannot open (%s)", cmd, path, strerror(errno));
    }
    while (fgets(line, sizeof line, fp) != NULL) {
        char key[64];
        char *eq;
        char *end;
        double v;
        char *s = line;
        size_t n;
        lineno++;
        while (*s == ' ' || *s == '\t') {
            s++;
        }
        if (*s == '#' || *s == '\n' || *s == '\0') {
            continue;
        }
        eq = strchr(s, '=');
        if (eq == NULL) {
            fclose(fp);
            return calc_refuse("%s: --probe %s: line %d: expected 'key = value'", cmd, path, lineno);
        }
        n = (size_t)(eq - s);
        while (n > 0 && (s[n - 1] == ' ' || s[n - 1] == '\t')) {
            n--;
        }
        if (n == 0 || n >= sizeof key) {
            fclose(fp);
            return calc_refuse("%s: --probe %s: line %d: bad key", cmd, path, lineno);
        }
        memcpy(key, s, n);
        key[n] = '\0';
        errno = 0;
        v = strtod(eq + 1, &end);
        while (*end == ' ' || *end == '\t' || *end == '\n' || *end == '\r') {
            end++;
        }
        if (end == eq + 1 || errno != 0 || *end != '\0' || !isfinite(v)) {
            fclose(fp);
            return calc_refuse("%s: --probe %s: line %d: value of %s is not a number", cmd, path, lineno, key);
        }
        if (strcmp(key, "spring_N_per_m") == 0) {
            p->spring_n_per_m = v;
        } else if (strcmp(key, "deflection_nm_per_V") == 0) {
            p->deflection_nm_per_v = v;
        } else if (strcmp(key, "lateral_nN_per_V") == 0) {
            p->lateral_gain_nn_per_v = v;
        } else if (strcmp(key, "tip_height_um") == 0) {
            p->h_um = v;
        } else if (strcmp(key, "lever_length_um") == 0) {
            p->l_um = v;
        } else if (strcmp(key, "mu") == 0) {
            p->mu = v;
        } else if (strcmp(key, "adhesion_nN") == 0) {
            p->adh_nn = v;
        } else {
            fclose(fp);
            return calc_refuse("%s: --probe %s: line %d: unknown key '%s' (spring_N_per_m, deflection_nm_per_V, lateral_nN_per_V, "
                "tip_height_um, lever_length_um, mu, adhesion_nN)", cmd, path, lineno, key);
        }
    }
    fclose(fp);
    return 0;
}

/* calc force's answer: JSON, or lines for people. */
static void print_force(const int32_t fa[3], const int32_t fc[3], uint32_t flags, bool json)
{
    if (json) {
        printf("{\"command\": \"calc force\", \"status\": \"ok\", \"fx_nN\": %.3f, \"fy_nN\": %.3f, \"fz_nN\": %.3f, "
               "\"frame\": \"AFM\", \"fx_cantilever_nN\": %.3f, \"fy_cantilever_nN\": %.3f, "
               "\"fx_unobservable\": %s, \"saturated\": %s}\n",
               fwu_nn_from_pn(fa[0]), fwu_nn_from_pn(fa[1]), fwu_nn_from_pn(fa[2]), fwu_nn_from_pn(fc[0]), fwu_nn_from_pn(fc[1]),
               (flags & FW_FLAG_FX_UNOBSERVABLE) ? "true" : "false",
               (flags & FW_FLAG_SAT_FORCE) ? "true" : "false");
    } else {
        printf("force of the sample on the tip (firmware fw_force_solve_pn), AFM frame\n");
        printf("  F_x                    %.3f nN\n", fwu_nn_from_pn(fa[0]));
        printf("  F_y                    %.3f nN\n", fwu_nn_from_pn(fa[1]));
        printf("  F_z                    %.3f nN\n", fwu_nn_from_pn(fa[2]));
        printf("  cantilever frame       F_x %.3f nN, F_y %.3f nN\n", fwu_nn_from_pn(fc[0]), fwu_nn_from_pn(fc[1]));
        if (flags & FW_FLAG_FX_UNOBSERVABLE) {
            printf("  note                   |sin theta| < 1/4: F_x from the friction fallback (blended)\n");
        }
        if (flags & FW_FLAG_SAT_FORCE) {
            printf("  note                   a force was clamped to the firmware's int32 pN range\n");
        }
        printf("  status                 ok\n");
    }
}

static void help_calc_force(void)
{
    printf("usage: afm_calc calc force --sn V --sl V --theta-deg T --scan-angle-deg A [--probe FILE] [--json]\n"
           "  Force of the sample on the tip (physics.md section 1, eq. 1a-1c, 3) from the\n"
           "  photodiode signals S_n, S_l (volts, |S| < 256), the tip's direction of motion T\n"
           "  in the cantilever frame and the scan angle A (alpha = A - 270 deg); printed in\n"
           "  the AFM frame, nN. Near T = 0 or 180 deg (|sin T| < 1/4) F_x comes (partly) from\n"
           "  the friction fallback mu (F_z + F_adh).\n"
           "  --probe FILE: 'key = value' lines (spring_N_per_m, deflection_nm_per_V, lateral_nN_per_V,\n"
           "  tip_height_um, lever_length_um, mu, adhesion_nN); default: the paper's probe\n"
           "  (0.12 N/m, 89 nm/V, 37.9 nN/V, h 17.3 um, l 100 um, mu 0.0865, no adhesion).\n");
}

int cmd_calc_force(int argc, char **argv)
{
    const char *cmd = "calc force";
    opt_t o[] = {
        { "--sn", NULL, 0, 1 }, { "--sl", NULL, 0, 1 }, { "--theta-deg", NULL, 0, 1 },
        { "--scan-angle-deg", NULL, 0, 1 }, { "--probe", NULL, 0, 0 }, { "--json", NULL, 1, 0 },
    };
    probe_t p;
    double sn;
    double sl;
    double theta;
    double scan;
    fw_force_t f;
    fw_status_t st;
    q30_t ts;
    q30_t tc;
    q30_t as;
    q30_t ac;
    int32_t fc[3];
    int32_t fa[3];
    uint32_t flags = 0;
    bool sat = false;
    if (calc_wants_help(argc, argv)) {
        help_calc_force();
        return 0;
    }
    if (calc_parse_opts(cmd, argc, argv, o, (int)(sizeof o / sizeof o[0])) != 0
        || calc_num_opt_range(cmd, &o[0], -255.0, 255.0, "|S_n| must stay below 256 V", &sn) != 0
        || calc_num_opt_range(cmd, &o[1], -255.0, 255.0, "|S_l| must stay below 256 V", &sl) != 0
        || calc_num_opt_range(cmd, &o[2], -1e6, 1e6, "degrees", &theta) != 0
        || calc_num_opt_range(cmd, &o[3], -1e6, 1e6, "degrees", &scan) != 0) {
        return EXIT_USAGE;
    }
    probe_default(&p);
    if (o[4].value != NULL && probe_read(cmd, o[4].value, &p) != 0) {
        return EXIT_USAGE;
    }
    {
        fw_rule_t rule = fw_force_check(fwu_pn_per_v_from_nn_per_v(p.spring_n_per_m * p.deflection_nm_per_v),
                                        fwu_pn_per_v_from_nn_per_v(p.lateral_gain_nn_per_v), fwu_nm_from_um(p.h_um),
                                        fwu_nm_from_um(p.l_um), fwu_ppm(p.mu), fwu_pn_from_nn(p.adh_nn));
        if (rule != FW_RULE_OK) {
            return calc_refuse("%s: --probe %s: the firmware refuses this probe: %s (fw_force_check, rule %d)", cmd,
                o[4].value != NULL ? o[4].value : "(default)", fw_rule_text(rule), (int)rule);
        }
    }
    (void)fw_force_init(&f, fwu_pn_per_v_from_nn_per_v(p.spring_n_per_m * p.deflection_nm_per_v),
                        fwu_pn_per_v_from_nn_per_v(p.lateral_gain_nn_per_v), fwu_nm_from_um(p.h_um), fwu_nm_from_um(p.l_um),
                        fwu_ppm(p.mu), fwu_pn_from_nn(p.adh_nn));
    fw_math_sincos_q30(fw_math_bam_from_mdeg(fwu_mdeg_from_deg(fmod(theta, 360.0))), &ts, &tc);
    fw_math_sincos_q30(fw_math_bam_from_mdeg(fwu_mdeg_from_deg(fmod(scan, 360.0)) - 270000), &as, &ac);
    /* the direction as the vector (cos T, sin T) in 2.30: the solver takes any length */
    st = fw_force_solve_pn(&f, fwu_q23_from_v(sn), fwu_q23_from_v(sl), tc, ts, fc, &flags);
    if (st != FW_OK) {
        return calc_refuse("%s: fw_force_solve_pn failed (%s)", cmd, calc_status_name(st));
    }
    fw_force_rotate_pn(fc, ac, as, fa, &sat);
    if (sat) {
        flags |= FW_FLAG_SAT_FORCE;
    }
    print_force(fa, fc, flags, o[5].value != NULL);
    return 0;
}

/* The paper's probe as the firmware's header has it (fw_paper_probe.h),
 * under the scene's probe key names: the one copy the bench's scripts read. */
int cmd_calc_probe(int argc, char **argv)
{
    const char *cmd = "calc probe";
    opt_t o[] = { { "--json", NULL, 1, 0 } };
    probe_t p;
    if (calc_wants_help(argc, argv)) {
        printf("usage: afm_calc calc probe [--json]\n"
               "  The paper's probe (fw_paper_probe.h): what a scene without probe keys gets.\n");
        return 0;
    }
    if (calc_parse_opts(cmd, argc, argv, o, 1) != 0) {
        return EXIT_USAGE;
    }
    probe_default(&p);
    if (o[0].value != NULL) {
        printf("{\"command\": \"%s\", \"status\": \"ok\", \"spring_N_per_m\": %.6f, \"deflection_nm_per_V\": %.3f, "
               "\"lateral_nN_per_V\": %.3f, \"tip_height_um\": %.3f, \"lever_length_um\": %.3f, \"mu\": %.6f, "
               "\"normal_gain_nN_per_V\": %.3f, \"cn_nm_per_V\": %.3f}\n",
               cmd, p.spring_n_per_m, p.deflection_nm_per_v, p.lateral_gain_nn_per_v, p.h_um, p.l_um, p.mu,
               FW_PAPER_NORMAL_GAIN_PN_PER_V * 1e-3, FW_PAPER_DISP_PM_PER_V * 1e-3);
    } else {
        printf("The paper's probe (fw_paper_probe.h)\n");
        printf("  spring_N_per_m         %.4f\n  deflection_nm_per_V    %.1f\n  lateral_nN_per_V       %.1f\n", p.spring_n_per_m,
               p.deflection_nm_per_v, p.lateral_gain_nn_per_v);
        printf("  tip_height_um          %.1f\n  lever_length_um        %.1f\n  mu (tip on glass)      %.4f\n", p.h_um, p.l_um, p.mu);
        printf("  C_n (inscribed lines)  %.1f nm/V\n", FW_PAPER_DISP_PM_PER_V * 1e-3);
    }
    return 0;
}
