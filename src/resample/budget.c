/* budget.c - the cost model of budget.h. */
#include "resample/budget.h"

double wpd_budget_sample_fraction(uint64_t target, uint64_t points)
{
    double f = points ? 1.3 * (double)target / (double)points : 1;
    return f < 1 ? f : 1;
}

size_t wpd_budget_tile_point_bytes(double sample_fraction)
{
    /* Coordinates, index and halo flag (33), plus the larger of what the two
     * passes over a tile add: Poisson (candidate and kept lists 8, grid copy
     * and slot ids 28, priority, band, state and order 14, cells ~8) or
     * smoothing (surface grid ~40): 128. A sample: in smoothing itself and
     * its share of the neighbours' context held, with its neighbour lists,
     * cell and move state: measured 340 bytes (NC 2 x 2 to 50 %: peak RSS
     * 206 MB smoothed, 109 MB with --no-smooth, two tiles of 142 K samples
     * in flight), more than a sweep of the exact count needs (its cost
     * fields 17, as a candidate ~90 with its border and view): 360. */
    return 128 + (size_t)(360 * sample_fraction);
}

size_t wpd_budget_min(uint64_t target, uint64_t points)
{
    return WPD_BUDGET_FIXED_BYTES + WPD_BUDGET_SPILL_BUFFERS / 4 +
           (size_t)WPD_TILES_IN_FLIGHT * WPD_BUDGET_MIN_TILE_POINTS *
               wpd_budget_tile_point_bytes(wpd_budget_sample_fraction(target, points));
}

size_t wpd_budget_in_memory_bytes(uint64_t n, uint32_t record_size)
{
    return (size_t)n * (record_size + 140) + ((size_t)32 << 20);
}

uint64_t wpd_budget_max_tile_points(size_t mem, uint64_t target, uint64_t points)
{
    size_t fixed = WPD_BUDGET_FIXED_BYTES + WPD_BUDGET_SPILL_BUFFERS;
    size_t left = mem > fixed ? mem - fixed : 0;
    size_t per = wpd_budget_tile_point_bytes(wpd_budget_sample_fraction(target, points));
    uint64_t m = left / ((size_t)WPD_TILES_IN_FLIGHT * per);
    return m < WPD_BUDGET_MIN_TILE_POINTS ? WPD_BUDGET_MIN_TILE_POINTS : m;
}

size_t wpd_budget_batch_bytes(uint32_t record_size)
{
    return (size_t)WPD_BATCH_POINTS * (record_size + 24);
}

int wpd_threads_within(int threads, size_t room, size_t per_thread)
{
    size_t extra = room / (per_thread ? per_thread : 1);
    return threads <= 1 ? 1 : (size_t)(threads - 1) <= extra ? threads : 1 + (int)extra;
}

int wpd_budget_pass_threads(size_t mem, int threads, size_t in_use, size_t per_thread)
{
    size_t used = WPD_BUDGET_FIXED_BYTES + in_use;
    return wpd_threads_within(threads, mem > used ? mem - used : 0, per_thread);
}

int wpd_budget_tile_workers(int threads, int ntiles)
{
    if (ntiles <= 1)
        return 1;
    return threads < WPD_TILES_IN_FLIGHT ? threads : WPD_TILES_IN_FLIGHT;
}

int wpd_budget_threads_per_tile(int threads, int ntiles)
{
    return ntiles <= 1 ? threads : 1;
}
