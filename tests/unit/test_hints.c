/* Unit tests: the exact count's nearest samples handed to smoothing through
 * tiles (resample/hints.h): which points keep a hint, and how the store's
 * deletions renumber them. */
#include <stdlib.h>
#include <string.h>

#include "core/grid.h"
#include "method/eliminate.h"
#include "method/smooth.h"
#include "resample/hints.h"
#include "resample/run.h"
#include "harness.h"

#define NO WPD_SMOOTH_NO_NEAREST

/* One tile, box [0, 100]^3, radius 1, its hints open in a private
 * directory under the tests' own (removed by wpd_hints_close). */
typedef struct hint_run {
    wpd_run run;
    wpd_resample_options opt;
    wpd_tile tile;
} hint_run;

static int open_one_tile(hint_run *h, wpd_error *err)
{
    memset(h, 0, sizeof *h);
    h->opt.tmpdir = test_tmp_dir();
    for (int a = 0; a < 3; a++)
        h->tile.box_hi[a] = 100;
    h->run.opt = &h->opt;
    h->run.plan.ntiles = 1;
    h->run.plan.tiles = &h->tile;
    h->run.radius = 1;
    return wpd_hints_open(&h->run, err);
}

/* Four own samples in a row and a point beside each, plus one beside the
 * first but 0.5 from the box's face: nearer the face than its distance to
 * the sample plus the 1 r a neighbour's sample may wander in, so it keeps
 * no hint. Then the hints by the points' order, as smoothing takes them
 * with a store of `samples` (a grid over the points gives the order). */
enum { SAMPLES = 4, POINTS = 5 };
static const double sample_xyz[3 * SAMPLES] = {20, 20, 20, 40, 20, 20, 60, 20, 20, 80, 20, 20};
static const double point_xyz[3 * POINTS] = {21, 20, 20, 41, 20, 20, 61, 20, 20,
                                             81, 20, 20, 0.5, 20, 20};

static int keep_row(hint_run *h, wpd_error *err)
{
    uint32_t store_of[SAMPLES] = {0, 1, 2, 3}, near[POINTS] = {0, 1, 2, 3, 0};
    wpd_hints_view v = {sample_xyz, store_of, SAMPLES};
    return wpd_hints_keep(&h->run, 0, point_xyz, near, POINTS, &v, err);
}

static int taken(hint_run *h, size_t samples, uint32_t by_point[POINTS], wpd_error *err)
{
    wpd_grid g = {0};
    uint32_t *by_slot = NULL;
    int rc = wpd_grid_build(&g, point_xyz, NULL, POINTS, 5, 1, err);
    if (rc == 0)
        rc = wpd_hints_take(&h->run, 0, &g, POINTS, samples, &by_slot, err);
    for (size_t s = 0; rc == 0 && s < POINTS; s++)
        by_point[g.id[s]] = by_slot ? by_slot[s] : 0xdead;
    free(by_slot);
    wpd_grid_free(&g);
    return rc;
}

TEST(hints_kept_where_the_cover_would_find_the_same_sample)
{
    hint_run h;
    wpd_error err;
    CHECK(open_one_tile(&h, &err) == 0);
    CHECK(keep_row(&h, &err) == 0);
    uint32_t got[POINTS];
    CHECK(taken(&h, SAMPLES, got, &err) == 0);
    uint32_t want[POINTS] = {0, 1, 2, 3, NO};
    CHECK(memcmp(got, want, sizeof want) == 0);
    /* A hint past a smaller store is dropped, not read as a sample. */
    CHECK(taken(&h, 2, got, &err) == 0);
    uint32_t cut[POINTS] = {0, 1, NO, NO, NO};
    CHECK(memcmp(got, cut, sizeof cut) == 0);
    wpd_hints_close(&h.run);
}

TEST(hints_follow_two_deletions_without_a_keep_between)
{
    hint_run h;
    wpd_error err;
    CHECK(open_one_tile(&h, &err) == 0);
    CHECK(keep_row(&h, &err) == 0);
    /* Sample 1 deleted (2 and 3 move down), then the new sample 0 (the
     * first): the map must compose the two, not keep the last. */
    uint32_t first[SAMPLES] = {0, NO, 1, 2}, second[SAMPLES - 1] = {NO, 0, 1};
    CHECK(wpd_hints_renumber(&h.run, 0, first, SAMPLES, &err) == 0);
    uint32_t got[POINTS];
    CHECK(taken(&h, SAMPLES - 1, got, &err) == 0);
    uint32_t once[POINTS] = {0, NO, 1, 2, NO};
    CHECK(memcmp(got, once, sizeof once) == 0);
    CHECK(wpd_hints_renumber(&h.run, 0, second, SAMPLES - 1, &err) == 0);
    CHECK(taken(&h, SAMPLES - 2, got, &err) == 0);
    uint32_t twice[POINTS] = {NO, NO, 0, 1, NO};
    CHECK(memcmp(got, twice, sizeof twice) == 0);
    /* A keep starts a new numbering: the old map no longer applies. */
    CHECK(keep_row(&h, &err) == 0);
    CHECK(taken(&h, SAMPLES, got, &err) == 0);
    uint32_t fresh[POINTS] = {0, 1, 2, 3, NO};
    CHECK(memcmp(got, fresh, sizeof fresh) == 0);
    /* Forgotten hints: every point is searched for. */
    CHECK(wpd_hints_forget(&h.run, 0, &err) == 0);
    uint32_t *none = (uint32_t *)1;
    wpd_grid g = {0};
    CHECK(wpd_grid_build(&g, point_xyz, NULL, POINTS, 5, 1, &err) == 0);
    CHECK(wpd_hints_take(&h.run, 0, &g, POINTS, SAMPLES, &none, &err) == 0 && none == NULL);
    wpd_grid_free(&g);
    wpd_hints_close(&h.run);
}
