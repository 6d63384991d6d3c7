/* test_eliminate.c - the coverage-aware exact count (method/eliminate.h):
 * costs as the definition reads, one sweep's deletions apart, the result
 * independent of how the input is handed in, and no holes. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/hash.h"
#include "harness.h"
#include "method/eliminate.h"
#include "method/poisson.h"

static double unit(uint64_t *state)
{
    *state = wpd_mix64(*state + 0x9e3779b97f4a7c15ULL);
    return (double)(*state >> 11) * 0x1p-53;
}

/* n points on a gently curved 30 x 20 sheet, with gid = index. */
static double *sheet(size_t n, uint64_t seed, uint64_t **gid)
{
    double *xyz = malloc(3 * n * sizeof *xyz);
    *gid = malloc(n * sizeof **gid);
    uint64_t st = seed;
    for (size_t i = 0; i < n; i++) {
        double x = 30 * unit(&st), y = 20 * unit(&st);
        xyz[3 * i] = x, xyz[3 * i + 1] = y, xyz[3 * i + 2] = 0.5 * sin(x / 5);
        (*gid)[i] = i;
    }
    return xyz;
}

static double dist2(const double *a, const double *b)
{
    double dx = a[0] - b[0], dy = a[1] - b[1], dz = a[2] - b[2];
    return dx * dx + dy * dy + dz * dz;
}

/* The samples of a maximal Poisson pass at radius r, as coordinates. */
static double *poisson_samples(const double *xyz, const uint64_t *gid, size_t n, double r,
                               size_t *m)
{
    uint32_t *kept = malloc(n * sizeof *kept);
    wpd_error err = {0};
    wpd_poisson_input in = {xyz, gid, NULL, NULL, n, NULL, 0, r, 7, 1};
    long k = wpd_poisson_pass(&in, kept, &err);
    *m = k > 0 ? (size_t)k : 0;
    double *s = malloc((*m ? *m : 1) * 3 * sizeof *s);
    for (size_t i = 0; i < *m; i++)
        memcpy(s + 3 * i, xyz + 3 * (size_t)kept[i], 3 * sizeof *s);
    free(kept);
    return s;
}

/* Largest distance from an input point to its nearest live sample. */
static double coverage(const double *xyz, size_t n, const double *s, const uint8_t *alive,
                       size_t m)
{
    double worst = 0;
    for (size_t i = 0; i < n; i++) {
        double best = INFINITY;
        for (size_t j = 0; j < m; j++)
            if (alive[j] && dist2(xyz + 3 * i, s + 3 * j) < best)
                best = dist2(xyz + 3 * i, s + 3 * j);
        worst = fmax(worst, best);
    }
    return sqrt(worst);
}

/* Runs the elimination to target, handing the input in as `blocks` chunks
 * in reverse order on `threads` threads. Returns the live flags. */
static uint8_t *eliminate(const double *s, size_t m, const double *xyz, size_t n, size_t target,
                          double r, int blocks, int threads, int *sweeps)
{
    wpd_eliminate e;
    wpd_error err = {0};
    uint8_t *alive = NULL;
    if (wpd_eliminate_init(&e, s, NULL, m, r, 0, threads, &err))
        return NULL;
    *sweeps = 0;
    while (e.live > target) {
        if (wpd_eliminate_begin(&e, &err))
            goto done;
        for (int b = blocks - 1; b >= 0; b--) {
            size_t lo = n * (size_t)b / (size_t)blocks, hi = n * (size_t)(b + 1) / (size_t)blocks;
            wpd_eliminate_add_points(&e, xyz + 3 * lo, NULL, hi - lo, threads, NULL);
        }
        if (wpd_eliminate_sweep(&e, target, &err) <= 0)
            goto done;
        ++*sweeps;
    }
    alive = malloc(m);
    memcpy(alive, e.alive, m);
done:
    wpd_eliminate_free(&e);
    return alive;
}

/* Input points beyond the samples' box (outliers) are handed in too. */
/* The costs by brute force: nearest and second-nearest sample of every
 * point by (squared distance, index). */
