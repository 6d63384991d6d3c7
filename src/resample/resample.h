/* resample.h - Weighted Poisson-disk resampling of a cloud to n points: the
 * one driver behind `wpd resample`, for clouds that fit the memory budget
 * and clouds that do not.
 *
 * The data path (docs/architecture.md, docs/engine.md):
 *   scan     one streaming pass (two for inputs without a declared box or
 *            with a wrong one): the frame, finite points per file, occupied
 *            voxels (-> the radius, both estimates), a coarse density grid;
 *   plan     tiles of density-grid cells that fit the budget, their
 *            neighbours and a colouring; a cloud that fits is one tile;
 *   tile     a streaming pass puts every point into its tile and, within
 *            the halo, into its neighbours: zstd spill files, or the one
 *            tile kept in memory;
 *   poisson  colour by colour, tiles of a colour in parallel (one tile: all
 *            threads); counts summed over tiles drive the refinement until a
 *            pass keeps at least n;
 *   exact    the exact count over all samples: coverage-aware elimination,
 *            each sweep reading every tile's input points;
 *   smooth   colour by colour: each tile's samples, its neighbours' samples
 *            as context, its input plus halo as the surface;
 *   merge    each tile's samples, in absolute coordinates, become one
 *            sorted run (the result's samples): memory or files;
 *   records  (wpd_resample_stream_records, after the run) the runs merged
 *            into global-index order, with the samples' records from a
 *            last streaming pass, handed to the writer.
 * Every step is the same code whether the cloud is one tile in memory or
 * many in the spill; the output does not depend on the number of threads.
 */
#ifndef WPD_RESAMPLE_H
#define WPD_RESAMPLE_H

#include <stddef.h>
#include <stdint.h>

#include "common/error.h"
#include "common/progress.h"
#include "io/cloud.h"
#include "par/par.h"
#include "spill/run_merge.h"
#include "spill/runs.h"
#include "spill/spill.h"
#include "method/params.h"

typedef struct wpd_resample_options {
    uint64_t target;          /* n (>= 1) */
    size_t mem_bytes;         /* memory budget */
    const char *tmpdir;       /* directory for the private spill directory */
    int min_tiles;            /* >= 2: tiles (the spill) with at least this many */
    wpd_params params;        /* the method's parameters; threads */
    wpd_progress *progress;   /* phase progress, or NULL */
    const wpd_par *par;       /* the ranks of an MPI run (par/par.h), or NULL: one
                                 process. Every rank runs the same run; the ranks
                                 share the scan's reading (docs/scale-out.md) */
    /* A collection's later night (docs/ingest.md): the radius is given, the
     * samples of earlier nights within reach are fixed, and density wins
     * over the count. Zeros: an ordinary run. */
    double fixed_radius;      /* > 0: one Poisson pass at this radius: no estimate,
                                 no refinement, no copying of a small input */
    double density_factor;    /* > 0: the exact count keeps round(f x the Poisson
                                 pass's samples) (at most all of them), not target */
    const double *fixed_xyz;  /* [3 nfixed] absolute coordinates: samples the run
                                 keeps clear of and counts as present (the Poisson
                                 pass's fixed points, the exact count's coverage and
                                 crowding, smoothing's context) but never writes */
    size_t nfixed;
} wpd_resample_options;

/* Wall time of each phase, seconds. */
typedef struct wpd_resample_timings {
    double bounds, scan, plan, tile, poisson, exact, smooth, merge, total;
} wpd_resample_timings;

