/* poisson.h - the Poisson phase through tiles (internal to src/resample/). */
#ifndef WPD_RESAMPLE_POISSON_H
#define WPD_RESAMPLE_POISSON_H

#include "common/error.h"
#include "resample/run.h"

/* The Poisson passes, colour by colour, refined until the count lies in
 * [n, 1.05 n]: each tile's samples in the sample store. */
int wpd_poisson_phase(wpd_run *run, wpd_error *err);

/* n at or above the input: every point a sample, tile by tile. */
int wpd_take_all_phase(wpd_run *run, wpd_error *err);

#endif