static double *costs_by_brute_force(const double *xyz, size_t n, const double *s, size_t m)
{
    double *want = calloc(m, sizeof *want);
    for (size_t i = 0; i < n; i++) {
        size_t a = SIZE_MAX, b = SIZE_MAX;
        double da = INFINITY, db = INFINITY;
        for (size_t j = 0; j < m; j++) {
            double d = dist2(xyz + 3 * i, s + 3 * j);
            if (d < da) {
                b = a, db = da, a = j, da = d;
            } else if (d < db) {
                b = j, db = d;
            }
        }
        if (b != SIZE_MAX && db > want[a])
            want[a] = db;
    }
    return want;
}

TEST(eliminate_costs_are_the_holes_the_definition_gives)
{
    uint64_t *gid;
    size_t n = 4000, m;
    double *xyz = sheet(n, 3, &gid);
    double *s = poisson_samples(xyz, gid, n, 1.2, &m);
    for (size_t i = 0; i < 40; i++) { /* moved after the pass: far from every sample */
        xyz[3 * i] = -10 + (double)i;
        xyz[3 * i + 2] = i % 2 ? 6 : -6;
    }
    wpd_eliminate e;
    wpd_error err = {0};
    CHECK(wpd_eliminate_init(&e, s, NULL, m, 1.2, 0, 2, &err) == 0);
    CHECK(wpd_eliminate_begin(&e, &err) == 0);
    wpd_eliminate_add_points(&e, xyz, NULL, n, 2, NULL);
    double *want = costs_by_brute_force(xyz, n, s, m);
    size_t wrong = 0;
    for (size_t j = 0; j < m; j++) {
        double got;
        memcpy(&got, &e.cost[j], sizeof got);
        wrong += got != want[j];
    }
    CHECK_MSG(wrong == 0, "%zu of %zu costs differ", wrong, m);
    wpd_eliminate_free(&e);
    free(want), free(s), free(xyz), free(gid);
}

/* A radius far below the samples' spacing (n near the input's size, where
 * the input is sparser than r): the grid's cells grow past 1.5 r (else a
 * search crosses thousands of empty cells), and the costs and the nearest
 * live samples are still exactly the definition's. */
TEST(eliminate_is_exact_when_samples_stand_far_apart_for_r)
{
    uint64_t *gid;
    size_t n = 4000, m;
    double *xyz = sheet(n, 5, &gid);
    double *s = poisson_samples(xyz, gid, n, 1.2, &m);
    double r = 0.02, reach = 8;
    wpd_eliminate e;
    wpd_error err = {0};
    CHECK(wpd_eliminate_init(&e, s, NULL, m, r, reach, 2, &err) == 0);
    CHECK(wpd_eliminate_begin(&e, &err) == 0);
    CHECK_MSG(e.grid.cell > 8 * 1.5 * r, "cell %g for r %g", e.grid.cell, r);
    wpd_eliminate_add_points(&e, xyz, NULL, n, 2, NULL);
    double *want = costs_by_brute_force(xyz, n, s, m);
    size_t wrong = 0, wrong_nearest = 0;
    for (size_t j = 0; j < m; j++) {
        double got, best = INFINITY;
        memcpy(&got, &e.cost[j], sizeof got);
        wrong += got != fmin(want[j], reach * reach);
        for (size_t k = 0; k < m; k++)
            if (k != j)
                best = fmin(best, dist2(s + 3 * j, s + 3 * k));
        wrong_nearest += wpd_eliminate_nearest(&e, (uint32_t)j) != fmin(sqrt(best), reach);
    }
    CHECK_MSG(wrong == 0 && wrong_nearest == 0, "%zu costs and %zu nearest of %zu differ",
              wrong, wrong_nearest, m);
    wpd_eliminate_free(&e);
    free(want), free(s), free(xyz), free(gid);
}

/* Samples on a lattice of step 1 at a large offset (exact ties everywhere,
 * coordinates whose float rounding is coarse), points at lattice nodes,
 * midpoints and cell centres (equidistant from 2, 4 or 8 samples) and at
 * random, some in a hole whose nearest samples lie beyond the cells
 * gathered around them: more points than one query block, so the float
 * distances, the blocks and the fall-back search must still give the exact
 * costs, ties broken by index. */