/* What a run produced and what it did. */
typedef struct wpd_resample_result {
    size_t count;             /* samples (n, or every point when n >= input) */
    wpd_runs *samples;        /* the samples, one sorted run per tile (global index,
                                 absolute coordinates, sharp label with --sharp):
                                 in memory for a cloud resampled in memory, else in
                                 files of their own (the spill is gone); read them in
                                 global-index order through wpd_run_merge_open */
    uint64_t *file_samples;   /* [nfiles] samples per input file */
    wpd_bounds *file_bounds;  /* [nfiles] the box of each file's samples */
    int labelled;             /* 1: the samples carry sharp labels (--sharp) */
    uint64_t sharp_samples;   /* samples labelled sharp */
    uint32_t record_size;
    int moved;                /* 1: coordinates were smoothed */
    uint64_t input_points;    /* finite input points */
    uint64_t dropped;         /* input points with non-finite coordinates */
    int nfiles;
    uint64_t *file_count;     /* [nfiles] finite points per input file */
    uint64_t nunits;          /* several ranks, inputs that can seek: the units of */
    uint64_t *unit_points;    /* the scan and their finite points (wpd_pass_units),
                                 which split the records pass between the ranks;
                                 else 0, NULL */
    double radius_estimate, radius;
    size_t first_pass_count, poisson_count;
    int passes;               /* Poisson passes over the input */
    int exact_sweeps;         /* sweeps of the exact count, each reading every tile */
    int exact_rounds;         /* rounds of its tiles' decisions, over all sweeps */
    int resolution_rounds;    /* tile rounds re-run for points a tile's view could not
                                 decide (a chain of decisions past the halo) */
    int resolution_tiles;     /* tiles those rounds re-ran */
    size_t open_cells, pulled_to_surface;
    size_t non_surface;       /* samples smoothing kept still: no surface around them */
    size_t isolated;          /* ... kept still: the input there sparser than the samples */
    size_t guarded_moves;     /* smoothing moves shortened or refused to keep the spacing
                                 and the coverage (all iterations; method/smooth_guard.h) */
    size_t cover_hinted;      /* input points (halo copies counted in each tile) whose
                                 nearest sample smoothing's cover took from the exact
                                 count instead of a search (resample/hints.h) */
    uint64_t sharp_points;    /* input points labelled sharp, of those labelled: the
                                 Poisson passes ask only for the labels they need
                                 (every one when n >= the input) */
    uint64_t sharp_labelled;  /* labels computed (through tiles, a halo point's or a
                                 point of a tile run again count each time). This and
                                 sharp_points depend on the threads and the tiling
                                 (which labels the passes ask for); the samples do not */
    int in_memory;            /* 1: one tile held in memory, no spill */
    int tiles, colours;
    uint64_t largest_tile;
    double *tile_box;         /* [6 tiles]: min x y z, max x y z, absolute, outer
                                 faces at the data's bounds */
    wpd_spill_stats spill;    /* zeros in memory */
    uint64_t work_file_bytes; /* the most bytes this process's working files beside the
                                 spill held at once: the exact count's per-tile arrays
                                 and the nearest samples for smoothing (spill/blobs.h,
                                 resample/hints.h); 0 in memory */
    wpd_resample_timings time;
} wpd_resample_result;

/* Whether a run with these options holds the cloud in memory (one tile, all
 * threads on it, no spill) rather than tiling it through the spill. */
int wpd_resample_in_memory(const wpd_cloud *cloud, const wpd_resample_options *opt);

/* Resamples cloud to opt->target points. Returns 0 (res filled; free with
 * wpd_resample_result_free), or -1 with err set: WPD_E_MEMORY when the
 * budget is too small (before any work), WPD_E_IO, WPD_E_INPUT,
 * WPD_E_USAGE. Spill files are removed on every path. */
int wpd_resample_run(wpd_cloud *cloud, const wpd_resample_options *opt,
                     wpd_resample_result *res, wpd_error *err);

void wpd_resample_result_free(wpd_resample_result *res);

/* Takes the next n samples in global-index order (xyz, edge: their
 * coordinates and labels, edge NULL when they have none) with their input
 * records (records: n records of the cloud's record size), all from input
 * file `file`. The arrays are valid during the call. Returns 0, or -1
 * with err set. */
typedef int (*wpd_sample_sink)(void *arg, int file, const double *xyz, const uint8_t *edge,
                               const uint8_t *records, size_t n, wpd_error *err);

/* The records pass: reads cloud once in order (with the filter it has, the
 * one the run had) and hands the samples of `samples` (a merge over a
 * result's runs, WPD_RUN_MERGE_BUDGET bytes) to sink, batch by batch, in
 * global-index order, each with its input record; no record is held beyond
 * one batch, no sample beyond one chunk of the merge. Reading runs on up
 * to `threads` threads where the budget mem_bytes allows. Returns 0, or -1
 * with err set: the sink's failure, a read or run error, WPD_E_INPUT when
 * the inputs no longer hold the samples (they changed while being
 * resampled). */
int wpd_resample_stream_records(wpd_cloud *cloud, wpd_run_merge *samples, size_t mem_bytes,
                                int threads, wpd_progress *progress, wpd_sample_sink sink,
                                void *arg, wpd_error *err);

/* The records pass of one share of the output: the samples first ..
 * first + count - 1 (in global-index order) of `samples`, read from the
 * unit that holds the first of them (unit_points: the finite points of
 * each of the nunits units, wpd_pass_units) until the last is out. The
 * ranks of an MPI run each write their share (docs/scale-out.md). Same
 * contract as wpd_resample_stream_records otherwise; count 0: nothing. */
int wpd_resample_stream_share(wpd_cloud *cloud, wpd_run_merge *samples, uint64_t first,
                              uint64_t count, const uint64_t *unit_points, uint64_t nunits,
                              size_t mem_bytes, int threads, wpd_progress *progress,
                              wpd_sample_sink sink, void *arg, wpd_error *err);

#endif
