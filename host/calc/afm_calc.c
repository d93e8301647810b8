/*
 * afm_calc - the lever calculator. Host code: it converts the command line's
 * decimal numbers into the firmware's integer units and runs the firmware's
 * own fixed-point solvers (firmware/), so what it prints is what the board
 * computes.
 *
 *   afm_calc calib tilted --up R --down R --angle-deg PHI --spring-N-per-m K --deflection-nm-per-V K [--json] [--write FILE]
 *   afm_calc calib lines --depths-nm a,b,.. --offsets-nm a,b,.. --deflection-nm-per-V K [--json] [--write FILE]
 *   afm_calc model wire --length-nm L --diameter-nm D --push-at-nm l [--f-nN-per-um f] [--json]
 *   afm_calc model squeeze --length-nm L --push-at-nm l --gamma-deg G --mu MU --fl-nN FL --fa-ts-nN F [--twist-deg T] [--json]
 *   afm_calc calc force --sn V --sl V --theta-deg T --scan-angle-deg A [--probe FILE] [--json]
 *
 * Exit status: 0 ok, 2 bad or out-of-domain arguments (one message on
 * stderr naming the option and value).
 *
 * afm_calc_main (afm_calc.h) is the whole program; main.c calls it, the fuzz
 * harness (fuzz/fuzz_calc.cpp) calls it in-process: nothing here exits, every
 * refusal returns its status up to afm_calc_main.
 *
 * The commands live in calc_calib.c, calc_model.c and calc_force.c; their
 * arguments in calc_args.c.
 */
#include <stdio.h>
#include <string.h>

#include "afm_calc.h"
#include "calc_args.h"

/* ---- dispatch ----------------------------------------------------------- */

static void usage(FILE *fp)
{
    fprintf(fp,
            "usage: afm_calc <group> <command> [options]   (each command has --help)\n"
            "  calib tilted   mu and k_theta K_l / h from friction loops on a tilted surface\n"
            "  calib lines    C_n from lines inscribed at several depths\n"
            "  model wire     static point and minimum push of a rigid nanowire\n"
            "  model squeeze  tip-substrate-wire squeeze: psi_max, F_r, the push and dF (eq. 29-30)\n"
            "  calc force     3-D tip force from S_n, S_l, theta and the scan angle\n"
            "  calc probe     the paper's probe (fw_paper_probe.h)\n");
}

int afm_calc_main(int argc, char **argv)
{
    if (argc < 2 || strcmp(argv[1], "--help") == 0 || strcmp(argv[1], "-h") == 0) {
        usage(argc < 2 ? stderr : stdout);
        return argc < 2 ? EXIT_USAGE : 0;
    }
    if (argc < 3) {
        return calc_refuse("'%s' needs a command (see afm_calc --help)", argv[1]);
    }
    if (strcmp(argv[1], "calib") == 0 && strcmp(argv[2], "tilted") == 0) {
        return cmd_calib_tilted(argc - 3, argv + 3);
    }
    if (strcmp(argv[1], "calib") == 0 && strcmp(argv[2], "lines") == 0) {
        return cmd_calib_lines(argc - 3, argv + 3);
    }
    if (strcmp(argv[1], "model") == 0 && strcmp(argv[2], "wire") == 0) {
        return cmd_model_wire(argc - 3, argv + 3);
    }
    if (strcmp(argv[1], "model") == 0 && strcmp(argv[2], "squeeze") == 0) {
        return cmd_model_squeeze(argc - 3, argv + 3);
    }
    if (strcmp(argv[1], "calc") == 0 && strcmp(argv[2], "force") == 0) {
        return cmd_calc_force(argc - 3, argv + 3);
    }
    if (strcmp(argv[1], "calc") == 0 && strcmp(argv[2], "probe") == 0) {
        return cmd_calc_probe(argc - 3, argv + 3);
    }
    return calc_refuse("unknown command '%s %s' (see afm_calc --help)", argv[1], argv[2]);
}
