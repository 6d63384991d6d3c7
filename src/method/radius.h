/* radius.h - the Poisson-disk radius from an estimate of the surface area
 * (paper eq. 1, 3, 4), in two variants:
 *
 * paper       one voxel size, l_v = voxel_frac x largest extent, m occupied
 *             voxels, S = m l_v^2, r = l_v sqrt(m / (lambda n pi)).
 *             Voxels much larger than r see a wall, a roof and the ground
 *             under it as one face and a rough or vegetated surface as flat,
 *             so the first pass misses n by a factor that depends on the
 *             scene: 0.63 .. 1.80 on the scans in data/scans.
 * multiscale  the area that decides a Poisson-disk count is the area seen at
 *             the scale of the disks themselves, so count the voxels whose
 *             edge is r itself: find r with density x m(r) = n, where m(l)
 *             is the number of occupied voxels of edge l and density the
 *             number of samples a greedy pass keeps per occupied r-voxel.
 *             (Random sequential adsorption on a plane would give 0.697; on
 *             the ten scans in data/scans the greedy pass keeps 0.69 x that,
 *             consistently: WPD_MULTISCALE_DENSITY = 0.47 puts the median
 *             first pass at ~1.03 n, all of them within 0.94 .. 1.12 n.)
 *             m is counted at the paper's radius, the equation solved by
 *             log-log interpolation through all counted scales, and m
 *             counted again at the solution until it moves less than 8 %
 *             (2-3 counts).
 *
 * Voxels are aligned to coordinate 0 of the block's frame, so blocks that
 * share an origin share voxels and their counts can be summed per scale by
 * an out-of-core caller, which then calls wpd_radius_from_counts.
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

/* Occupied voxels of edge edge[s] (> 0) for s < nscales among n points,
 * written to m[s]; one pass over the points per scale, the voxels shared out
 * among threads by key hash (threads <= 0: OpenMP default), so the count is
 * exact whatever the threads. A scale too fine for the extent to index in
 * 63 bits gets m = 0. Returns 0, or -1 with err set (out of memory). */
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

/* Multiscale estimate for n points and a target count (>= 1), see above;
 * out->passes counts the passes over the points (the paper's included). */
int wpd_radius_multiscale(const double *xyz, size_t n, size_t target, double lambda,
                          double voxel_frac, double density, int threads,
                          wpd_radius_info *out, wpd_error *err);

#endif
