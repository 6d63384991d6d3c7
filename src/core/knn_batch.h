/* knn_batch.h - every point's k nearest others at once, cell by cell.
 *
 * The answer is wpd_knn's, bit for bit: for each point, the k nearest
 * other points of the grid by (squared distance, source index). The grid
 * is walked cell by cell; the points of the 3 x 3 x 3 cells around a cell
 * are gathered once, as floats in cell units (core/grid_block.h), and each
 * of the cell's points takes its float distance to all of them in one
 * vectorized loop. Those below a threshold (from the previous point's
 * (k+1)-th distance, moved until k + 1 to 2k + 8 pass) are sorted, and
 * when the (k+1)-th is clear of the k-th by more than the floats' error
 * and no point outside the gathered cells can be as near as the k-th
 * (wpd_block_holds), the first k are the answer, ordered exactly in
 * double. Any other point (near ties, too few points around, a block too
 * crowded, an index the grid holds twice) is searched for alone with
 * wpd_knn. One search a point keeps a
 * sorted list through unpredictable branches for every point it scans
 * (about 2 us at k = 13 on the smoothing's samples); here that happens
 * only for the few below the threshold. docs/engine.md, Speed.
 */
#ifndef WPD_CORE_KNN_BATCH_H
#define WPD_CORE_KNN_BATCH_H

#include <stddef.h>
#include <stdint.h>

#include "common/error.h"
#include "core/grid.h"

/* For every point of g whose source index i is below nq: its k (1..
 * WPD_KNN_MAX) nearest other points within max_dist (INFINITY: no limit),
 * as wpd_knn(g, its coordinates, k, i, max_dist, ...) gives them, into
 * idx[row * k ..] and d2[row * k ..] (d2 may be NULL) with row = rows ?
 * rows[i] : i, and their number into count[row]. The grid's cell should be
 * about twice the typical k-th distance (wpd_knn_median_kth): smaller
 * cells send more points to the search alone, larger ones gather more
 * points per cell. A point searched for alone looks no farther than
 * max_dist (an isolated point would otherwise grow its search over the
 * whole grid). threads <= 0: OpenMP's default. *alone (may be NULL): how
 * many points were searched for alone. Returns 0, or -1 with err set (out
 * of memory). */
int wpd_knn_batch(const wpd_grid *g, size_t nq, int k, double max_dist, const uint32_t *rows,
                  uint32_t *idx, double *d2, uint8_t *count, int threads, size_t *alone,
                  wpd_error *err);

#endif
