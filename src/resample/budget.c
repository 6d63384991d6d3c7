/* budget.c - the cost model of budget.h. */
#include "resample/budget.h"

double wpd_budget_sample_fraction(uint64_t target, uint64_t points)
{
    double f = points ? 1.3 * (double)target / (double)points : 1;
    return f < 1 ? f : 1;
}

size_t wpd_budget_tile_point_bytes(double sample_fraction, int sharp)
{
    /* A point a tile reads (its own and its halo's): coordinates, index and
     * halo flag (33) plus what the Poisson pass adds (candidate and kept
     * lists 8, grid copy and slot ids 28, priority, band, state and order
     * 14, cells ~8): 128 whatever n. Smoothing holds the tile's points in
     * its surface grid and its samples with their share of the neighbours'
     * context, neighbour lists, cell and move state: 74 + 422 f a point,
     * fitted to the smoothing peaks of the 100 M synthetic city to 10 % and
     * 50 % (peak RSS over the points read by two tiles in flight: 106 and
     * 286 bytes, at 0.82 of the model like the Poisson peak at 1 %), and
     * more than a sweep of the exact count needs (its cost fields 17 a
     * sample, as a candidate ~90 with its border and view). The larger of
     * the two makes the peak nearly flat in n: about 220 MB under --mem
     * 512M on 2 threads from 1 % to 50 %, where 128 + 360 f gave 234, 185
     * and 216 MB. Each sample's memo of the input around it (48 bytes,
     * smooth_surface.h) came later and fits in that margin: 37 f a point,
     * NC 7 x 7 to 50 % peaking at 287 MB against 270 without it. So do the
     * exact count's nearest samples for smoothing (resample/hints.h): 8
     * bytes a point in the sweep (the query's answer and the hint), 6 to 8
     * while smoothing reads them in and 4 through the tile's smoothing. */
    double smoothing = 74 + 422 * sample_fraction;
    /* --sharp: the labeller's grid over the view (coordinates and slot ids
     * 28, cells ~4), the labels (1) and the crease test's verdicts (1),
     * held through the Poisson pass. */
    double poisson = sharp ? 128 + 34 : 128;
    return smoothing > poisson ? (size_t)smoothing : (size_t)poisson;
}

size_t wpd_budget_min(uint64_t target, uint64_t points, int sharp)
{
    return WPD_BUDGET_FIXED_BYTES + WPD_BUDGET_SPILL_BUFFERS / 4 +
           (size_t)WPD_TILES_IN_FLIGHT * WPD_BUDGET_MIN_TILE_POINTS *
               wpd_budget_tile_point_bytes(wpd_budget_sample_fraction(target, points), sharp);
}

size_t wpd_budget_in_memory_bytes(uint64_t n, uint32_t record_size, uint64_t target, int sharp,
                                  int smooth)
{
    double f = smooth ? wpd_budget_sample_fraction(target, n) : 0;
    size_t point = wpd_budget_tile_point_bytes(f, sharp);
    return (size_t)n * (record_size + 12 + point) + ((size_t)32 << 20);
}

uint64_t wpd_budget_max_tile_points(size_t mem, uint64_t target, uint64_t points, int sharp)
{
    size_t fixed = WPD_BUDGET_FIXED_BYTES + WPD_BUDGET_SPILL_BUFFERS;
    size_t left = mem > fixed ? mem - fixed : 0;
    size_t per = wpd_budget_tile_point_bytes(wpd_budget_sample_fraction(target, points), sharp);
    uint64_t m = left / ((size_t)WPD_TILES_IN_FLIGHT * per);
    return m < WPD_BUDGET_MIN_TILE_POINTS ? WPD_BUDGET_MIN_TILE_POINTS : m;
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
