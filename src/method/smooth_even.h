/* smooth_even.h - the even-spacing steps of smoothing (internal to
 * method/smooth.c).
 *
 * The Voronoi (Lloyd) steps even the samples' cells on a surface; they
 * leave the local spacing uneven where a Poisson sample left its gaps and
 * clusters, and they cannot act where there is no surface (vegetation,
 * multiple returns). An even-spacing step moves a sample onto one of the
 * input points near it, the one that brings the local spacing m (the mean
 * distance to the EVEN_K nearest samples: the paper's local density
 * measure) of the sample and of its neighbours closest to their local
 * mean. Positions are input points, so the step needs no tangent plane and
 * invents nothing; distances are 3-D, so it works in volumes as on
 * surfaces. All samples plan from the previous positions (Jacobi), so the
 * result does not depend on threads; the guards of smooth_guard.h judge
 * the moves as they judge the Lloyd steps. docs/algorithm.md, section 4.
 */
#ifndef WPD_SMOOTH_EVEN_H
#define WPD_SMOOTH_EVEN_H

#include <stddef.h>
#include <stdint.h>

#include "core/grid.h"

/* Samples that define a sample's local spacing (the local density
 * measure of `wpd metrics` and of the paper uses 6). */
#define WPD_EVEN_K 6

/* A sample's WPD_EVEN_K + 1 nearest listed neighbours at prev, nearest
 * first (fewer where the list is shorter: the rest have id UINT32_MAX). */
typedef struct wpd_even_nearest {
    uint32_t id[WPD_EVEN_K + 1];
    double d[WPD_EVEN_K + 1];
} wpd_even_nearest;

/* The samples' neighbourhoods at one iteration's previous positions. */
typedef struct wpd_even_view {
    const double *prev;     /* positions: n samples, then context samples */
    size_t n;
    const uint32_t *nb;     /* [n*k] neighbour lists (index < n: sample, else context) */
    const uint8_t *cnt;     /* [n] neighbours in each list */
    int k;
    const double *spacing;  /* [n] local spacing of each sample at prev */
    const wpd_even_nearest *nearest; /* [n] */
} wpd_even_view;

/* spacing[o] = mean distance from sample o to its WPD_EVEN_K nearest
 * listed neighbours at prev (all listed ones if fewer; 0 if none), and
 * nearest[o] those neighbours and the next one. */
void wpd_even_spacings(const double *prev, size_t n, const uint32_t *nb, const uint8_t *cnt,
                       int k, double *spacing, wpd_even_nearest *nearest, int threads);

/* Limits of one sample's step. */
typedef struct wpd_even_limits {
    double reach;           /* candidates lie within this of the sample (its step cap) */
    double floor;           /* and at least this far from every listed neighbour */
    const double *start;    /* and within wander of here (the Poisson position) */
    double wander;
} wpd_even_limits;

/* Input points a sample may move onto: the nearest within its reach. At
 * 10 % of the input the reach (0.35 r) holds one or two, at 1 % about 20.
 * The 8 nearest rather than all of them: a Jacobi step onto the farthest
 * points of the reach overshoots, so the nearer ones win most sums anyway.
 * Against 24 (bench/quality_check.py, seeds 0-3): the same 18, 15, 17, 17
 * cases; NC 3 x 3 to 1 % (20 M points) local CV 0.0750 -> 0.0722, Voronoi
 * CV 0.3327 -> 0.3284, the smoothing 0.77x the time; NC Raleigh to 1 %
 * 0.0746 -> 0.0717 and 0.3441 -> 0.3372. 6 candidates lost cases (17, 15,
 * 17, 16). docs/algorithm.md section 4. */
#define WPD_EVEN_CANDIDATES 8

/* Input points a sample may move onto, best first, when the guards
 * refuse the best. */
#define WPD_EVEN_TRIES 4

/* The input points of surface within reach of sample o (at most the
 * WPD_EVEN_CANDIDATES nearest) that lower sum (m_s - t)^2 below its value
 * where o stands, over o and its listed neighbours s that are samples,
 * with t the mean of their spacings at prev and the neighbours' lists as
 * at prev but for o's position. Writes the grid slots of the
 * WPD_EVEN_TRIES best to slot[], lowest sum first (ties: the nearer
 * point), and returns how many (0: no input point lowers it). */
int wpd_even_candidates(const wpd_even_view *v, const wpd_grid *surface, size_t o,
                        const wpd_even_limits *lim, uint32_t slot[WPD_EVEN_TRIES]);

#endif
