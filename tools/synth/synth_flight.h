/* synth_flight.h - the flight plan of `wpd synth`'s simulated survey:
 * parallel north/south strips with 30 % side overlap over the scene (or,
 * for the oblique survey, cross strips: north/south and east/west, with a
 * wide sweep), the flying height, and the oscillating mirror's scan
 * pattern (scan angle, its whole-degree rank and intensity gain per step). Fixed before the
 * scan starts; implemented by synth_flight.c.
 */
#ifndef WPD_SYNTH_FLIGHT_H
#define WPD_SYNTH_FLIGHT_H

#include <stdint.h>

#include "tools/synth/synth_scene.h"

#define RETURNS_PRIOR 1.2       /* expected points per pulse before measuring */

typedef struct flight {
    double swath, height, spacing;   /* strip geometry */
    double altitude;                 /* of the aircraft: height above the scene centre */
    int strips;                      /* all strips, both directions */
    int per_direction;               /* strips 0 .. per_direction-1 fly north/south, the
                                        next ones (oblique survey) east/west */
    double half_angle;               /* of the mirror's sweep, radians */
    double inner_angle;              /* oblique survey: no pulse nearer nadir than this
                                        (radians); 0: the sweep is continuous */
    double first_centre;
    int pulses_per_line;             /* M */
    double *tan_of;                  /* [M]: tangent of the scan angle of step j */
    int8_t *rank_of;                 /* [M]: angle in whole degrees */
    double *gain_of;                 /* [M]: intensity factor of the incidence */
    int *lo, *hi;                    /* per strip: steps landing in or near the scene */
    int *inside;                     /* per strip: steps landing in the scene */
    double line_spacing;             /* nominal along-track spacing (m) */
    double point_spacing;            /* the survey's point spacing: line_spacing, or for the
                                        oblique survey that of all strips together */
    double line_period;              /* seconds per scan line */
} flight;

/* Plans strips and scan pattern for scene sc (set up by synth_scene_init)
 * and `points` points; oblique: the oblique survey (synth_flight.c).
 * Returns 0, or -1 when out of memory; call synth_flight_free in either
 * case. */
int synth_flight_plan(flight *f, const scene *sc, uint64_t points, int oblique);

/* Frees the tables of f and clears it. */
void synth_flight_free(flight *f);

/* Across-track position of the track of strip i: local x of a north/south
 * strip, local y of an east/west one. */
static inline double strip_centre(const flight *f, int i)
{
    return f->first_centre + (i % f->per_direction) * f->spacing;
}

/* 1 if strip i flies east/west: its pulses lean north or south, and the
 * tracer works in the scene with x and y swapped (synth_trace.h). */
static inline int strip_transposed(const flight *f, int i) { return i >= f->per_direction; }

#endif
