/* sharp.h - a geometric sharp-feature (edge) detector on the input points.
 *
 * The paper takes edge labels from MSL-Net, a trained network; this is a
 * plain geometric stand-in. A point is a sharp-feature point when the
 * surface variation of its k nearest input points (itself included),
 *   sigma = lambda_min / (lambda_0 + lambda_1 + lambda_2)
 * of their covariance (Pauly, Gross, Kobbelt 2002), exceeds a threshold.
 * Why this measure: it needs no oriented normals (a normal-deviation test
 * needs a consistent orientation, which scans do not give), it reuses the
 * PCA the smoothing needs anyway, and it is scale-free. sigma is ~0 on a
 * plane (noise of a tenth of the spacing gives ~0.003), about 0.06-0.1 for
 * a point on a right-angle crease with k = 13, and up to 1/3 for an
 * isotropic blob. The default threshold WPD_SHARP_THRESHOLD = 0.05 keeps
 * creases of about 90 degrees and sharper; gentler creases need a lower
 * one. Limitation: vegetation and scan noise clusters also score high and
 * are labelled sharp.
 */
#ifndef WPD_SHARP_H
#define WPD_SHARP_H

#include <stddef.h>
#include <stdint.h>

#include "common/error.h"
#include "core/grid.h"

#define WPD_SHARP_THRESHOLD 0.05

/* Labels points 0..n-1 of the grid's source array (the block points come
 * first in it; halo points after them are used as neighbours only): edge[i]
 * = 1 for a sharp-feature point. k in 3..WPD_KNN_MAX. */
void wpd_detect_sharp(const wpd_grid *surface, size_t n, int k, double threshold,
                      uint8_t *edge, int threads);

/* Fewest points (the point itself included) wpd_detect_sharp_capped needs
 * within its cap to call a point sharp. */
#define WPD_SHARP_MIN_POINTS 5

/* The same measure on a bounded neighbourhood, so that a block can label its
 * points exactly: the neighbourhood of a point p is the k nearest points of
 * the grid closer than cap (> 0; INFINITY: no cap) to p, p itself included;
 * with fewer than WPD_SHARP_MIN_POINTS of them p is not sharp. Equal distances are ordered
 * by coordinates (x, then y, then z), never by index, and the points enter
 * the plane fit in that order, so p's label is a function of p and of the
 * coordinates of the grid points closer than cap to it: a block whose grid
 * holds every input point within cap of p labels p as the whole cloud does
 * (in the same coordinate frame), whatever the order of its points or the
 * threads. For a tile whose grid holds its own points and the halo points
 * within H of its box, that is every own point when cap <= H, and every
 * halo point closer than H - cap to the box.
 *
 * Labels the grid's source points begin..end-1 (end <= surface->n; own points
 * first, halo points after them, as for wpd_detect_sharp): writes edge[i] =
 * 1 (sharp) or 0 for i in [begin, end), edge indexed by source index; every
 * grid point serves as a neighbour. k in 3..WPD_KNN_MAX (clamped). */
void wpd_detect_sharp_capped(const wpd_grid *surface, size_t begin, size_t end, int k, double cap,
                             double threshold, uint8_t *edge, int threads);

#endif
