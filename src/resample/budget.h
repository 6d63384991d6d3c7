/* budget.h - the whole cost model of a resampling run, in one place
 * (docs/engine.md, Memory).
 *
 * A run is given a memory budget (--mem). Before any work it is split into:
 *   fixed      48 MB: one thread's voxel ladder and batches, the plan, the
 *              runtime (a large target's sampled ladder sets, up to 32 MB
 *              each, come out of the room of the scan's other lanes);
 *   spill      32 MB of write buffers for all tiles together (tiled runs);
 *   samples    nothing over all samples: a tiled run keeps them in
 *              files (the sample store, the exact count's fields, the
 *              result's runs: sample_store.h, exact_internal.h), a tile's only while it is
 *              worked on - counted in its tile's bytes below; the records
 *              pass merges the runs within WPD_RUN_MERGE_BUDGET after the
 *              tiles are freed;
 *   tiles      the rest, for WPD_TILES_IN_FLIGHT tiles at
 *              wpd_budget_tile_point_bytes(f) a point, f the samples a
 *              point may leave (1.3 n / N, at most 1).
 * A cloud held in memory as one tile is costed apart
 * (wpd_budget_in_memory_bytes).
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
};

/* The samples an input point may leave: 1.3 target / points (the first
 * pass may overshoot), at most 1. */
double wpd_budget_sample_fraction(uint64_t target, uint64_t points);

/* Bytes a point of a tile in flight costs: coordinates, index and halo flag
 * (33), the larger of the Poisson scratch and the smoothing surface grid,
 * and for the fraction f of a sample it may leave, what that sample costs
 * while its tile is smoothed (the largest of the phases: held with its
 * share of the neighbours' context and its smoothing state). With sharp
 * (--sharp) the Poisson pass also holds the labeller's grid over the
 * view's points and their labels. Records never enter tiles. */
size_t wpd_budget_tile_point_bytes(double sample_fraction, int sharp);

/* Smallest budget a tiled run to target samples out of points accepts:
 * below it the run is refused before the first read. */
size_t wpd_budget_min(uint64_t target, uint64_t points, int sharp);

/* Budget needed to hold a cloud of n points as one tile in memory (all
 * threads on it) for target samples, smoothed or not: a point costs its
 * record, 12 bytes of the run's own and what a tile's point costs
 * (wpd_budget_tile_point_bytes; without smoothing, at no sample fraction:
 * the Poisson scratch). A fit, like the tile model it leans on: measured
 * on the 2.27 M-point NC Raleigh scan with 38-byte records, 380 MB peak to
 * 100 K (the model 436), 917 MB to 50 % (the model 935: the smoothing
 * state of 1.13 M samples). */
size_t wpd_budget_in_memory_bytes(uint64_t n, uint32_t record_size, uint64_t target, int sharp,
                                  int smooth);

/* Home points a tile may hold so that WPD_TILES_IN_FLIGHT of them fit
 * beside the fixed part and the spill buffers (at least
 * WPD_BUDGET_MIN_TILE_POINTS). */
uint64_t wpd_budget_max_tile_points(size_t mem, uint64_t target, uint64_t points, int sharp);

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
