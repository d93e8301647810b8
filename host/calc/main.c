/* afm_calc: the lever calculator (afm_calc.c, afm_calc_main). */
#include "afm_calc.h"

int main(int argc, char **argv) { return afm_calc_main(argc, argv); }
