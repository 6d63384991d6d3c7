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
 *
 * Finer scales are estimated from a sample. A large cloud to a large n
 * needs r below the finest exact scale (the 111 M-point NC 7 x 7 cloud to
 * 1 M: r about 46 against an exact ladder that starts at 122), and the
 * slope of the counts there is not the slope above it (-2.3 against -1.9
 * on that cloud): extrapolated, r came out 10 % small and the first
 * Poisson pass kept 1.39 n, so the whole pass was done again. So a sample
 * ladder, 4 times finer, counts only the points of blocks of 4 times the
 * exact edge that a hash of the block picks (one in 16): about as many
 * keys. Its counts at the scales finer than the exact ladder's finest,
 * scaled by the ratio of the two ladders' counts at that finest exact
 * scale, come first in the output - while the exact ladder has coarsened
 * at most twice (beyond, its voxels hold several blocks and the ratio
 * means nothing: no estimate, the counts extrapolate as before). The same
 * cloud to 10 % and 50 % needs r of 15.6 and 6 against that sample's
 * finest 30: a second sample ladder, 4 times finer again, counts the
 * points of one in 16 of the blocks of the exact edge inside the first
 * sample's blocks, and is scaled by the ratio to the first sample's
 * estimate in the same way. Every ladder depends only on the points, not
 * on their order or on how they were split between lanes.
 */
#ifndef WPD_LADDER_H
#define WPD_LADDER_H

#include <stddef.h>
#include <stdint.h>

#include "core/voxel_set.h"
#include "method/radius.h"

#define WPD_LADDER_KEYS (1u << 20) /* keys held at once by each set (the
                                      exact one and each sample's): 16-24 MB
                                      each, 32 while coarsening */

/* One set of occupied voxels, coarsened as it grows. */
typedef struct wpd_ladder_scale {
    wpd_voxel_set set;
    double edge, inv;         /* current voxel edge */
    int level;                /* times coarsened since init */
    uint64_t last;            /* last key put: scans repeat voxels */
    uint64_t *recent;         /* [WPD_LADDER_RECENT] keys put lately, by a hash of
                                 the key: a scan line's voxels come back on the
                                 next lines, and a key found here is in the set */
} wpd_ladder_scale;

#define WPD_LADDER_RECENT_BITS 12
#define WPD_LADDER_RECENT (1u << WPD_LADDER_RECENT_BITS)

/* Sample ladders at most: each 4 times finer than the one before, on one
 * block in 16 of that one's sampled blocks. */
#define WPD_LADDER_SAMPLES 2

typedef struct wpd_ladder {
    wpd_ladder_scale all;     /* every point */
    wpd_ladder_scale sample[WPD_LADDER_SAMPLES]; /* the points of the sampled
                                 blocks, 4 and 16 x finer */
    double block_inv[WPD_LADDER_SAMPLES]; /* 1 / each sample's blocks' edge */
    uint64_t last_block;      /* the last point's first-level block, and whether
                                 the first sample holds it */
    int last_depth;
    int sampling;             /* how many sample ladders run */
    size_t cap;               /* keys allowed per set before coarsening */
} wpd_ladder;

/* Prepares a ladder for points in [0, extent] per axis (frame coordinates),
 * npoints of them, for a radius where about `wanted` voxels are occupied.
 * The sample ladders run as wpd_ladder_samples says: the first only when
 * wanted exceeds cap / 2, the keys the exact ladder's first scale is
 * sized for (a surface as large as the box's largest face): below that the
 * exact scales bracket the radius on the shared scans, and the sample
 * would cost a quarter more scan time for nothing (NC Raleigh); the second
 * when wanted exceeds 16 times that, past the first sample's finest scale.
 * Returns 0, or -1 when out of memory. */
int wpd_ladder_init(wpd_ladder *l, const double extent[3], uint64_t npoints, size_t cap,
                    double wanted);

/* How many sample ladders a ladder of that cap runs for `wanted`. */
static inline int wpd_ladder_samples(size_t cap, double wanted)
{
    double first = (double)(cap < 1024 ? 1024 : cap) / 2;
    return wanted > 16 * first ? 2 : wanted > first ? 1 : 0;
}

/* Adds one point (frame coordinates, each >= 0). Returns 0 or -1 (memory). */
int wpd_ladder_put(wpd_ladder *l, const double p[3]);

/* Adds every voxel of `from` (consumed; free it after) to `into`; both
 * were initialised with the same arguments. The result is the ladder that
 * one stream of both inputs gives - the finest scale, at or above both,
 * whose occupied voxels fit the cap - so a cloud can be counted in parts on
 * several threads and merged. Returns 0 or -1 (memory). */
int wpd_ladder_merge(wpd_ladder *into, wpd_ladder *from);

/* The voxels of l as bytes, for a ladder counted on another process (the
 * ranks of an MPI run, par/par.h): *buf (malloc'd) of *n bytes. Returns 0
 * or -1 (memory). */
int wpd_ladder_pack(const wpd_ladder *l, uint8_t **buf, size_t *n);

/* wpd_ladder_merge with a ladder packed by wpd_ladder_pack from a ladder
 * initialised with the same arguments as `into`. Returns 0, or -1 (memory,
 * or bytes that are no such ladder). */
int wpd_ladder_merge_packed(wpd_ladder *into, const uint8_t *buf, size_t n);

/* Counts per scale, finest first, into edge[] and m[] (WPD_MAX_SCALES
 * each); *nscales set, *nestimated of them (the first ones) estimated
 * from the samples, the others exact. A sample's estimates are given only
 * when it holds at least WPD_LADDER_SAMPLE_MIN voxels at the finest scale
 * known without it (the second sample's only after the first's). Consumes
 * the sets. Returns 0 or -1 (memory). */
int wpd_ladder_finish(wpd_ladder *l, double *edge, uint64_t *m, int *nscales, int *nestimated);

#define WPD_LADDER_SAMPLE_MIN 1024

void wpd_ladder_free(wpd_ladder *l);

#endif