TEST(eliminate_costs_are_exact_with_ties_and_many_blocks)
{
    size_t side = 24, m = 0, n = 100000;
    double *s = malloc(3 * side * side * 2 * sizeof *s), *xyz = malloc(3 * n * sizeof *xyz);
    double off = 4.0e6;
    for (size_t j = 0; j < side * side * 2; j++) {
        size_t x = j % side, y = j / side % side;
        if (x >= 5 && x < 13 && y >= 5 && y < 13) /* a hole: nearest samples beyond the */
            continue;                             /* cells gathered around a point */
        s[3 * m] = off + (double)x;
        s[3 * m + 1] = off + (double)y;
        s[3 * m++ + 2] = (double)(j / (side * side));
    }
    uint64_t st = 17;
    for (size_t i = 0; i < n; i++) {
        double h = i % 4 == 3 ? unit(&st) : 0.5 * (double)(i % 3); /* 0, .5, 1 or random */
        xyz[3 * i] = off + (double)(i % 23) + h;
        xyz[3 * i + 1] = off + (double)(i / 23 % 23) + (i % 5 == 0 ? 0.5 : h);
        xyz[3 * i + 2] = i % 7 == 0 ? 0.5 : (double)(i % 2);
    }
    double *want = costs_by_brute_force(xyz, n, s, m);
    for (int threads = 1; threads <= 2; threads++) {
        wpd_eliminate e;
        wpd_error err = {0};
        CHECK(wpd_eliminate_init(&e, s, NULL, m, 1.0, 0, threads, &err) == 0);
        CHECK(wpd_eliminate_begin(&e, &err) == 0);
        wpd_eliminate_add_points(&e, xyz, NULL, n, threads, NULL);
        size_t wrong = 0;
        for (size_t j = 0; j < m; j++) {
            double got;
            memcpy(&got, &e.cost[j], sizeof got);
            wrong += got != want[j];
        }
        CHECK_MSG(wrong == 0, "%zu of %zu costs differ (%d threads)", wrong, m, threads);
        wpd_eliminate_free(&e);
    }
    free(want), free(s), free(xyz);
}

TEST(eliminate_deletions_of_one_sweep_stay_apart)
{
    uint64_t *gid;
    size_t n = 4000, m;
    double *xyz = sheet(n, 5, &gid);
    double *s = poisson_samples(xyz, gid, n, 1.0, &m);
    wpd_eliminate e;
    wpd_error err = {0};
    CHECK(wpd_eliminate_init(&e, s, NULL, m, 1.0, 0, 1, &err) == 0);
    CHECK(wpd_eliminate_begin(&e, &err) == 0);
    wpd_eliminate_add_points(&e, xyz, NULL, n, 1, NULL);
    uint64_t *cost = malloc(m * sizeof *cost);
    memcpy(cost, e.cost, m * sizeof *cost);
    long del = wpd_eliminate_sweep(&e, m / 2, &err);
    CHECK_MSG(del > 0 && e.live == m - (size_t)del, "deleted %ld of %zu", del, m);
    size_t bad = 0;
    for (size_t a = 0; a < m; a++)
        for (size_t b = a + 1; b < m; b++) {
            if (e.alive[a] || e.alive[b])
                continue;
            double ca, cb;
            memcpy(&ca, &cost[a], sizeof ca), memcpy(&cb, &cost[b], sizeof cb);
            bad += dist2(s + 3 * a, s + 3 * b) <= 4 * fmax(ca, cb);
        }
    CHECK_MSG(bad == 0, "%zu pairs deleted together within twice their cost", bad);
    wpd_eliminate_free(&e);
    free(cost), free(s), free(xyz), free(gid);
}

/* The nearest live sample of every live sample at once is the one-by-one
 * search's, bit for bit: after a sweep (a live subset), with the reach
 * cutting some answers short and without, on 1 and 2 threads. */
