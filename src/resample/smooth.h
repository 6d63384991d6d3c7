/* smooth.h - smoothing through tiles (internal to src/resample/). */
#ifndef WPD_RESAMPLE_SMOOTH_H
#define WPD_RESAMPLE_SMOOTH_H

#include "common/error.h"
#include "resample/run.h"

/* The smoothing iterations, colour by colour, each tile with its
 * neighbours' samples as context. */
int wpd_smooth_phase(wpd_run *run, wpd_error *err);

#endif
