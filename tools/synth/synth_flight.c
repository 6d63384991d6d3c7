/* synth_flight.c - plans `wpd synth`'s survey (see synth_flight.h): the
 * swath and strip spacing from the scene's side, the flying height from
 * the swath, the pulse spacing from the target count, and the per-step
 * tables of the mirror's sweep.
 */
#include "tools/synth/synth_flight.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define SCAN_HALF_ANGLE (22.0 * 3.14159265358979323846 / 180.0)
#ifndef OBLIQUE_OUTER_DEGREES
#define OBLIQUE_OUTER_DEGREES 65.0
#endif
#ifndef OBLIQUE_INNER_DEGREES
#define OBLIQUE_INNER_DEGREES 35.0
#endif
#define OBLIQUE_HALF_ANGLE (OBLIQUE_OUTER_DEGREES * 3.14159265358979323846 / 180.0)
#define OBLIQUE_INNER_ANGLE (OBLIQUE_INNER_DEGREES * 3.14159265358979323846 / 180.0)
#define SWATH_MIN 60.0          /* small scenes are low (UAV-like) surveys */
#define SWATH_MAX 500.0
#define SIDE_OVERLAP 0.30
#define MIN_STRIPS 3
#define GROUND_SPEED 60.0       /* m/s, nominal, for the widest swath */
#define MIN_GROUND_SPEED 8.0

void synth_flight_free(flight *f)
{
    free(f->tan_of), free(f->rank_of), free(f->gain_of), free(f->lo), free(f->hi), free(f->inside);
    memset(f, 0, sizeof *f);
}

/* Strip geometry: swath, spacing and count from the scene's side (at
 * least MIN_STRIPS, centred on the scene), the flying height from the
 * swath and the scan angle.
 *
 * The oblique survey flies at the same height (so over the same scene:
 * the buildings' height limit depends on it) with pulses leaning 35 to 65
 * degrees to either side, as an oblique scanner's (a UAV's tilted head,
 * a helicopter's side-looking ones) do, in strips a
 * quarter of the swath apart in both directions, north/south and
 * east/west, whose tracks extend a quarter swath beyond the scene on
 * either side: every point is seen from about four strips of each
 * direction, and every wall, whichever way it faces, from strips on its
 * side at angles of up to 65 degrees (a wall takes tan(angle) times the
 * ground's pulses per square metre of one strip, so steep angles are what
 * samples it). Walls near the scene's border are seen from strips
 * outside it, as surveys plan their lines. Why no pulse nearer nadir than
 * 35 degrees: the ground takes pulses from every strip and direction, a
 * wall only those leaning towards it, a quarter of them, so near-nadir
 * pulses, which see no wall, thin the walls for a denser ground; without
 * them a wall gets 3.8 points per square metre against the ground's 8.6
 * (2.9 against 9.2 with a continuous +-65 degree sweep; 300 K seed 1). */
static void plan_strips(flight *f, const scene *sc, int oblique)
{
    double L = sc->side;
    f->swath = clampd(L / (1 + (MIN_STRIPS - 1) * (1 - SIDE_OVERLAP)), SWATH_MIN, SWATH_MAX);
    f->spacing = f->swath * (1 - SIDE_OVERLAP);
    f->strips = (int)ceil((L - f->swath) / f->spacing - 1e-9) + 1;
    if (f->strips < MIN_STRIPS)
        f->strips = MIN_STRIPS;
    f->first_centre = L / 2 - (f->strips - 1) * f->spacing / 2;
    f->height = f->swath / 2 / tan(SCAN_HALF_ANGLE);
    f->altitude = terrain(sc, L / 2, L / 2) + f->height;
    f->half_angle = SCAN_HALF_ANGLE;
    f->per_direction = f->strips;
    if (oblique) {
        double reach = f->height * tan(OBLIQUE_HALF_ANGLE);
        f->half_angle = OBLIQUE_HALF_ANGLE;
        f->inner_angle = OBLIQUE_INNER_ANGLE;
        f->swath = 2 * reach;
        f->spacing = reach / 2;
        f->per_direction = (int)ceil((L + reach) / f->spacing - 1e-9) + 1;
        f->strips = 2 * f->per_direction;
        f->first_centre = L / 2 - (f->per_direction - 1) * f->spacing / 2;
    }
}