TEST(eliminate_nearest_all_is_each_samples_nearest)
{
    uint64_t *gid;
    size_t n = 4000, m;
    double *xyz = sheet(n, 8, &gid);
    double *s = poisson_samples(xyz, gid, n, 0.7, &m);
    double reaches[2] = {0, 1.0};
    for (int r = 0; r < 2; r++)
        for (int threads = 1; threads <= 2; threads++) {
            wpd_eliminate e;
            wpd_error err = {0};
            CHECK(wpd_eliminate_init(&e, s, NULL, m, 0.7, reaches[r], threads, &err) == 0);
            CHECK(wpd_eliminate_begin(&e, &err) == 0);
            wpd_eliminate_add_points(&e, xyz, NULL, n, threads, NULL);
            CHECK(wpd_eliminate_sweep(&e, m / 2, &err) > 0);
            CHECK(wpd_eliminate_begin(&e, &err) == 0);
            double *nn = malloc(m * sizeof *nn);
            for (size_t i = 0; i < m; i++)
                nn[i] = -1;
            wpd_eliminate_nearest_all(&e, nn);
            size_t differ = 0, capped = 0, dead = 0;
            for (size_t i = 0; i < m; i++) {
                if (!e.alive[i]) {
                    dead += nn[i] != -1;
                    continue;
                }
                differ += nn[i] != wpd_eliminate_nearest(&e, (uint32_t)i);
                capped += nn[i] == e.reach;
            }
            CHECK_MSG(differ == 0 && dead == 0, "reach %g, %d threads: %zu differ, %zu dead "
                      "samples written", reaches[r], threads, differ, dead);
            if (r == 1)
                CHECK_MSG(capped > 0, "no answer cut short by the reach: the test tests less");
            free(nn);
            wpd_eliminate_free(&e);
        }
    free(s), free(xyz), free(gid);
}

TEST(eliminate_result_does_not_depend_on_blocks_or_threads)
{
    uint64_t *gid;
    size_t n = 6000, m;
    double *xyz = sheet(n, 9, &gid);
    double *s = poisson_samples(xyz, gid, n, 0.9, &m);
    size_t target = m * 3 / 4;
    int sw1, sw2;
    uint8_t *a = eliminate(s, m, xyz, n, target, 0.9, 1, 1, &sw1);
    uint8_t *b = eliminate(s, m, xyz, n, target, 0.9, 7, 2, &sw2);
    CHECK(a && b);
    size_t live = 0;
    for (size_t j = 0; a && j < m; j++)
        live += a[j];
    CHECK_MSG(live == target, "%zu live, target %zu", live, target);
    CHECK(a && b && !memcmp(a, b, m) && sw1 == sw2);
    free(a), free(b), free(s), free(xyz), free(gid);
}

/* 5 % fewer samples than a maximal pass: the holes stay near r, where as
 * many deleted at random open holes of up to 2 r. */
TEST(eliminate_opens_no_holes)
{
    uint64_t *gid;
    size_t n = 8000, m;
    double *xyz = sheet(n, 11, &gid);
    double r = 0.8;
    double *s = poisson_samples(xyz, gid, n, r, &m);
    size_t target = m - m / 20;
    int sweeps;
    uint8_t *alive = eliminate(s, m, xyz, n, target, r, 3, 2, &sweeps);
    CHECK(alive != NULL);
    uint8_t *all = malloc(m), *random = malloc(m);
    memset(all, 1, m);
    memset(random, 1, m);
    uint64_t st = 1;
    for (size_t k = 0; k < m - target;) {
        size_t j = (size_t)(unit(&st) * (double)m);
        if (random[j])
            random[j] = 0, k++;
    }
    double before = coverage(xyz, n, s, all, m), after = coverage(xyz, n, s, alive, m),
           at_random = coverage(xyz, n, s, random, m);
    CHECK_MSG(before <= r && after <= 1.1 * r && at_random > 1.3 * r,
              "coverage %.3f -> %.3f (random deletions %.3f), r %.3f, %d sweeps", before, after,
              at_random, r, sweeps);
    free(alive), free(all), free(random), free(s), free(xyz), free(gid);
}

/* The sample strictly nearest to p among s[0..m) where alive (NULL: all),
 * or WPD_ELIMINATE_NO_NEAREST on a tie or without one. */
static uint32_t strictly_nearest(const double *p, const double *s, const uint8_t *alive,
                                 size_t m)
{
    double best = INFINITY, second = INFINITY;
    uint32_t at = WPD_ELIMINATE_NO_NEAREST;
    for (size_t j = 0; j < m; j++) {
        if (alive && !alive[j])
            continue;
        double d = dist2(p, s + 3 * j);
        if (d < best)
            second = best, best = d, at = (uint32_t)j;
        else if (d < second)
            second = d;
    }
    return best < second ? at : WPD_ELIMINATE_NO_NEAREST;
}

