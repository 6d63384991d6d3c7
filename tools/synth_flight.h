/* synth_flight.h - the flight plan of `wpd synth`'s simulated survey:
 * parallel north/south strips with 30 % side overlap over the scene, the
 * flying height, and the oscillating mirror's scan pattern (scan angle,
 * its whole-degree rank and intensity gain per step). Fixed before the
 * scan starts; implemented by synth_flight.c.
 */
#ifndef WPD_SYNTH_FLIGHT_H
#define WPD_SYNTH_FLIGHT_H

#include <stdint.h>

#include "synth_scene.h"

#define RETURNS_PRIOR 1.2       /* expected points per pulse before measuring */

typedef struct flight {
    double swath, height, spacing;   /* strip geometry */
    double altitude;                 /* of the aircraft: height above the scene centre */
    int strips;
    double first_centre;
    int pulses_per_line;             /* M */
    double *tan_of;                  /* [M]: tangent of the scan angle of step j */
    int8_t *rank_of;                 /* [M]: angle in whole degrees */
    double *gain_of;                 /* [M]: intensity factor of the incidence */
    int *lo, *hi;                    /* per strip: steps landing in or near the scene */
    int *inside;                     /* per strip: steps landing in the scene */
    double line_spacing;             /* nominal along-track spacing (m) */
    double line_period;              /* seconds per scan line */
} flight;

/* Plans strips and scan pattern for scene sc (set up by synth_scene_init)
 * and `points` points. Returns 0, or -1 when out of memory; call
 * synth_flight_free in either case. */
int synth_flight_plan(flight *f, const scene *sc, uint64_t points);

/* Frees the tables of f and clears it. */
void synth_flight_free(flight *f);

/* Local x of the track of strip i. */
static inline double strip_centre(const flight *f, int i)
{
    return f->first_centre + i * f->spacing;
}

#endif
