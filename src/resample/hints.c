/* hints.c - the exact count's nearest samples for smoothing through tiles
 * (hints.h). */
#include "resample/hints.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/testhook.h"
#include "method/eliminate.h"
#include "method/params.h"
#include "method/smooth.h"
#include "spill/blobs.h"

_Static_assert(WPD_ELIMINATE_NO_NEAREST == WPD_SMOOTH_NO_NEAREST, "one mark for no hint");

int wpd_hints_wanted(const wpd_run *run)
{
    return run->files && !run->res->in_memory && wpd_params_smooths(run->p) &&
           !wpd_hints_off_for_test();
}

int wpd_hints_off_for_test(void)
{
    return wpd_test_number("WPD_TEST_NO_HINTS", 0, 1) == 1;
}

int wpd_hints_checked_for_test(void)
{
    return wpd_test_number("WPD_TEST_CHECK_HINTS", 0, 1) == 1;
}

/* Two blobs a tile: the hints by the store's numbering when they were
 * kept, and the map from that numbering to the store's now (empty: the
 * same), which the deletions update - a few bytes a sample instead of
 * rewriting four a point. */
static size_t hints_key(int t)
{
    return 2 * (size_t)t;
}

static size_t map_key(int t)
{
    return 2 * (size_t)t + 1;
}

int wpd_hints_open(wpd_run *run, wpd_error *err)
{
    const char *dir = run->opt->tmpdir ? run->opt->tmpdir : ".";
    return wpd_blobs_open(dir, 2 * (size_t)run->plan.ntiles, &run->work_files, &run->hints, err);
}

void wpd_hints_close(wpd_run *run)
{
    wpd_blobs_close(run->hints);
    run->hints = NULL;
}

/* How far x lies inside the box [lo, hi] (<= 0 outside). Comparisons,
 * not fmin: that is a call at -O2, here once per input point. */
static double depth_in(const double x[3], const double lo[3], const double hi[3])
{
    double d = INFINITY;
    for (int a = 0; a < 3; a++) {
        double below = x[a] - lo[a], above = hi[a] - x[a];
        d = below < d ? below : d;
        d = above < d ? above : d;
    }
    return d;
}

/* The hints go to their file in 16 bits each where the tile's samples
 * allow (UINT16_MAX for none): 2 bytes an input point and its halo copies
 * on disk beside the spill's 7 (NC 3 x 3 to 1 %: 44 against 151 MB).
 * zstd at its fastest level took them only to 34 MB, for about a quarter
 * of what the hints save smoothing there. Frees hint. */
static int put_packed(wpd_run *run, int t, uint32_t *hint, size_t npts, size_t samples,
                      wpd_error *err)
{
    if (samples >= UINT16_MAX)
        return wpd_blobs_put(run->hints, hints_key(t), hint, npts * sizeof *hint, err);
    uint16_t *narrow = malloc((npts ? npts : 1) * sizeof *narrow);
    for (size_t i = 0; narrow && i < npts; i++)
        narrow[i] = hint[i] == WPD_SMOOTH_NO_NEAREST ? UINT16_MAX : (uint16_t)hint[i];
    free(hint);
    if (!narrow)
        return wpd_fail(err, WPD_E_MEMORY, "out of memory for the nearest samples of tile %d", t);
    return wpd_blobs_put(run->hints, hints_key(t), narrow, npts * sizeof *narrow, err);
}

/* Hint i of those put_packed stored, width bytes each. */
static uint32_t hint_at(const void *data, size_t width, size_t i)
{
    if (width == 4)
        return ((const uint32_t *)data)[i];
    uint16_t h = ((const uint16_t *)data)[i];
    return h == UINT16_MAX ? WPD_SMOOTH_NO_NEAREST : h;
}