/* Points and samples on integer lattices, so that many points lie exactly
 * as far from two samples: the strictly nearest sample of each point, and
 * none on a tie, before and after a sweep. */
TEST(eliminate_names_each_points_strictly_nearest_sample)
{
    size_t n = 0, m = 0;
    double *xyz = malloc(3 * 3600 * sizeof *xyz), *s = malloc(3 * 400 * sizeof *s);
    uint64_t st = 3;
    for (int i = 0; i < 60; i++)
        for (int j = 0; j < 60; j++, n++)
            xyz[3 * n] = i, xyz[3 * n + 1] = j, xyz[3 * n + 2] = (i + j) % 2;
    for (int i = 0; i < 20; i++)
        for (int j = 0; j < 20; j++, m++) /* 3 apart, some moved by one */
            s[3 * m] = 3 * i + (unit(&st) < 0.3), s[3 * m + 1] = 3 * j, s[3 * m + 2] = 0;
    uint32_t *got = malloc(n * sizeof *got);
    wpd_eliminate e;
    wpd_error err = {0};
    CHECK(wpd_eliminate_init(&e, s, NULL, m, 3, 0, 2, &err) == 0);
    for (int sweep = 0; sweep < 2; sweep++) {
        CHECK(wpd_eliminate_begin(&e, &err) == 0);
        wpd_eliminate_add_points(&e, xyz, NULL, n, 2, got);
        size_t wrong = 0, ties = 0;
        for (size_t i = 0; i < n; i++) {
            uint32_t want = strictly_nearest(xyz + 3 * i, s, e.alive, m);
            wrong += got[i] != want;
            ties += want == WPD_ELIMINATE_NO_NEAREST;
        }
        CHECK_MSG(wrong == 0 && ties > 100, "sweep %d: %zu of %zu wrong, %zu ties", sweep,
                  wrong, n, ties);
        CHECK(wpd_eliminate_sweep(&e, m * 3 / 4, &err) > 0);
    }
    wpd_eliminate_free(&e);
    free(got), free(s), free(xyz);
}

/* The same sheet at scales far from the frame's usual ones: the queries'
 * float distances are in cell units (core/grid_block.h), so they neither
 * underflow (in the cloud's units, cells of 1e-22 gave denormal squares
 * that rounded out of order: 12 of 256 costs wrong) nor overflow (cells
 * past some 10^18: infinite squares, NaNs with a tag), and the costs and
 * nearest samples are still the definition's. */
TEST(eliminate_is_exact_at_any_scale)
{
    const double scales[] = {1e-22, 1e-15, 1e19, 1e21};
    for (size_t t = 0; t < sizeof scales / sizeof *scales; t++) {
        uint64_t *gid;
        size_t n = 4000, m;
        double *xyz = sheet(n, 7, &gid);
        double *s = poisson_samples(xyz, gid, n, 1.2, &m);
        for (size_t i = 0; i < 3 * n; i++)
            xyz[i] *= scales[t];
        for (size_t j = 0; j < 3 * m; j++)
            s[j] *= scales[t];
        uint32_t *got = malloc(n * sizeof *got);
        wpd_eliminate e;
        wpd_error err = {0};
        CHECK(wpd_eliminate_init(&e, s, NULL, m, 1.2 * scales[t], 0, 2, &err) == 0);
        CHECK(wpd_eliminate_begin(&e, &err) == 0);
        wpd_eliminate_add_points(&e, xyz, NULL, n, 2, got);
        double *want = costs_by_brute_force(xyz, n, s, m);
        size_t wrong = 0, wrong_nearest = 0;
        for (size_t j = 0; j < m; j++) {
            double cost;
            memcpy(&cost, &e.cost[j], sizeof cost);
            wrong += cost != want[j];
        }
        for (size_t i = 0; i < n; i++)
            wrong_nearest += got[i] != strictly_nearest(xyz + 3 * i, s, NULL, m);
        CHECK_MSG(wrong == 0 && wrong_nearest == 0, "scale %g: %zu of %zu costs, %zu of %zu "
                  "nearest samples differ", scales[t], wrong, m, wrong_nearest, n);
        wpd_eliminate_free(&e);
        free(want), free(got), free(s), free(xyz), free(gid);
    }
}
