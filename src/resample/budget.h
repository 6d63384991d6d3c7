/* budget.h - the whole cost model of a resampling run, in one place
 * (docs/engine.md, Memory).
 *
 * A run is given a memory budget (--mem). Before any work it is split into:
 *   fixed      48 MB: one thread's voxel ladder and batches, the plan, the
 *              runtime;
 *   spill      32 MB of write buffers for all tiles together (tiled runs);
 *   samples    1.3 n x 147 bytes: the samples of a first pass that may
 *              overshoot n, the flat copy and the grid the exact count
 *              works on (not their records: the records pass hands each
 *              to the writer as it reads it; no output array: the samples
 *              leave the run as sorted runs, merged within
 *              WPD_RUN_MERGE_BUDGET while written, after the tiles are
 *              freed);
 *   tiles      the rest, for WPD_TILES_IN_FLIGHT tiles at
 *              wpd_budget_tile_point_bytes() a point.
 * A thread beyond the first in a streaming pass runs only where the budget
 * holds its own working set (wpd_budget_pass_threads), so peak memory does
 * not grow with --threads. Tiles are sized for a constant number in flight,
 * never by the thread count: the tiling, and so the output, must not depend
 * on --threads.
 */
#ifndef WPD_BUDGET_H
#define WPD_BUDGET_H

#include <stddef.h>
#include <stdint.h>

enum {
    WPD_BUDGET_FIXED_BYTES = 48 << 20,
    WPD_BUDGET_SPILL_BUFFERS = 32 << 20,
    WPD_BUDGET_MIN_TILE_POINTS = 20000,
    WPD_TILES_IN_FLIGHT = 4,       /* more threads than this do not speed tiles up */
    WPD_BATCH_POINTS = 65536,      /* points a streaming pass reads at once */
};

/* Bytes a point of a tile in flight costs: coordinates, index and halo flag
 * (33) plus the larger of the Poisson scratch and the smoothing surface
 * grid. Records never enter tiles. */
size_t wpd_budget_tile_point_bytes(void);

/* Bytes per output sample (store, exact-count scratch; no result array:
 * the runs are the store's arrays or files; its record is never held:
 * records.c). */
size_t wpd_budget_sample_bytes(void);

/* Bytes for the samples of a run to target points (1.3 target: the first
 * pass may overshoot). */
size_t wpd_budget_samples_bytes(uint64_t target);

/* Smallest budget a run to target samples accepts: below it the run is
 * refused before the first read. */
size_t wpd_budget_min(uint64_t target);

/* Budget needed to hold a cloud of n points as one tile in memory (all
 * threads on it): measured 380 MB peak for the 2.27 M-point NC Raleigh scan
 * to 100 K with 38-byte records. */
size_t wpd_budget_in_memory_bytes(uint64_t n, uint32_t record_size);

/* Home points a tile may hold so that WPD_TILES_IN_FLIGHT of them fit
 * beside the fixed part, the spill buffers and the samples (at least
 * WPD_BUDGET_MIN_TILE_POINTS). */
uint64_t wpd_budget_max_tile_points(size_t mem, uint64_t target);

/* Bytes of one batch of WPD_BATCH_POINTS points with their records. */
size_t wpd_budget_batch_bytes(uint32_t record_size);

/* min(threads, 1 + room / per_thread), at least 1: each thread beyond the
 * first needs per_thread bytes of its own. */
int wpd_threads_within(int threads, size_t room, size_t per_thread);

/* Threads a streaming pass may run beside in_use bytes held during it,
 * each beyond the first needing per_thread bytes (the first one's are in
 * the fixed part). The passes' results never depend on it. */
int wpd_budget_pass_threads(size_t mem, int threads, size_t in_use, size_t per_thread);

/* Threads working on tiles: one tile each, at most WPD_TILES_IN_FLIGHT;
 * a run with one tile gives it every thread instead (tile_threads). */
int wpd_budget_tile_workers(int threads, int ntiles);
int wpd_budget_threads_per_tile(int threads, int ntiles);

#endif
