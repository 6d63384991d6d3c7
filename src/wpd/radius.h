/* radius.h - the Poisson-disk radius from an estimate of the surface area
 * (paper eq. 1, 3, 4), in two variants:
 *
 * paper       one voxel size, l_v = voxel_frac x largest extent, m occupied
 *             voxels, S = m l_v^2, r = l_v sqrt(m / (lambda n pi)).
 *             Voxels much larger than r see a wall, a roof and the ground
 *             under it as one face, and a rough or vegetated surface as flat:
 *             the area, and so r, is off by a factor that depends on the
 *             scene (see docs in the report).
 * multiscale  the area that decides a Poisson-disk count is the area seen at
 *             the scale of the disks themselves, so count the voxels whose
 *             edge is r itself: find r with density x m(r) = n, where m(l)
 *             is the number of occupied voxels of edge l and density the
 *             number of samples a greedy Poisson-disk pass keeps per
 *             occupied voxel of edge r (random sequential adsorption on a
 *             plane gives 0.547 x 4 / pi = 0.697; measured on real scans
 *             WPD_MULTISCALE_DENSITY). m(l) is counted at several scales in
 *             one pass and interpolated log-log; a further pass is made
 *             only when r falls outside the counted scales.
 *
 * Voxels are aligned to coordinate 0 of the block's frame, so blocks that
 * share an origin share voxels and their counts can be summed (per scale)
 * by an out-of-core caller, which then calls wpd_radius_from_counts.
 */
#ifndef WPD_RADIUS_H
#define WPD_RADIUS_H

#include <stddef.h>
#include <stdint.h>

#include "common/error.h"

#define WPD_MULTISCALE_DENSITY 0.47
#define WPD_MAX_SCALES 16

typedef struct wpd_radius_info {
    double radius;       /* the estimate */
    double area;         /* surface area estimate behind it */
    double voxel_edge;   /* voxel edge of the scale used (interpolated) */
    double voxels;       /* occupied voxels at that scale (interpolated) */
    int passes;          /* voxel-counting passes over the points */
} wpd_radius_info;

/* Occupied voxels of edge edge[s] (> 0) for s < nscales (<= WPD_MAX_SCALES)
 * among n points, written to m[s]. A scale whose edge is a power-of-two
 * multiple of a smaller one is derived from that one's voxel set, so
 * scales laid out in octave chains cost one pass over the points per chain
 * (chains counted in parallel; threads <= 0: OpenMP default). A scale too
 * fine for the extent to index in 63 bits gets m = 0. Returns 0, or -1 with
 * err set (out of memory). */
int wpd_voxel_counts(const double *xyz, size_t n, const double *edge, int nscales,
                     uint64_t *m, int threads, wpd_error *err);

/* Paper eq. 4: l_v sqrt(m / (lambda n pi)). */
double wpd_radius_paper_formula(double m, double lv, size_t target, double lambda);

/* Paper estimate for n points and a target count (>= 1). */
int wpd_radius_paper(const double *xyz, size_t n, size_t target, double lambda,
                     double voxel_frac, int threads, wpd_radius_info *out, wpd_error *err);

/* Solves density x m(r) = target from counts m[s] at edges edge[s] (any
 * order, at least one scale), interpolating log m against log l between the
 * two scales around the solution, extrapolating with the nearest slope
 * (area-like, m ~ l^-2, when only one scale is known) outside them. Fills
 * out (passes untouched) and returns 1 when the solution lies within the
 * counted scales, 0 when it was extrapolated. */
int wpd_radius_from_counts(const double *edge, const uint64_t *m, int nscales, size_t target,
                           double density, wpd_radius_info *out);

/* Multiscale estimate for n points and a target count (>= 1): starts from
 * the paper estimate, counts 7 scales around it, repeats around the
 * extrapolated radius while it falls outside (at most 3 rounds). */
int wpd_radius_multiscale(const double *xyz, size_t n, size_t target, double lambda,
                          double voxel_frac, double density, int threads,
                          wpd_radius_info *out, wpd_error *err);

#endif
