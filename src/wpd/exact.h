/* exact.h - cutting a Poisson-disk sample down to exactly n points.
 *
 * In sweeps: every sample's nearest neighbour (among the remaining samples
 * and the fixed samples of neighbouring blocks) is found, samples are taken
 * in order of increasing nearest-neighbour distance (equal distances by
 * global index), and a sample is deleted unless its nearest neighbour was
 * already deleted in this sweep (its distance is then stale, and deleting
 * it too would open a hole where a close pair used to be). A sweep stops at
 * n; further sweeps run until n is reached. The result depends only on the
 * coordinates and global indices.
 */
#ifndef WPD_EXACT_H
#define WPD_EXACT_H

#include <stddef.h>
#include <stdint.h>

#include "common/error.h"

typedef struct wpd_exact_input {
    const double *xyz;       /* block points */
    const uint64_t *gid;     /* their global indices */
    const double *fixed_xyz; /* samples of neighbouring blocks (never deleted) */
    size_t nfixed;
    double spacing;          /* typical sample spacing (the radius), a grid hint */
    int threads;             /* <= 0: OpenMP default */
} wpd_exact_input;

/* Deletes samples from idx[0..count-1] (point indices, ascending) until
 * target remain (nothing when count <= target); idx stays ascending.
 * Returns the new count, or -1 with err set (out of memory). */
long wpd_exact_count(const wpd_exact_input *in, uint32_t *idx, size_t count, size_t target,
                     int *sweeps, wpd_error *err);

/* Distance from each sample idx[i] to its nearest other sample or fixed
 * sample, written to nn[i] (INFINITY when there is none). partner[i] (may be
 * NULL) gets the position in idx of that neighbour, or UINT32_MAX when it is
 * a fixed sample or there is none. Returns 0, or -1 with err set. */
int wpd_nearest_distances(const wpd_exact_input *in, const uint32_t *idx, size_t count,
                          double *nn, uint32_t *partner, wpd_error *err);

#endif