/* Pulse spacing that gives `points` points over the scene area the strips
 * see, the pulses per scan line and the time a line takes. */
static void plan_pulses(flight *f, double L, uint64_t points)
{
    double covered = 0;
    for (int i = 0; i < f->strips; i++) {
        double c = strip_centre(f, i);
        covered += max2(0, min2(L, c + f->swath / 2) - max2(0, c - f->swath / 2)) * L;
        if (f->inner_angle > 0) { /* the band under the track no pulse reaches */
            double gap = f->height * tan(f->inner_angle);
            covered -= max2(0, min2(L, c + gap) - max2(0, c - gap)) * L;
        }
    }
    double pulses_per_m2 = (double)points / RETURNS_PRIOR / covered;
    double step = 1 / sqrt(pulses_per_m2);
    int m = (int)(f->swath * (1 - tan(f->inner_angle) / tan(f->half_angle)) / step + 0.5);
    if (f->inner_angle > 0)
        m += m % 2; /* an even count: half of the steps on either side */
    f->pulses_per_line = m < 2 ? 2 : m > 1000000 ? 1000000 : m;
    f->line_spacing = step;
    /* One strip's spacing where strips barely overlap (the default survey);
     * the oblique survey's strips all overlap: the spacing of their pulses
     * together. */
    f->point_spacing = f->per_direction < f->strips ? 1 / sqrt(pulses_per_m2 * covered / (L * L))
                                                   : step;
    f->line_period = step / clampd(GROUND_SPEED * f->swath / SWATH_MAX, MIN_GROUND_SPEED, GROUND_SPEED);
}

/* The scan angle of step j of m: equal angular steps over -22 .. +22
 * degrees, or for the oblique survey over -70 .. -40 and 40 .. 70 (the
 * first half of the steps on the left, the second on the right). */
static double step_angle(const flight *f, int j, int m)
{
    if (f->inner_angle <= 0)
        return f->half_angle * (2 * (j + 0.5) / m - 1);
    double width = f->half_angle - f->inner_angle;
    if (j < m / 2)
        return -f->half_angle + width * (j + 0.5) / (m / 2);
    return f->inner_angle + width * (j - m / 2 + 0.5) / (m / 2);
}

/* The mirror's sweep, step by step (step_angle). */
static void plan_sweep(flight *f)
{
    const int m = f->pulses_per_line;
    for (int j = 0; j < m; j++) {
        double a = step_angle(f, j, m);
        f->tan_of[j] = tan(a);
        f->rank_of[j] = (int8_t)lround(a * 180 / 3.14159265358979323846);
        f->gain_of[j] = 0.6 + 0.4 * cos(a);
    }
}

/* Steps whose nominal ground point is near the scene (traced: the terrain
 * moves the actual one) and in it (the expected yield), per strip. */
static void plan_strip_steps(flight *f, double L)
{
    const int m = f->pulses_per_line;
    for (int i = 0; i < f->strips; i++) {
        double c = strip_centre(f, i);
        int lo = 0, hi = m, inside = 0;
        while (lo < m && c + f->height * f->tan_of[lo] < -5.0)
            lo++;
        while (hi > lo && c + f->height * f->tan_of[hi - 1] > L + 5.0)
            hi--;
        for (int j = lo; j < hi; j++) {
            double x = c + f->height * f->tan_of[j];
            inside += x >= 0 && x <= L;
        }
        f->lo[i] = lo, f->hi[i] = hi, f->inside[i] = inside;
    }
}

int synth_flight_plan(flight *f, const scene *sc, uint64_t points, int oblique)
{
    memset(f, 0, sizeof *f);
    plan_strips(f, sc, oblique);
    plan_pulses(f, sc->side, points);
    size_t m = (size_t)f->pulses_per_line, strips = (size_t)f->strips;
    f->tan_of = malloc(m * sizeof *f->tan_of);
    f->rank_of = malloc(m * sizeof *f->rank_of);
    f->gain_of = malloc(m * sizeof *f->gain_of);
    f->lo = malloc(strips * sizeof *f->lo);
    f->hi = malloc(strips * sizeof *f->hi);
    f->inside = malloc(strips * sizeof *f->inside);
    if (!f->tan_of || !f->rank_of || !f->gain_of || !f->lo || !f->hi || !f->inside)
        return -1;
    plan_sweep(f);
    plan_strip_steps(f, sc->side);
    return 0;
}
