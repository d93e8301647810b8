/*
 * afm_calc calib tilted and calib lines: the firmware's calibration solvers
 * (fw_calib) on numbers from the command line.
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

/* ---- calib tilted ------------------------------------------------------- */

int cmd_calib_tilted(int argc, char **argv)
{
    const char *cmd = "calib tilted";
    opt_t o[] = {
        { "--up", NULL, 0, 1 }, { "--down", NULL, 0, 1 }, { "--angle-deg", NULL, 0, 1 },
        { "--spring-N-per-m", NULL, 0, 1 }, { "--deflection-nm-per-V", NULL, 0, 1 }, { "--json", NULL, 1, 0 },
        { "--write", NULL, 0, 0 },
    };
    double ru;
    double rd;
    double phi;
    double spring_n_per_m;
    double deflection_nm_per_v;
    double normal_gain_pn_per_v;
    fw_calib_tilted_t t;
    fw_status_t st;
    if (calc_wants_help(argc, argv)) {
        printf("usage: afm_calc calib tilted --up R_U --down R_D --angle-deg PHI --spring-N-per-m N_PER_M --deflection-nm-per-V NM_PER_V [--json] [--write FILE]\n"
               "  Lateral calibration on a tilted surface (physics.md section 2): from the\n"
               "  friction-loop slopes dS_l/dS_n uphill (R_U) and downhill (R_D, may be < 0)\n"
               "  on a surface of slope PHI degrees, gives mu and k_theta K_l / h (nN/V).\n"
               "  Refuses |R_U/R_D| <= 1 (+2^-10), PHI < 0.1 or >= 90 deg, R_U <= 0.\n"
               "  --write FILE: a scene include with firmware.lateral_nN_per_V and firmware.mu.\n"
               "  Paper: --up 0.07 --down 0.02 --angle-deg 9 --spring-N-per-m 0.12 --deflection-nm-per-V 89 -> mu 0.0865, 37.9 nN/V\n");
        return 0;
    }
    if (calc_parse_opts(cmd, argc, argv, o, (int)(sizeof o / sizeof o[0])) != 0
        || calc_num_opt_range(cmd, &o[0], -127.0, 127.0, "slopes must lie in (-127, 127)", &ru) != 0
        || calc_num_opt_range(cmd, &o[1], -127.0, 127.0, "slopes must lie in (-127, 127)", &rd) != 0
        || calc_num_opt_range(cmd, &o[2], -360.0, 360.0, "degrees", &phi) != 0
        || calc_num_opt_range(cmd, &o[3], 1e-6, 1e4, "k_n must lie in [1e-6, 1e4] N/m", &spring_n_per_m) != 0
        || calc_num_opt_range(cmd, &o[4], 1e-3, 1e6, "K_n must lie in [1e-3, 1e6] nm/V", &deflection_nm_per_v) != 0) {
        return EXIT_USAGE;
    }
    normal_gain_pn_per_v = spring_n_per_m * deflection_nm_per_v * 1000.0;   /* N/m * nm/V = nN/V, in pN/V */
    if (normal_gain_pn_per_v < 1.0 || normal_gain_pn_per_v > 2147483647.0) {
        return calc_refuse("%s: --spring-N-per-m %s --deflection-nm-per-V %s: k_n K_n = %g nN/V does not fit int32 pN/V", cmd, o[3].value, o[4].value,
            fwu_nn_per_v_from_pn_per_v((int64_t)normal_gain_pn_per_v));
    }
    st = fw_calib_tilted_solve(fwu_q24(ru), fwu_q24(rd), fw_math_bam_from_mdeg(fwu_mdeg_from_deg(phi)),
                               fwu_i32(normal_gain_pn_per_v), &t);
    if (st != FW_OK) {
        /* the firmware names the rule; the options that feed it with it */
        fw_rule_t rule = fw_calib_tilted_rule(fwu_q24(ru), fwu_q24(rd), fw_math_bam_from_mdeg(fwu_mdeg_from_deg(phi)),
                                              fwu_i32(normal_gain_pn_per_v));
        const char *opt = (rule == FW_RULE_TILTED_SLOPE) ? "--angle-deg" : (rule == FW_RULE_TILTED_UPHILL) ? "--up" : "--up --down";
        return calc_refuse("%s: %s (--up %s --down %s --angle-deg %s): the firmware refuses it: %s (fw_calib_tilted_solve: %s, rule %d)",
            cmd, opt, o[0].value, o[1].value, o[2].value, fw_rule_text(rule), calc_status_name(st), (int)rule);
    }
    {
        double mu = fwu_from_q30(t.mu);
        double beta = fwu_deg_from_bam(t.beta);
        double lat = fwu_nn_per_v_from_pn_per_v(t.lateral_gain_pn_per_v);
        if (o[5].value != NULL) {
            printf("{\"command\": \"calib tilted\", \"status\": \"ok\", \"mu\": %.6f, \"mu_ppm\": %ld, "
                   "\"lateral_nN_per_V\": %.3f, \"lateral_pN_per_V\": %ld, \"slope_angle_deg\": %.4f, "
                   "\"friction_angle_deg\": %.4f, \"normal_gain_nN_per_V\": %.4f}\n",
                   mu, (long)t.mu_ppm, lat, (long)t.lateral_gain_pn_per_v, phi, beta, normal_gain_pn_per_v * 1e-3);
        } else {
            printf("tilted-surface calibration (firmware fw_calib_tilted_solve)\n");
            printf("  slope angle phi        %.4f deg\n", phi);
            printf("  k_n K_n                %.4f nN/V\n", normal_gain_pn_per_v * 1e-3);
            printf("  mu                     %.6f\n", mu);
            printf("  friction angle beta    %.4f deg\n", beta);
            printf("  k_theta K_l / h        %.3f nN/V\n", lat);
            printf("  status                 ok\n");
        }
        if (o[6].value != NULL) {
            char keys[256];
            snprintf(keys, sizeof keys, "  lateral_nN_per_V: %.3f   # k_theta K_l / h\n  mu: %.6f                # tip-substrate\n", lat, mu);
            return calc_write_include(cmd, o[6].value, argc, argv, keys);
        }
    }
    return 0;
}

