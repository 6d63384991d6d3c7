/* eliminate.h - cutting a Poisson-disk sample down to exactly n points
 * without opening holes: coverage-aware elimination.
 *
 * The samples S of a maximal Poisson pass cover the input: every input
 * point lies within r of a sample. Deleting a sample s hands each input
 * point of its region (the points whose nearest sample is s) to that
 * point's second-nearest sample, so the hole s leaves is
 *     cost(s) = max over the input points p whose nearest sample is s of
 *               the distance from p to its second-nearest sample.
 * The elimination deletes samples in increasing cost, as the sequential
 * greedy "delete the sample whose deletion opens the smallest hole" would,
 * in sweeps that each need one look at every input point:
 *   1. every input point is handed in (wpd_eliminate_add_points, in any
 *      order, from any number of blocks): the costs of the live samples;
 *   2. wpd_eliminate_sweep takes the samples up to the cost of rank
 *      q + min(q, live / 20) (q: deletions still to make) in order of
 *      (rank, index), rank = cost x a crowding factor <= 1 (the crowded
 *      first among similar costs: (d / median d)^2 for a sample whose
 *      nearest live sample lies at d below the median of d), and deletes
 *      each one that has no sample deleted before it in the sweep within
 *      twice the larger of their costs, until q are deleted.
 * Costs look no farther than the reach R (the engine's input halo, 2.5
 * times the first radius): an input point farther than R from every sample
 * counts for none, a second-nearest sample beyond R counts as at R, and the
 * crowding distance below is at most R. With that, a tile that sees the
 * input points within R of its box and the samples within 2 R computes
 * its own samples' costs exactly as the whole cloud would (the exact count
 * through tiles, resample/exact.c); in practice no cost reaches R
 * (the largest candidate bound on the shared scans is 2.2 r).
 * Two samples deleted in one sweep never touch each other's regions or
 * second-nearest samples (the rule of step 2), so each opens exactly the
 * hole its cost says. A sweep always deletes at least the candidate of
 * smallest rank. The result depends only on the coordinates of the samples and of
 * the input points and on the sample order (ties by index): not on the
 * threads, nor on how the input is cut into blocks.
 *
 * Measured on NC Raleigh (2.27 M points) -> 100 K from the default first
 * pass (105 K, one sweep): Hausdorff 0.00131 of the diagonal, as dart
 * throwing at the same count; pruning and deleting in nearest-neighbour
 * order, as before, gave 0.00212 (docs/algorithm.md, section 3).
 */
#ifndef WPD_ELIMINATE_H
#define WPD_ELIMINATE_H

#include <stddef.h>
#include <stdint.h>

#include "common/error.h"
#include "core/bits.h"
#include "core/grid.h"

typedef struct wpd_eliminate {
    size_t n;             /* samples */
    size_t live;          /* samples not deleted */
    const double *xyz;    /* [3n] sample coordinates (the caller's) */
    const uint8_t *half;  /* [n] 1: a sample of radius r/2 (sharp feature), or NULL */
    uint8_t *alive;       /* [n] */
    uint64_t *cost;       /* [n] squared cost as the bits of a double (>= 0,
                             so integer order is numeric order) */
    uint32_t *live_idx;   /* [n] indices of the live samples, ascending */
    wpd_grid grid;        /* over the live samples */
    double spacing;       /* grid cell */
    double reach;         /* R above */
    int threads;
} wpd_eliminate;

/* Starts with all n samples (xyz[3i..3i+2], kept by the caller for the
 * life of e) live; half (may be NULL): samples of radius r/2 (sharp
 * features), whose holes count relative to their radius: they are ranked
 * by 4 times their squared cost, or a crowded edge line would be the first
 * to go. spacing: the sample spacing (the radius), a grid hint; reach: R
 * above (<= 0: none). Returns 0, or -1 with err set (out of memory). */
int wpd_eliminate_init(wpd_eliminate *e, const double *xyz, const uint8_t *half, size_t n,
                       double spacing, double reach, int threads, wpd_error *err);

/* After wpd_eliminate_begin: the distance from live sample s to its
 * nearest other live sample, or the reach when none lies within it. */
double wpd_eliminate_nearest(const wpd_eliminate *e, uint32_t s);

/* wpd_eliminate_nearest of every live sample s into nn[s] (nn: room for
 * e->n; other entries untouched), the same values, all at once (a batch
 * k-NN: core/knn_batch.h). */
void wpd_eliminate_nearest_all(const wpd_eliminate *e, double *nn);

/* A squared cost (bits of a double) as the sweep ranks it: 4 times for a
 * sample of radius r/2. */
static inline double wpd_eliminate_cost_of(uint64_t cost_bits, int half)
{
    double c = wpd_bits_double(cost_bits);
    return half ? 4 * c : c;
}

/* The crowding factor of a sample whose nearest live sample lies at nn,
 * when the median of that distance over the live samples is median. */
static inline double wpd_eliminate_crowd_factor(double nn, double median)
{
    double f = median > 0 && nn < median ? nn / median : 1;
    return f * f;
}

/* Opens a sweep: indexes the live samples and zeroes their costs.
 * Returns 0, or -1 with err set. */
int wpd_eliminate_begin(wpd_eliminate *e, wpd_error *err);

/* No sample strictly nearest to a point (wpd_eliminate_add_points). */
#define WPD_ELIMINATE_NO_NEAREST UINT32_MAX

/* Hands in input points pts[3i..3i+2], i < npts (frame coordinates, as the
 * samples'), but those with skip[i] != 0 (skip may be NULL). Every input
 * point must be handed in exactly once per sweep (the samples themselves
 * are input points too). May run on several threads, also concurrently for
 * different blocks. nearest (NULL: not wanted) gets, per point, its nearest
 * live sample when that is strictly nearer than every other live sample,
 * else WPD_ELIMINATE_NO_NEAREST (a tie, no sample at all, a skipped point):
 * the costs find it anyway, and smoothing's cover starts from it. */
void wpd_eliminate_add_points(wpd_eliminate *e, const double *pts, const uint8_t *skip,
                              size_t npts, int threads, uint32_t *nearest);

/* Closes the sweep: deletes samples (rules above) while more than target
 * are live. Returns the number deleted (>= 1 when live > target), or -1
 * with err set (out of memory). */
long wpd_eliminate_sweep(wpd_eliminate *e, size_t target, wpd_error *err);

void wpd_eliminate_free(wpd_eliminate *e);

#endif