int wpd_hints_keep(wpd_run *run, int t, const double *pts, const uint32_t *near, size_t npts,
                   const wpd_hints_view *v, wpd_error *err)
{
    const wpd_tile *tile = &run->plan.tiles[t];
    uint32_t *hint = malloc((npts ? npts : 1) * sizeof *hint);
    if (!hint)
        return wpd_fail(err, WPD_E_MEMORY, "out of memory for the nearest samples of tile %d", t);
    /* A neighbour's sample may end WPD_SMOOTH_WANDER_MAX r into the box.
     * (The outer tiles' boxes reach to infinity on their outer sides.) */
    double wander = WPD_SMOOTH_WANDER_MAX * run->radius;
    for (size_t i = 0; i < npts; i++) {
        uint32_t h = near[i], own = h == WPD_ELIMINATE_NO_NEAREST ? h : v->store_of[h];
        hint[i] = WPD_SMOOTH_NO_NEAREST;
        if (own == WPD_SMOOTH_NO_NEAREST)
            continue;
        /* d + wander < depth, as d^2 < (depth - wander)^2. The factors and
         * the slack keep rounding on the safe side: of d, and of the faces -
         * a point's home tile comes from its cell (floor of x / cell), so a
         * neighbour's sample may lie an ulp of its coordinates inside. */
        const double *x = pts + 3 * i, *s = v->xyz + 3 * (size_t)h;
        double slack = 1e-9 * (fabs(x[0]) + fabs(x[1]) + fabs(x[2]) + wander);
        double room = depth_in(x, tile->box_lo, tile->box_hi) - wander - slack;
        double d2 = (x[0] - s[0]) * (x[0] - s[0]) + (x[1] - s[1]) * (x[1] - s[1]) +
                    (x[2] - s[2]) * (x[2] - s[2]);
        if (room > 0 && d2 * (1 + 1e-8) < room * room * (1 - 1e-8))
            hint[i] = own;
    }
    if (put_packed(run, t, hint, npts, v->own, err))
        return -1;
    return wpd_blobs_put(run->hints, map_key(t), NULL, 0, err); /* the same numbering */
}

int wpd_hints_renumber(wpd_run *run, int t, const uint32_t *moved, size_t n, wpd_error *err)
{
    void *data;
    size_t bytes;
    if (wpd_blobs_get(run->hints, map_key(t), &data, &bytes, err))
        return -1;
    uint32_t *map = data;
    size_t m = bytes / sizeof *map;
    if (m == 0) { /* the same numbering so far: the map is moved itself */
        free(data);
        map = malloc((n ? n : 1) * sizeof *map);
        if (!map)
            return wpd_fail(err, WPD_E_MEMORY, "out of memory in tile %d", t);
        memcpy(map, moved, n * sizeof *map);
        m = n;
    } else {
        for (size_t i = 0; i < m; i++)
            if (map[i] != WPD_SMOOTH_NO_NEAREST)
                map[i] = moved[map[i]];
    }
    return wpd_blobs_put(run->hints, map_key(t), map, m * sizeof *map, err);
}

int wpd_hints_forget(wpd_run *run, int t, wpd_error *err)
{
    return wpd_blobs_put(run->hints, hints_key(t), NULL, 0, err);
}

int wpd_hints_take(const wpd_run *run, int t, const wpd_grid *surface, size_t npts,
                   size_t samples, uint32_t **out, wpd_error *err)
{
    *out = NULL;
    if (!run->hints)
        return 0;
    void *data, *mapped;
    size_t bytes, mbytes;
    if (wpd_blobs_get(run->hints, hints_key(t), &data, &bytes, err))
        return -1;
    if (wpd_blobs_get(run->hints, map_key(t), &mapped, &mbytes, err)) {
        free(data);
        return -1;
    }
    size_t width = npts && (bytes == 2 * npts || bytes == 4 * npts) ? bytes / npts : 0;
    const uint32_t *map = mapped;
    size_t m = mbytes / sizeof *map;
    uint32_t *by_slot = width && surface->n == npts ? malloc(npts * sizeof *by_slot) : NULL;
    for (size_t s = 0; by_slot && s < npts; s++) {
        uint32_t h = hint_at(data, width, surface->id[s]);
        if (h != WPD_SMOOTH_NO_NEAREST && m)
            h = h < m ? map[h] : WPD_SMOOTH_NO_NEAREST;
        /* An index past the store would be read as a sample: none instead. */
        by_slot[s] = h < samples ? h : WPD_SMOOTH_NO_NEAREST;
    }
    free(data);
    free(mapped);
    *out = by_slot; /* none, or no memory for them: the cover searches */
    return 0;
}
