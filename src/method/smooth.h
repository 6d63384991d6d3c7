/* smooth.h - weighted tangent smoothing (paper eq. 7-8), kept on the
 * scanned surface.
 *
 * Once, before the iterations: each sample's k nearest neighbours (among the
 * samples and the context samples of neighbouring blocks) and its PCA
 * normal over itself and those neighbours. Then, per iteration, for every
 * sample at once (Jacobi: all read the previous iteration's positions, so
 * the result does not depend on threads): the neighbours are projected on
 * the sample's tangent plane, its Voronoi cell among them is clipped out of
 * a square frame (core/voronoi.h), and the sample moves towards the area
 * centroid of that cell: a Lloyd / CVT step, the one the paper derives eq. 8
 * from (eq. 8 taken literally, the cotangent-weighted mean of the
 * neighbours, is the point itself whenever its cell is closed, so it never
 * moves a point; docs/algorithm.md). A sample
 * whose cell is open (still touches the frame: it lies on a border of the
 * sampling) does not move, nor does a sharp-feature sample with a normal
 * (non-sharp) neighbour, nor a sample whose neighbourhood is no surface
 * (vegetation, multiple returns: surface variation above 0.1) or whose
 * input neighbours are sparser than the samples.
 *
 * With the input points given, even-spacing steps are taken in turn with
 * those Voronoi steps (smooth_even.h): each sample but the sharp-feature
 * ones moves onto the input point near it that best evens its and its
 * neighbours' local spacing, in volumes as on surfaces.
 *
 * The paper moves samples within their tangent planes only, so on a curved
 * surface they drift off it, a little more each iteration. Here, when the
 * input points are given, a moved sample is put back on the surface: onto
 * the PCA plane of the k input points nearest to its new position.
 *
 * Guarantees (smooth_guard.h): no two samples end closer than 0.82 x their
 * Poisson distance (spacing; spacing/2 between two sharp-feature samples),
 * if they started at least that far apart; with the input points given, no
 * input point ends farther from the samples than max(spacing, its distance
 * before smoothing); no sample ends farther than spacing from its start.
 * A move that would break one is shortened, or dropped. Context samples
 * do not move: a block smoothed after its neighbours keeps clear of their
 * final positions.
 */
#ifndef WPD_SMOOTH_H
#define WPD_SMOOTH_H

#include <stddef.h>
#include <stdint.h>

#include "common/error.h"
#include "core/grid.h"

typedef struct wpd_smooth_input {
    double *xyz;             /* [3n] sample positions: read, then replaced */
    size_t n;
    const uint8_t *edge;     /* per sample: sharp-feature label, or NULL */
    const double *ctx_xyz;   /* samples of neighbouring blocks: neighbours only */
    const uint8_t *ctx_edge; /* their sharp-feature labels, or NULL (none sharp) */
    size_t nctx;
    const wpd_grid *surface; /* grid over the input points, or NULL: no projection */
    double surface_hint;     /* guess of the distance to the k-th nearest input
                                point (a search radius; 0: the grid's cell) */
    int k;                   /* neighbours per sample (13), 3..WPD_KNN_MAX */
    int iterations;          /* Voronoi steps (5) */
    double spacing;          /* the Poisson radius r of the samples (> 0; 0: nothing
                                moves): the guards' unit, no two samples closer to
                                begin with */
    int threads;             /* <= 0: OpenMP default */
    double resolution[3];    /* the output stores coordinates as multiples of these
                                per axis in the block frame (LAS scale); 0: exact.
                                The surface guarantee judges rounded positions. */
    int even_iterations;     /* even-spacing steps, alternated with the Voronoi
                                steps, a Voronoi step first (smooth_even.h; they
                                need surface, else none) */
    const uint32_t *nearest; /* per input point (by surface's slots),
                                the sample (index into xyz) strictly nearer to it
                                than every other sample and context sample, or
                                WPD_SMOOTH_NO_NEAREST; or NULL. Where an earlier
                                pass found these (the exact count), the coverage
                                guard starts from them (the same result) */
    int check_nearest;       /* tests: the cover's first owners are also searched
                                for, and any difference from those nearest gives
                                an error (WPD_E_USAGE: a bug) */
} wpd_smooth_input;

#define WPD_SMOOTH_NO_NEAREST UINT32_MAX

/* No sample ends farther than this many spacings (r) from where it
 * started, whatever the iterations: the tiles rely on it (a tile's context
 * reaches 3 r past its box, resample/smooth.c; the exact count's nearest
 * samples, resample/hints.h). */
#define WPD_SMOOTH_WANDER_MAX 1.0

typedef struct wpd_smooth_stats {
    size_t open_cells;       /* samples kept fixed for an open cell (last iteration) */
    size_t sharp_fixed;      /* sharp-feature samples kept fixed */
    size_t volume_fixed;     /* kept fixed by the Voronoi steps: their neighbourhood
                                is no surface (even-spacing steps may move them) */
    size_t isolated_fixed;   /* kept fixed by the Voronoi steps: no scanned surface
                                around them (even-spacing steps may move them) */
    size_t shortened;        /* moves shortened by the spacing or coverage guard
                                (all iterations; smooth_guard.h) */
    size_t refused;          /* moves the guards refused altogether */
    size_t pulled_to_surface; /* samples pulled back to within the input's local
                                 spacing of the input (see smooth.c) */
    size_t hinted;           /* input points whose first owner in the cover came from
                                in->nearest */
    double mean_move;        /* mean distance moved per sample over all iterations,
                                in units of spacing */
    double normals_seconds;  /* neighbour search and normals */
    double smooth_seconds;   /* the iterations */
} wpd_smooth_stats;

/* Smooths in->xyz in place. Returns 0, or -1 with err set. */
int wpd_smooth(const wpd_smooth_input *in, wpd_smooth_stats *stats, wpd_error *err);

/* How far samples are from the scanned surface, in units of the input's
 * local spacing s = sqrt(pi d_k^2 / k) (d_k: distance from the sample to its
 * k-th nearest input point, so s is the side of the square each input point
 * covers there). */
typedef struct wpd_drift {
    size_t n;
    double mean_nearest;     /* mean distance to the nearest input point / s */
    double max_nearest;
    double frac_beyond;      /* fraction of samples farther than s from every input point */
    double mean_plane;       /* mean distance to the PCA plane of the k nearest input points / s */
    double max_plane;
} wpd_drift;

/* Measures the drift of n samples at xyz against the input grid. */
void wpd_measure_drift(const wpd_grid *surface, const double *xyz, size_t n, int k,
                       int threads, wpd_drift *out);

#endif
