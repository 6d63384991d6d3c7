/* knn.h - k-nearest-neighbour queries on a spatial hash grid.
 *
 * Results are exact and deterministic: neighbours are ordered by squared
 * distance, equal distances by source index, so a query gives the same
 * answer whatever the grid's cell size or the thread count.
 */
#ifndef WPD_CORE_KNN_H
#define WPD_CORE_KNN_H

#include <stddef.h>
#include <stdint.h>

#include "core/grid.h"

#define WPD_KNN_MAX 64      /* largest k supported */

/* k clamped into 3..WPD_KNN_MAX: a plane fit needs 3 points, the query
 * buffers hold WPD_KNN_MAX. */
static inline int wpd_knn_clamp_k(int k)
{
    return k < 3 ? 3 : k > WPD_KNN_MAX ? WPD_KNN_MAX : k;
}
#define WPD_NO_SELF UINT32_MAX

/* The k (1..WPD_KNN_MAX) points of g nearest to q, skipping the point whose
 * source index is `self` (WPD_NO_SELF: skip none) and any point farther than
 * max_dist (INFINITY: no limit). Writes their source indices to idx[] and
 * squared distances to d2[] (d2 may be NULL), nearest first. Returns how
 * many were found: k unless fewer points qualify.
 * The search scans the cells of a box [q - rho, q + rho], growing rho until
 * the k-th distance is within rho, so it is always exact; hint (> 0) is the
 * first rho, 0 means the cell size. A hint at or a little above the k-th
 * distance saves work (the first box is then the only one, and its points
 * beyond the hint are never sorted in); one below it costs a second box. */
int wpd_knn(const wpd_grid *g, const double q[3], int k, uint32_t self,
            double max_dist, double hint, uint32_t *idx, double *d2);

/* Builds a grid (as wpd_grid_build) for k-nearest-neighbour queries among
 * its own points: starting from cell_guess, it measures the k-th neighbour
 * distance of 64 points spread over the grid and, when the median is far
 * from the cell (a box of half-width d_k should span 2-3 cells), rebuilds
 * once with a cell of that median. The result depends only on the points. */
int wpd_grid_build_knn(wpd_grid *g, const double *xyz, const uint32_t *subset, size_t n,
                       int k, double cell_guess, int threads, wpd_error *err);

/* The median distance from 64 of g's points, spread over its slots, to
 * their k-th nearest other point; 0 when g has fewer than 256 points or
 * fewer than half of those probes have k others. */
double wpd_knn_median_kth(const wpd_grid *g, int k);

/* wpd_knn returning grid slots instead of source indices: the neighbours'
 * coordinates are then g->xyz[3*slot ..], whatever array the grid was
 * built from. */
int wpd_knn_slots(const wpd_grid *g, const double q[3], int k, uint32_t self,
                  double max_dist, double hint, uint32_t *slot, double *d2);

/* wpd_knn for nq queries at once (OpenMP, threads <= 0: default), query i
 * at qxyz[3i..3i+2], excluding self[i] (self may be NULL: exclude nothing).
 * Writes idx[i*k ..], d2[i*k ..] (d2 may be NULL) and count[i]. */
void wpd_knn_many(const wpd_grid *g, const double *qxyz, const uint32_t *self,
                  size_t nq, int k, double max_dist, uint32_t *idx, double *d2,
                  uint8_t *count, int threads);

#endif
