/*
 * afm_calc model wire and model squeeze: the firmware's rod and squeeze models
 * (fw_wire) on numbers from the command line.
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

/* ---- model wire --------------------------------------------------------- */

/* model wire's answer: JSON, or lines for people. */
static void print_wire(bool s_defined, int32_t s_pm, double k, double f_min_nn, double f, const char *regime, double lambda, double at,
                       double len, bool json)
{
    if (json) {
        printf("{\"command\": \"model wire\", \"status\": \"ok\", ");
        if (s_defined) {
            printf("\"static_point_nm\": %.3f, ", fwu_nm_from_pm(s_pm));
        } else {
            printf("\"static_point_nm\": null, ");
        }
        printf("\"min_force_per_fL\": %.6f, \"min_force_nN\": %.6f, \"regime\": \"%s\", "
               "\"aspect_ratio\": %.3f, \"rigid_rod_model_valid\": %s}\n",
               k, f_min_nn, regime, lambda, lambda <= 15.0 ? "true" : "false");
    } else {
        printf("rigid rod pushed at l = %g nm of L = %g nm (firmware fw_wire_static_point)\n", at, len);
        if (s_defined) {
            printf("  static point S         %.3f nm from end A\n", fwu_nm_from_pm(s_pm));
        } else {
            printf("  static point S         none: pure translation (bifurcation at L/2)\n");
        }
        printf("  regime                 %s\n", regime);
        printf("  F_min / (f L)          %.6f\n", k);
        printf("  F_min                  %.6f nN (f = %g nN/um)\n", f_min_nn, f);
        printf("  aspect ratio L/d       %.2f%s\n", lambda,
               lambda <= 15.0 ? "" : "  (above 15: the rod bends, rigid model out of scope)");
        printf("  status                 ok\n");
    }
}

static void help_model_wire(void)
{
    printf("usage: afm_calc model wire --length-nm L --diameter-nm D --push-at-nm l [--f-nN-per-um f] [--json]\n"
           "  Rigid rod pushed perpendicular to its axis at l from end A (physics.md section 6):\n"
           "  static point S (distance from A; none at l = L/2), minimum push F_min / (f L)\n"
           "  (0.414 at an end, 1 at the middle) and F_min for friction density f (default 1 nN/um).\n");
}

int cmd_model_wire(int argc, char **argv)
{
    const char *cmd = "model wire";
    opt_t o[] = {
        { "--length-nm", NULL, 0, 1 }, { "--diameter-nm", NULL, 0, 1 }, { "--push-at-nm", NULL, 0, 1 },
        { "--f-nN-per-um", NULL, 0, 0 }, { "--json", NULL, 1, 0 },
    };
    double len;
    double dia;
    double at;
    double f = 1.0;
    int32_t len_pm;
    int32_t at_pm = 0;
    fw_wire_static_t st;
    fw_status_t s;
    const char *regime;
    double k;
    double f_min_nn;
    double lambda;
    if (calc_wants_help(argc, argv)) {
        help_model_wire();
        return 0;
    }
    if (calc_parse_opts(cmd, argc, argv, o, (int)(sizeof o / sizeof o[0])) != 0
        || calc_num_opt_range(cmd, &o[0], 0.001, FW_WIRE_LENGTH_MAX_PM / 1000.0, "0 < L <= 1073741 nm", &len) != 0
        || calc_num_opt_range(cmd, &o[1], 0.001, 1e9, "D must be > 0", &dia) != 0
        || calc_num_opt(cmd, &o[2], &at) != 0
        || (o[3].value != NULL && calc_num_opt_range(cmd, &o[3], 0.0, 1e6, "f must be >= 0", &f) != 0)) {
        return EXIT_USAGE;
    }
    len_pm = fwu_pm_from_nm(len);
    if (at < 0.0 || at > len) {
        return calc_refuse("%s: --push-at-nm %s: must lie on the rod, in [0, %g] nm", cmd, o[2].value, len);
    }
    if (calc_to_i32(cmd, &o[2], at * 1e3, &at_pm) != 0) {
        return EXIT_USAGE;
    }
    s = fw_wire_static_point(len_pm, at_pm, &st);
    if (s != FW_OK) {
        return calc_refuse("%s: --push-at-nm %s: %s", cmd, o[2].value, calc_status_name(s));
    }
    regime = (st.regime == FW_WIRE_TRANSLATE) ? "translate"
             : (st.regime == FW_WIRE_ROTATE_NEAR_B) ? "rotate_about_far_end_side" : "rotate_about_near_end_side";
    k = fwu_from_q30(st.k);
    lambda = len / dia;
    {
        /* F_min = k(l) f L by the firmware's own friction and threshold */
        fw_wire_tip_t tip;
        fw_wire_t w;
        bool sat = false;
        if (fw_wire_tip_init(&tip, 0, 20000, fwu_pn_per_um_from_nn_per_um(f), 0, 0) != FW_OK
            || fw_wire_init(&w, 0, 0, 0, len_pm, len_pm) != FW_OK) {
            return calc_refuse("%s: --f-nN-per-um %s: the firmware refuses this friction or length", cmd, o[3].value ? o[3].value : "1");
        }
        f_min_nn = fwu_nn_from_pn(fw_wire_push_threshold_pn(st.k, fw_wire_friction_pn(&tip, &w), &sat));
    }
    print_wire(st.s_defined, st.s_pm, k, f_min_nn, f, regime, lambda, at, len, o[4].value != NULL);
    return 0;
}

