/* synth_scan.h - `wpd synth`'s acquisition: the aircraft flies the planned
 * strips line by line, the mirror sweeps each scan line pulse by pulse,
 * each pulse is traced through the scene and its echoes get their
 * acquisition attributes (gps time, scan angle, class, intensity, colour)
 * and go to the output, until exactly the target count is written.
 * Implemented by synth_scan.c.
 */
#ifndef WPD_SYNTH_SCAN_H
#define WPD_SYNTH_SCAN_H

#include <stdint.h>

#include "common/error.h"
#include "tools/synth/synth_flight.h"
#include "tools/synth/synth_math.h"
#include "tools/synth/synth_output.h"
#include "tools/synth/synth_scene.h"
#include "tools/synth/synth_trace.h"

/* State of the scan in progress. */
typedef struct scan {
    const scene *sc;
    const flight *fl;
    emitter *em;
    tracer tr;
    rng g;
    uint64_t pulses;             /* in-scene pulses traced */
    uint64_t echoes;             /* their echoes */
    double time;                 /* gps time of the current line */
    int strips_used;
} scan;

/* A scan of scene sc along flight fl into em (all of which must outlive
 * it), its random stream seeded from seed, starting at the first GPS time;
 * creases: 1 to mark the points on creases (point.crease). */
void synth_scan_init(scan *s, const scene *sc, const flight *fl, emitter *em, uint64_t seed,
                     int creases);

/* Flies the strips (again, with new source ids, in the rare case that one
 * pass falls short) until em's target count is written. Returns 0 or -1
 * with err set (the emitter's errors). */
int synth_fly(scan *s, wpd_error *err);

#endif
