/* ladder.h - occupied-voxel counts at a ladder of scales, from a stream of
 * points, in bounded memory: the radius estimate shared by the in-memory
 * and the out-of-core paths, so both start from the same radius.
 *
 * Counting starts at the scale where the bounding box's largest face would
 * fill half the key cap (a surface scene); whenever the set of occupied
 * voxels outgrows the cap, every key is coarsened to the next scale (twice
 * the edge). At the end the final set is coarsened again and again, giving
 * the counts m(l) at edges l, 2l, 4l ... (finest first), which
 * wpd_radius_from_counts turns into the radius with density x m(r) = n.
 */
#ifndef WPD_LADDER_H
#define WPD_LADDER_H

#include <stddef.h>
#include <stdint.h>

#include "core/voxel_set.h"
#include "wpd/radius.h"

#define WPD_LADDER_KEYS (1u << 20) /* keys held at once: 16-24 MB */

typedef struct wpd_ladder {
    wpd_voxel_set set;
    double edge, inv;         /* current voxel edge */
    int level;                /* times coarsened since init */
    size_t cap;               /* keys allowed before coarsening */
    uint64_t last;            /* last key put: scans repeat voxels */
} wpd_ladder;

/* Prepares a ladder for points in [0, extent] per axis (frame coordinates),
 * npoints of them. Returns 0, or -1 when out of memory. */
int wpd_ladder_init(wpd_ladder *l, const double extent[3], uint64_t npoints, size_t cap);

/* Adds one point (frame coordinates, each >= 0). Returns 0 or -1 (memory). */
int wpd_ladder_put(wpd_ladder *l, const double p[3]);

/* Adds every voxel of `from` (consumed; free it after) to `into`; both
 * were initialised with the same arguments. The result is the ladder that
 * one stream of both inputs gives - the finest scale, at or above both,
 * whose occupied voxels fit the cap - so a cloud can be counted in parts on
 * several threads and merged. Returns 0 or -1 (memory). */
int wpd_ladder_merge(wpd_ladder *into, wpd_ladder *from);

/* Counts per scale, finest first, into edge[] and m[] (WPD_MAX_SCALES
 * each); *nscales set. Consumes the set. Returns 0 or -1 (memory). */
int wpd_ladder_finish(wpd_ladder *l, double *edge, uint64_t *m, int *nscales);

void wpd_ladder_free(wpd_ladder *l);

#endif