/* ---- model squeeze ------------------------------------------------------ */

/* model squeeze's answer: JSON, or lines for people. */
static void print_squeeze(q30_t k, double psi_deg, const fw_squeeze_t *sq_in, bool squeezed, double at, double len, bool json)
{
    const fw_squeeze_t sq = *sq_in;
    if (json) {
        printf("{\"command\": \"model squeeze\", \"status\": \"ok\", \"k\": %.6f, \"psi_deg\": %.6f, "
               "\"psi_max_deg\": %.6f, \"squeezed\": %s, ",
               fwu_from_q30(k), psi_deg, fw_math_mdeg_from_bam(sq.psi_max) * 1e-3,
               squeezed ? "true" : "false");
        if (squeezed) {
            printf("\"f_r_nN\": null, \"push_nN\": null, \"df_nN\": null, \"saturated\": false}\n");
        } else {
            printf("\"f_r_nN\": %.6f, \"push_nN\": %.6f, \"df_nN\": %.6f, \"saturated\": %s}\n",
                   fwu_nn_from_pn(sq.f_r_pn), fwu_nn_from_pn(sq.push_pn), fwu_nn_from_pn(sq.df_pn),
                   (sq.flags & FW_FLAG_SAT_FORCE) != 0u ? "true" : "false");
        }
    } else {
        printf("tip-substrate-wire squeeze at l = %g nm of L = %g nm (firmware fw_wire_squeeze_solve)\n", at, len);
        printf("  k(l)                   %.6f\n", fwu_from_q30(k));
        printf("  psi = gamma + |twist|  %.4f deg\n", psi_deg);
        printf("  psi_max                %.4f deg\n", fw_math_mdeg_from_bam(sq.psi_max) * 1e-3);
        if (squeezed) {
            printf("  regime                 squeeze: psi >= psi_max, no push moves the rod\n");
        } else {
            printf("  F_r (29)               %.4f nN%s\n", fwu_nn_from_pn(sq.f_r_pn),
                   (sq.flags & FW_FLAG_SAT_FORCE) != 0u ? "  (saturated)" : "");
            printf("  push F_r cos psi       %.4f nN\n", fwu_nn_from_pn(sq.push_pn));
            printf("  dF (30)                %.4f nN%s\n", fwu_nn_from_pn(sq.df_pn),
                   sq.df_pn <= 0 ? "  (adhesion alone holds the tip)" : "");
        }
        printf("  status                 ok\n");
    }
}

