/* scan.h - the engine's streaming passes over the inputs before tiling.
 *
 * The frame: its origin is the minimum corner of the box, so every later
 * coordinate is small and precise. LAS headers declare the box; the scan
 * runs in that frame and checks it against the points (wpd_bounds_tight),
 * scanning again in the points' own frame when a header is off. Other
 * inputs get a bounds pass first. The scan pass counts finite points per
 * file, occupied voxels and a coarse density grid:
 * - occupied voxels at a ladder of scales (method/ladder.h), in bounded
 *   memory whatever the input size; the global radius comes from these
 *   counts, exactly as the in-memory path computes it.
 * - the density grid (cubic cells, at most WPD_SCAN_GRID along the longest
 *   axis) counts points per cell for the tile planner.
 * - occupied voxels at the paper's one scale (paper_frac x the longest
 *   side, aligned to the frame origin), for its radius estimate (eq. 3-4),
 *   exactly where the voxels number at most WPD_SCAN_PAPER_CELLS.
 */
#ifndef WPD_SCAN_H
#define WPD_SCAN_H

#include <stddef.h>
#include <stdint.h>

#include "common/error.h"
#include "common/progress.h"
#include "io/cloud.h"
#include "par/par.h"
#include "method/radius.h"

#define WPD_SCAN_GRID 128
#define WPD_SCAN_PAPER_CELLS (1u << 24) /* a bit each, per thread */

typedef struct wpd_scan {
    uint64_t count;                   /* finite points */
    int nfiles;
    uint64_t *file_count;             /* [nfiles] finite points per file */
    uint64_t dropped;                 /* points with non-finite coordinates */
    uint64_t nunits;                  /* with several ranks, over a cloud that can seek: */
    uint64_t *unit_points;            /* [nunits] finite points per unit of a pass
                                         (wpd_pass_units); else 0, NULL */
    double origin[3];                 /* frame origin: minimum corner of the box
                                         (the declared one when tight) */
    double extent[3];                 /* box size */
    double wanted_voxels;             /* as given to wpd_scan_run */
    int nscales;
    int nestimated;                   /* the first nestimated scales: estimated from a
                                         sample (method/ladder.h), the others exact */
    double edge[WPD_MAX_SCALES];      /* voxel edges, finest first, doubling */
    uint64_t voxels[WPD_MAX_SCALES];  /* occupied voxels at each edge */
    int dim[3];                       /* density grid cells per axis */
    double cell, inv_cell;            /* density grid cell edge, its inverse */
    uint64_t *density;                /* [dim0 * dim1 * dim2], x fastest */
    double paper_frac;                /* the paper's voxel edge / longest side */
    double paper_edge;                /* that edge, and the voxels occupied at it */
    uint64_t paper_voxels;            /* (0: too many voxels to count exactly) */
    double bounds_seconds, scan_seconds;
} wpd_scan;

/* Runs the passes over cloud (rewound before and after) on up to `threads`
 * threads (>= 1; the counts do not depend on it): as many as fit in `room`
 * bytes beside the first thread's working set (wpd_threads_within, budget.h).
 * paper_frac: the paper's voxel edge over the longest side, or 0 when the
 * paper's estimate is not wanted (its count costs a bitmap write a point).
 * voxel_cap: the most voxel keys each of a thread's ladder sets holds
 * at once (memory: ~32 bytes each); wanted_voxels: about how many voxels
 * the radius will occupy (the target over the density), which decides
 * whether the sampled finer scales are counted (wpd_ladder_init).
 * par (NULL: one process): the ranks of an MPI run share the reading, each
 * counting its share of the units, and every rank gets the counts of all
 * (the same as one process counting everything); every rank must call it.
 * Returns 0, or -1 with err set (read errors; WPD_E_INPUT when there is no
 * finite point). progress (may be NULL) gets phases
 * "bounds" (when it runs) and "scan". */
int wpd_scan_run(wpd_cloud *cloud, const wpd_par *par, size_t voxel_cap, double wanted_voxels,
                 double paper_frac, int threads, size_t room, wpd_progress *progress,
                 wpd_scan *out, wpd_error *err);

/* Density grid cell of frame point p (clamped into the grid). Inline: the
 * scan and the tiler ask it for every point. */
static inline size_t wpd_scan_cell_of(const wpd_scan *s, const double p[3])
{
    size_t c[3];
    for (int a = 0; a < 3; a++) {
        double f = p[a] * s->inv_cell;
        long i = f < 0 ? 0 : (long)f;
        c[a] = (size_t)(i >= s->dim[a] ? s->dim[a] - 1 : i);
    }
    return c[0] + (size_t)s->dim[0] * (c[1] + (size_t)s->dim[1] * c[2]);
}

void wpd_scan_free(wpd_scan *s);

#endif
