/*
 * afm_calc.h - the lever calculator as a function: main.c is the program
 * (./afm calib|model|calc), the fuzz harness (fuzz/fuzz_calc.cpp) calls it
 * in-process.
 */
#ifndef AFM_CALC_H
#define AFM_CALC_H

#ifdef __cplusplus
extern "C" {
#endif

/* The command line of afm_calc (argv[0] the program's name); returns the
 * exit status: 0 ok, 2 refused (one line on stderr says why). Prints its
 * results on stdout; writes a file only for --write FILE. Never exits. */
int afm_calc_main(int argc, char **argv);

#ifdef __cplusplus
}
#endif

#endif /* AFM_CALC_H */
