/* test_smooth_even.c - the even-spacing steps (method/smooth_even.h): the
 * points a sample may step onto are the best a literal evaluation of its
 * sum ranks, and the steps even the local spacing while keeping what
 * smoothing must keep (input points only, the spacing floor, the cover,
 * any thread count). */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "core/grid.h"
#include "core/hash.h"
#include "core/knn.h"
#include "harness.h"
#include "method/poisson.h"
#include "method/smooth.h"
#include "method/smooth_even.h"
#include "method/smooth_guard.h"

static double unit(uint64_t *state)
{
    *state = wpd_mix64(*state + 0x9e3779b97f4a7c15ULL);
    return (double)(*state >> 11) * 0x1p-53;
}

static double dist(const double *a, const double *b)
{
    return sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
                (a[2] - b[2]) * (a[2] - b[2]));
}

static int by_value(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* Mean of the (up to) 6 smallest of d[0..n). */
static double mean6(double *d, int n)
{
    qsort(d, (size_t)n, sizeof *d, by_value);
    int k = n < WPD_EVEN_K ? n : WPD_EVEN_K;
    double s = 0;
    for (int i = 0; i < k; i++)
        s += d[i];
    return k ? s / k : 0;
}

enum { K = 13, N = 70, NCTX = 10, INPUT = 3000 };

/* A candidate's literal sum, distance and index, ordered by the sum, then
 * the distance. */
typedef struct ranked {
    double e, d;
    int id;
} ranked;

static int by_sum(const void *a, const void *b)
{
    const ranked *x = a, *y = b;
    if (x->e != y->e)
        return (x->e > y->e) - (x->e < y->e);
    return (x->d > y->d) - (x->d < y->d);
}

/* Sample s's spacing with sample o at q: its listed neighbours, o's entry
 * (or o as an extra neighbour, if unlisted) at q. */
static double spacing_with(const double *pos, const uint32_t *nb, const uint8_t *cnt, size_t s,
                           size_t o, const double *q)
{
    double d[K + 1];
    int m = 0, listed = 0;
    for (int j = 0; j < cnt[s]; j++) {
        listed |= nb[s * K + j] == o;
        d[m++] = dist(pos + 3 * s, nb[s * K + j] == o ? q : pos + 3 * (size_t)nb[s * K + j]);
    }
    if (!listed && s != o)
        d[m++] = dist(pos + 3 * s, q);
    return mean6(d, m);
}

TEST(even_candidates_are_the_best_a_literal_sum_ranks)
{
    /* Random samples in a box with context samples beyond them, neighbour
     * lists by brute force, input points around; for every sample the
     * step is checked against every candidate's sum evaluated literally. */
    uint64_t seed = 11;
    int checked = 0, moved = 0, capped = 0, standing = 0;
    for (int trial = 0; trial < 20; trial++) {
        double pos[3 * (N + NCTX)], inp[3 * INPUT], spacing[N];
        wpd_even_nearest nearest[N];
        uint32_t nb[N * K];
        uint8_t cnt[N];
        for (int i = 0; i < 3 * (N + NCTX); i++)
            pos[i] = 4 * unit(&seed);
        for (int i = 0; i < 3 * INPUT; i++)
            inp[i] = 4 * unit(&seed);
        /* In every other trial half the samples stand on input points, as
         * they do before their first move: a point where the sample stands
         * is never ranked (its sum is staying's). */
        for (int i = 0; trial % 2 && i < N / 2; i++)
            memcpy(inp + 3 * (7 * i), pos + 3 * i, 3 * sizeof *inp);
        for (size_t o = 0; o < N; o++) {
            /* The K nearest by insertion (distinct random distances). */
            double best[K];
            cnt[o] = 0;
            for (uint32_t j = 0; j < N + NCTX; j++) {
                if (j == o)
                    continue;
                double d = dist(pos + 3 * o, pos + 3 * j);
                int at = cnt[o] < K ? cnt[o]++ : K;
                if (at == K && d >= best[K - 1])
                    continue;
                if (at == K)
                    at = K - 1;
                for (; at > 0 && best[at - 1] > d; at--) {
                    best[at] = best[at - 1];
                    nb[o * K + at] = nb[o * K + at - 1];
                }
                best[at] = d;
                nb[o * K + at] = j;
            }
        }
        wpd_even_spacings(pos, N, nb, cnt, K, spacing, nearest, 2);
        wpd_grid surface = {0};
        wpd_error err;
        CHECK(wpd_grid_build(&surface, inp, NULL, INPUT, 0.3, 1, &err) == 0);
        double reach = 0.25 + 0.1 * unit(&seed), floor = 0.2 * unit(&seed);
        wpd_even_view v = {pos, N, nb, cnt, K, spacing, nearest};
        for (size_t o = 0; o < N; o++) {
            double start[3];
            for (int a = 0; a < 3; a++)
                start[a] = pos[3 * o + a] + 0.3 * (unit(&seed) - 0.5);
            wpd_even_limits lim = {reach, floor, start, 0.5};
            uint32_t slot[WPD_EVEN_TRIES];
            int got = wpd_even_candidates(&v, &surface, o, &lim, slot);
            /* The literal sum for a position q. */
            double t = spacing[o];
            int nt = 1;
            for (int j = 0; j < cnt[o]; j++)
                if (nb[o * K + j] < N)
                    t += spacing[nb[o * K + j]], nt++;
            t /= nt;
            double stay = 0, order[INPUT];
            ranked better[INPUT];
            int nbetter = 0, within = 0;
            for (int c = 0; c < INPUT; c++) {
                order[c] = dist(inp + 3 * c, pos + 3 * o);
                within += order[c] <= reach;
            }
            /* The literal sums over the WPD_EVEN_CANDIDATES input points
             * nearest to the sample within reach: the candidates. */
            uint8_t candidate[INPUT] = {0};
            for (int taken = 0; taken < WPD_EVEN_CANDIDATES; taken++) {
                int next = -1;
                for (int c = 0; c < INPUT; c++)
                    if (!candidate[c] && order[c] <= reach && (next < 0 || order[c] < order[next]))
                        next = c;
                if (next < 0)
                    break;
                candidate[next] = 1;
            }
            capped += within > WPD_EVEN_CANDIDATES;
            standing += trial % 2 && o < N / 2;
            for (int c = -1; c < INPUT; c++) {
                const double *q = c < 0 ? pos + 3 * o : inp + 3 * c;
                if (c >= 0 && (!candidate[c] || dist(q, start) > 0.5))
                    continue;
                double d[K], e;
                int near = 0;
                for (int j = 0; j < cnt[o]; j++) {
                    d[j] = dist(q, pos + 3 * (size_t)nb[o * K + j]);
                    near |= d[j] < floor;
                }
                if (c >= 0 && near)
                    continue;
                e = pow(mean6(d, cnt[o]) - t, 2);
                for (int j = 0; j < cnt[o]; j++)
                    if (nb[o * K + j] < N)
                        e += pow(spacing_with(pos, nb, cnt, nb[o * K + j], o, q) - t, 2);
                if (c < 0)
                    stay = e;
                else
                    better[nbetter++] = (ranked){e, order[c], c};
            }
            int want = 0;
            for (int c = 0; c < nbetter; c++)
                if (better[c].e < stay * (1 - 1e-12))
                    better[want++] = better[c];
            qsort(better, (size_t)want, sizeof *better, by_sum);
            want = want < WPD_EVEN_TRIES ? want : WPD_EVEN_TRIES;
            CHECK_MSG(got == want, "trial %d sample %zu: %d points, literal sums %d", trial, o,
                      got, want);
            for (int c = 0; c < got && c < want; c++)
                CHECK_MSG(surface.id[slot[c]] == (uint32_t)better[c].id,
                          "trial %d sample %zu: point %d of %d differs", trial, o, c, got);
            checked++;
            moved += got > 0;
        }
        wpd_grid_free(&surface);
    }
    CHECK_MSG(checked > 500 && moved > checked / 10 && moved < checked,
              "%d checked, %d with a point to move onto", checked, moved);
    /* Some samples have more input points within reach than candidates:
     * the cap is exercised. */
    CHECK_MSG(capped > checked / 10 && capped < checked, "%d of %d samples capped", capped,
              checked);
    CHECK_MSG(standing == 10 * (N / 2), "%d samples standing on an input point", standing);
}

/* CV of the samples' mean distance to their 6 nearest (brute force). */
static double local_cv(const double *p, size_t m)
{
    double s = 0, s2 = 0;
    double *d = malloc(m * sizeof *d);
    for (size_t i = 0; i < m; i++) {
        size_t c = 0;
        for (size_t j = 0; j < m; j++)
            if (j != i)
                d[c++] = dist(p + 3 * i, p + 3 * j);
        double v = mean6(d, (int)c);
        s += v;
        s2 += v * v;
    }
    free(d);
    double mean = s / (double)m;
    return sqrt(fmax(0, s2 / (double)m - mean * mean)) / mean;
}

/* Largest distance from an input point to its nearest sample. */
static double cover_radius(const double *inp, size_t n, const double *p, size_t m)
{
    double worst = 0;
    for (size_t i = 0; i < n; i++) {
        double best = INFINITY;
        for (size_t j = 0; j < m; j++)
            best = fmin(best, dist(inp + 3 * i, p + 3 * j));
        worst = fmax(worst, best);
    }
    return worst;
}

TEST(even_steps_even_the_spacing_on_a_plane_and_in_a_volume)
{
    /* A jittered plane and a filled cube (vegetation: no tangent plane, so
     * the Voronoi steps leave it still), Poisson-sampled at r with every
     * 4th sample dropped as the exact count may: the even steps lower the
     * local spacing's CV, put every sample on an input point, keep every
     * pair 0.82 r apart and every input point within max(r, before). */
    double r = 1;
    for (int shape = 0; shape < 2; shape++) {
        uint64_t seed = 21 + (uint64_t)shape;
        size_t n = shape ? 20000 : 90 * 90;
        double *inp = malloc(3 * n * sizeof *inp);
        uint64_t *gid = malloc(n * sizeof *gid);
        for (size_t i = 0; i < n; i++) {
            for (int a = 0; a < 3; a++)
                inp[3 * i + a] = shape ? 7 * unit(&seed)
                                       : a == 2 ? 0 : 0.25 * ((a ? i / 90 : i % 90) + 0.8 * (unit(&seed) - 0.5));
            gid[i] = i;
        }
        wpd_error err;
        uint32_t *idx = malloc(n * sizeof *idx);
        wpd_poisson_input pin = {inp, gid, NULL, NULL, n, NULL, 0, r, 3, 2};
        long got = wpd_poisson_pass(&pin, idx, &err);
        size_t m = 0;
        double *s = malloc(3 * (size_t)got * sizeof *s), *t = malloc(3 * (size_t)got * sizeof *t),
               *t1 = malloc(3 * (size_t)got * sizeof *t1);
        for (long i = 0; i < got; i++)
            if (i % 4 != 3)
                memcpy(s + 3 * m++, inp + 3 * (size_t)idx[i], 3 * sizeof *s);
        wpd_grid surface = {0};
        CHECK(wpd_grid_build(&surface, inp, NULL, n, r / 2, 2, &err) == 0);
        wpd_smooth_stats st;
        for (int threads = 1; threads <= 2; threads++) {
            double *out = threads == 1 ? t1 : t;
            memcpy(out, s, 3 * m * sizeof *s);
            wpd_smooth_input in = {out, m, NULL, NULL, NULL, 0, &surface, 0, 13, 0, r, threads,
                                   {0, 0, 0}, 3, NULL, 0};
            CHECK(wpd_smooth(&in, &st, &err) == 0);
        }
        CHECK_MSG(memcmp(t, t1, 3 * m * sizeof *t) == 0, "shape %d: threads changed it", shape);
        double before = local_cv(s, m), after = local_cv(t, m);
        CHECK_MSG(after < 0.95 * before, "shape %d: local CV %.4f -> %.4f", shape, before, after);
        size_t on_input = 0, moved = 0;
        for (size_t i = 0; i < m; i++) {
            uint32_t near;
            double d2;
            wpd_knn_slots(&surface, t + 3 * i, 1, WPD_NO_SELF, INFINITY, 0, &near, &d2);
            on_input += d2 == 0;
            moved += memcmp(t + 3 * i, s + 3 * i, 3 * sizeof *t) != 0;
        }
        CHECK_MSG(on_input == m && moved > m / 8, "shape %d: %zu of %zu on input points, %zu moved",
                  shape, on_input, m, moved);
        double gap = INFINITY;
        for (size_t i = 0; i < m; i++)
            for (size_t j = i + 1; j < m; j++)
                gap = fmin(gap, dist(t + 3 * i, t + 3 * j));
        CHECK_MSG(gap >= WPD_SMOOTH_KEEP * r, "shape %d: two samples %.3f r apart", shape, gap);
        double cover0 = cover_radius(inp, n, s, m), cover1 = cover_radius(inp, n, t, m);
        CHECK_MSG(cover1 <= fmax(r, cover0) * (1 + 1e-9), "shape %d: hole %.4f r, was %.4f r",
                  shape, cover1, cover0);
        wpd_grid_free(&surface);
        free(inp);
        free(gid);
        free(idx);
        free(s);
        free(t);
        free(t1);
    }
}

/* Samples of inp at r (every 4th dropped) into s; returns how many. */
static size_t thinned_sample(const double *inp, size_t n, double r, double *s)
{
    wpd_error err;
    uint64_t *gid = malloc(n * sizeof *gid);
    uint32_t *idx = malloc(n * sizeof *idx);
    for (size_t i = 0; i < n; i++)
        gid[i] = i;
    wpd_poisson_input pin = {inp, gid, NULL, NULL, n, NULL, 0, r, 3, 2};
    long got = wpd_poisson_pass(&pin, idx, &err);
    size_t m = 0;
    for (long i = 0; i < got; i++)
        if (i % 4 != 3)
            memcpy(s + 3 * m++, inp + 3 * (size_t)idx[i], 3 * sizeof *s);
    free(gid);
    free(idx);
    return m;
}

TEST(even_steps_move_as_much_on_a_las_lattice)
{
    /* LAS output stores multiples of its scale: input points come as
     * (X s + offset) - origin, an ulp or so off the lattice, and a step's
     * end is rounded to it. The steps must move as much as with exact
     * output (a cap measured to the unrounded point refused them). */
    enum { SIDE = 90 };
    const double scale = 0.001, offset = 512345.678, r = 1;
    uint64_t seed = 31;
    size_t n = SIDE * SIDE;
    double *inp = malloc(3 * n * sizeof *inp), *s = malloc(3 * n * sizeof *s);
    double *t[2] = {malloc(3 * n * sizeof(double)), malloc(3 * n * sizeof(double))};
    for (size_t i = 0; i < n; i++)
        for (int a = 0; a < 3; a++) {
            double v = a == 2 ? 0 : 0.25 * ((a ? i / SIDE : i % SIDE) + 0.8 * (unit(&seed) - 0.5));
            inp[3 * i + a] = (nearbyint(v / scale) * scale + offset) - offset;
        }
    size_t m = thinned_sample(inp, n, r, s);
    wpd_grid surface = {0};
    wpd_error err;
    CHECK(wpd_grid_build(&surface, inp, NULL, n, r / 2, 2, &err) == 0);
    size_t moved[2] = {0, 0};
    for (int lattice = 0; lattice < 2; lattice++) {
        double res = lattice ? scale : 0;
        memcpy(t[lattice], s, 3 * m * sizeof *s);
        wpd_smooth_input in = {t[lattice], m, NULL, NULL, NULL, 0, &surface, 0, 13, 0, r, 2,
                               {res, res, res}, 3, NULL, 0};
        wpd_smooth_stats st;
        CHECK(wpd_smooth(&in, &st, &err) == 0);
        for (size_t i = 0; i < 3 * m; i += 3)
            moved[lattice] += memcmp(t[lattice] + i, s + i, 3 * sizeof *s) != 0;
    }
    double exact = local_cv(t[0], m), stored = local_cv(t[1], m);
    CHECK_MSG(moved[0] > m / 8 && moved[1] >= moved[0] * 0.95 && stored <= exact * 1.02,
              "%zu samples: %zu moved with exact output, %zu on the lattice; local CV %.4f, %.4f",
              m, moved[0], moved[1], exact, stored);
    wpd_grid_free(&surface);
    free(inp);
    free(s);
    free(t[0]);
    free(t[1]);
}
