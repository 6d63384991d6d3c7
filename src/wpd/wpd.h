/* wpd.h - Weighted Poisson-disk resampling of one block of points in
 * memory: the whole pipeline of the paper (radius, Poisson pass and
 * refinement, exact count, weighted tangent smoothing, optional sharp
 * features) in one call, for a target count.
 *
 * The out-of-core engine calls this once per tile, on many tiles in
 * parallel (params.threads = 1 each) or on one large tile with all threads.
 * Every step is reentrant (no global state) and deterministic: the same
 * block, target and seed give the same result whatever the thread count.
 * The order in which Poisson candidates are visited is a hash of (seed,
 * global index), so it does not depend on how the cloud was split.
 *
 * The finer-grained steps are public too, for an engine that coordinates
 * tiles itself:
 *   radius   each tile's wpd_voxel_counts at a few common edges (voxels are
 *            aligned to a shared origin), summed, then wpd_radius_from_counts
 *            for the global n (radius.h);
 *   passes   per tile one wpd_poisson_prepare (its points; fixed = samples
 *            already accepted by finished neighbour tiles of an earlier
 *            colour), then per round wpd_poisson_run(ctx, r) on every tile,
 *            the counts summed and given to one wpd_refine_report, which
 *            decides the next r for all (poisson.h, refine.h);
 *   count    wpd_exact_count with a per-tile quota, or a global ranking
 *            built from wpd_nearest_distances (exact.h);
 *   smooth   wpd_smooth with the neighbour tiles' samples as context and a
 *            grid over the tile's input plus halo as surface (smooth.h);
 *   sharp    wpd_detect_sharp on the same grid (sharp.h).
 * Or wpd_run_block per tile with params.radius set to the global radius.
 */
#ifndef WPD_WPD_H
#define WPD_WPD_H

#include <stddef.h>
#include <stdint.h>

#include "common/error.h"

/* One block. Coordinates are relative to a local origin chosen by the
 * caller (real scans lie ~1e6 units from 0: subtract e.g. the block's
 * minimum corner), in double precision. The optional neighbour arrays are
 * in the same frame; they are never output or moved. */
typedef struct wpd_block {
    size_t n;                 /* points */
    const double *xyz;        /* [3n] x y z */
    const uint64_t *gid;      /* [n] global index of each point's source record */
    const double *fixed_xyz;  /* (a) accepted samples of neighbouring tiles: no new
                                 sample within r of them; also count as neighbours
                                 in the exact count */
    size_t nfixed;
    const double *ctx_xyz;    /* (b) samples of neighbouring tiles used as smoothing
                                 neighbours */
    size_t nctx;
    const double *halo_xyz;   /* input points of neighbouring tiles near the border:
                                 surface support only (projection, sharp detection) */
    size_t nhalo;
} wpd_block;

typedef enum wpd_radius_method {
    WPD_RADIUS_PAPER = 0,     /* paper eq. 3-4: one voxel scale, voxel_frac x extent */
    WPD_RADIUS_MULTISCALE = 1 /* voxels counted at the scale of r itself (radius.h) */
} wpd_radius_method;

typedef struct wpd_params {
    double lambda;            /* overlap factor of eq. 1 (0.68) */
    double voxel_frac;        /* voxel edge / largest extent (0.05) */
    wpd_radius_method radius_method; /* WPD_RADIUS_MULTISCALE */
    double density;           /* multiscale: samples per occupied r-voxel */
    double radius;            /* > 0: start from this radius, no estimate
                                 (an engine's global radius) */
    int max_passes;           /* refinement passes at most (40) */
    int prune_previous;       /* 1: a pass at a larger radius prunes the previous
                                 overshooting sample, as the authors' release does,
                                 instead of the input (off: see wpd.c) */
    int k;                    /* neighbours for normals and smoothing (13) */
    int iterations;           /* smoothing iterations (5) */
    int smooth;               /* 1: weighted tangent smoothing (on) */
    int smooth_mode;          /* a wpd_smooth_mode (smooth.h): WPD_SMOOTH_CENTROID */
    int keep_on_surface;      /* 1: project smoothed samples onto the input surface (on) */
    int sharp;                /* 1: detect sharp features, sample them at r/2 (off) */
    double sharp_threshold;   /* surface variation above which a point is sharp */
    double resolution[3];     /* the output stores coordinates as multiples of these
                                 per axis in the block frame (a LAS scale, when the
                                 block's origin is an input point); 0: exact (0) */
    uint64_t seed;            /* visiting order (0) */
    int threads;              /* OpenMP threads inside the block; <= 0: default */
} wpd_params;

/* Fills p with the defaults above. */
void wpd_params_default(wpd_params *p);

/* Wall times of the steps, seconds. */
typedef struct wpd_timings {
    double radius;            /* radius estimate */
    double surface;           /* grid over the input for projection / sharp features
                                 (with 2+ threads and sharp off, built during the
                                 Poisson passes, so not part of the total) */
    double sharp;             /* sharp-feature detection */
    double poisson;           /* all Poisson passes with the refinement */
    double exact;             /* exact count */
    double normals;           /* sample neighbourhoods and normals */
    double smooth;            /* smoothing iterations */
    double total;
} wpd_timings;

typedef struct wpd_result {
    size_t count;             /* samples: the target, or n when n <= target */
    uint64_t *gid;            /* [count] global indices, ascending */
    uint32_t *index;          /* [count] block index of each sample */
    double *xyz;              /* [3count] smoothed coordinates, block frame */
    uint8_t *edge;            /* [count] sharp-feature label; NULL when sharp is off */
    double radius_estimate;   /* radius before refinement */
    double radius;            /* radius of the pass that was kept */
    size_t first_pass_count;  /* samples of the first pass (estimate quality) */
    size_t poisson_count;     /* samples before the exact count */
    int passes;               /* Poisson passes run over the input */
    int prune_passes;         /* passes pruning an overshooting pass */
    int exact_sweeps;
    size_t open_cells;        /* samples left in place for an open Voronoi cell */
    size_t pulled_to_surface; /* samples pulled back towards the input (smooth.c) */
    size_t sharp_points;      /* input points labelled sharp */
    wpd_timings time;
} wpd_result;

/* Resamples block b to target (>= 1) samples. On success fills res (free
 * with wpd_result_free) and returns 0; when b->n <= target every point is
 * returned unchanged. Returns -1 with err set on bad arguments (WPD_E_USAGE)
 * or when out of memory (WPD_E_MEMORY); res is then empty. */
int wpd_run_block(const wpd_block *b, size_t target, const wpd_params *p,
                  wpd_result *res, wpd_error *err);

/* Frees a result's arrays and zeroes it. */
void wpd_result_free(wpd_result *res);

#endif