static void help_model_squeeze(void)
{
    printf("usage: afm_calc model squeeze --length-nm L --push-at-nm l --gamma-deg G --mu MU --fl-nN FL\n"
           "                              --fa-ts-nN F [--twist-deg T] [--json]\n"
           "  Tip-substrate-wire squeeze (physics.md section 7, eq. 29-30) by the firmware's\n"
           "  fw_wire_squeeze_solve: a rod of length L pushed at l (k(l) of section 6) by a cone\n"
           "  of half angle G twisted by T (psi = G + |T|), wire-substrate mu, the rod's own\n"
           "  friction FL = mu F_a,os + tau A (nN) and tip-substrate adhesion F_a,ts (nN).\n"
           "  Prints psi_max = atan(1 / (k mu)), F_r (29), its horizontal part (the push that\n"
           "  moves the rod), dF = F_r sin psi - F_a,ts (30), or that the tip squeezes the rod.\n");
}

int cmd_model_squeeze(int argc, char **argv)
{
    const char *cmd = "model squeeze";
    opt_t o[] = {
        { "--length-nm", NULL, 0, 1 }, { "--push-at-nm", NULL, 0, 1 }, { "--gamma-deg", NULL, 0, 1 },
        { "--mu", NULL, 0, 1 }, { "--fl-nN", NULL, 0, 1 }, { "--fa-ts-nN", NULL, 0, 1 },
        { "--twist-deg", NULL, 0, 0 }, { "--json", NULL, 1, 0 },
    };
    double len;
    double at;
    double gamma;
    double mu;
    double fl;
    double fats;
    double twist = 0.0;
    int32_t at_pm = 0;
    fw_wire_static_t st;
    fw_squeeze_t sq;
    fw_status_t s;
    fw_bam_t psi;
    bool squeezed;
    if (calc_wants_help(argc, argv)) {
        help_model_squeeze();
        return 0;
    }
    if (calc_parse_opts(cmd, argc, argv, o, (int)(sizeof o / sizeof o[0])) != 0
        || calc_num_opt_range(cmd, &o[0], 0.001, FW_WIRE_LENGTH_MAX_PM / 1000.0, "0 < L <= 1073741 nm", &len) != 0
        || calc_num_opt(cmd, &o[1], &at) != 0) {
        return EXIT_USAGE;
    }
    if (at < 0.0 || at > len) {
        return calc_refuse("%s: --push-at-nm %s: must lie on the rod, in [0, %g] nm", cmd, o[1].value, len);
    }
    if (calc_num_opt_range(cmd, &o[2], 0.0, 89.999, "0 <= gamma < 90 deg", &gamma) != 0
        || calc_num_opt_range(cmd, &o[3], 0.0, FW_WIRE_MU_MAX_PPM / 1e6, "0 <= mu < 2", &mu) != 0
        || calc_num_opt_range(cmd, &o[4], 0.0, 2.0e6, "0 <= FL <= 2e6 nN", &fl) != 0
        || calc_num_opt_range(cmd, &o[5], 0.0, 2.0e6, "0 <= F_a,ts <= 2e6 nN", &fats) != 0
        || (o[6].value != NULL && calc_num_opt_range(cmd, &o[6], -89.999, 89.999, "|twist| < 90 deg", &twist) != 0)
        || calc_to_i32(cmd, &o[1], at * 1e3, &at_pm) != 0) {
        return EXIT_USAGE;
    }
    s = fw_wire_static_point(fwu_pm_from_nm(len), at_pm, &st);
    if (s != FW_OK) {
        return calc_refuse("%s: --push-at-nm %s: %s", cmd, o[1].value, calc_status_name(s));
    }
    if (gamma + fabs(twist) >= 90.0) {
        return calc_refuse("%s: --gamma-deg %s with --twist-deg %s: psi = gamma + |twist| must stay below 90 deg", cmd, o[2].value,
            o[6].value);
    }
    psi = fw_math_bam_from_mdeg(fwu_mdeg_from_deg(gamma + fabs(twist)));
    s = fw_wire_squeeze_solve(psi, st.k, fwu_q30(mu), fwu_pn_from_nn(fl), fwu_pn_from_nn(fats), &sq);
    if (s == FW_ERR_ARG) {
        return calc_refuse("%s: the firmware refuses these values (%s)", cmd, calc_status_name(s));
    }
    squeezed = s == FW_ERR_DOMAIN;
    print_squeeze(st.k, gamma + fabs(twist), &sq, squeezed, at, len, o[7].value != NULL);
    return 0;
}