/* ---- calib lines -------------------------------------------------------- */

int cmd_calib_lines(int argc, char **argv)
{
    const char *cmd = "calib lines";
    opt_t o[] = {
        { "--depths-nm", NULL, 0, 1 }, { "--offsets-nm", NULL, 0, 1 }, { "--deflection-nm-per-V", NULL, 0, 1 },
        { "--json", NULL, 1, 0 }, { "--write", NULL, 0, 0 },
    };
    double dz[LIST_MAX];
    double dd[LIST_MAX];
    int32_t dzp[LIST_MAX];
    int32_t ddp[LIST_MAX];
    int n;
    int m;
    int i;
    double deflection_nm_per_v;
    int32_t disp_n_pm_per_v;
    int32_t res;
    fw_status_t st;
    if (calc_wants_help(argc, argv)) {
        printf("usage: afm_calc calib lines --depths-nm D1,D2,.. --offsets-nm O1,O2,.. --deflection-nm-per-V NM_PER_V [--json] [--write FILE]\n"
               "  C_n from lines inscribed at several push depths (physics.md section 3):\n"
               "  S_n' = depth / K_n, least-squares fit offset = C_n S_n' + b; prints C_n (nm/V)\n"
               "  and the RMS residual (nm). 2..%d points, |values| <= 16777 nm.\n"
               "  --write FILE: a scene include with firmware.disp_n_nm_per_V.\n"
               "  Paper: --depths-nm 500,1000,1500,2000 --offsets-nm 0,130,260,390 --deflection-nm-per-V 89 -> 23.1 nm/V\n",
               LIST_MAX);
        return 0;
    }
    if (calc_parse_opts(cmd, argc, argv, o, (int)(sizeof o / sizeof o[0])) != 0
        || calc_list_opt(cmd, &o[0], dz, LIST_MAX, &n) != 0
        || calc_list_opt(cmd, &o[1], dd, LIST_MAX, &m) != 0
        || calc_num_opt_range(cmd, &o[2], 1e-3, 2e6, "K_n must lie in [1e-3, 2e6] nm/V", &deflection_nm_per_v) != 0) {
        return EXIT_USAGE;
    }
    if (n != m) {
        return calc_refuse("%s: --depths-nm %s --offsets-nm %s: %d depths but %d offsets", cmd, o[0].value, o[1].value, n, m);
    }
    if (n < 2) {
        return calc_refuse("%s: --depths-nm %s: at least 2 lines are needed", cmd, o[0].value);
    }
    for (i = 0; i < n; i++) {
        if (fabs(dz[i]) * 1000.0 > FW_CALIB_LINES_RANGE_PM) {
            return calc_refuse("%s: --depths-nm %s: |%g| nm exceeds %d nm", cmd, o[0].value, dz[i], FW_CALIB_LINES_RANGE_PM / 1000);
        }
        if (fabs(dd[i]) * 1000.0 > FW_CALIB_LINES_RANGE_PM) {
            return calc_refuse("%s: --offsets-nm %s: |%g| nm exceeds %d nm", cmd, o[1].value, dd[i], FW_CALIB_LINES_RANGE_PM / 1000);
        }
        dzp[i] = fwu_pm_from_nm(dz[i]);
        ddp[i] = fwu_pm_from_nm(dd[i]);
    }
    st = fw_calib_lines_cn(dzp, ddp, n, fwu_pm_per_v_from_nm_per_v(deflection_nm_per_v), &disp_n_pm_per_v, &res);
    if (st != FW_OK) {
        return calc_refuse("%s: --depths-nm %s: the depths must not all be equal and |offset/depth| must stay below 128 (%s)",
            cmd, o[0].value, calc_status_name(st));
    }
    if (o[3].value != NULL) {
        printf("{\"command\": \"calib lines\", \"status\": \"ok\", \"cn_nm_per_V\": %.3f, \"residual_nm\": %.3f, "
               "\"lines\": %d}\n", fwu_nm_per_v_from_pm_per_v(disp_n_pm_per_v), fwu_nm_from_pm(res), n);
    } else {
        printf("C_n from inscribed lines (firmware fw_calib_lines_cn)\n");
        printf("  lines                  %d\n", n);
        printf("  C_n                    %.3f nm/V\n", fwu_nm_per_v_from_pm_per_v(disp_n_pm_per_v));
        printf("  RMS residual           %.3f nm\n", fwu_nm_from_pm(res));
        printf("  status                 ok\n");
    }
    if (o[4].value != NULL) {
        char keys[128];
        snprintf(keys, sizeof keys, "  disp_n_nm_per_V: %.3f   # C_n\n", fwu_nm_per_v_from_pm_per_v(disp_n_pm_per_v));
        return calc_write_include(cmd, o[4].value, argc, argv, keys);
    }
    return 0;
}
