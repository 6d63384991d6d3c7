/* test_poisson_lazy.c - sharp labels on demand (poisson.h, wpd_labeller):
 * the two- and three-valued passes asking for the labels they need give
 * the decisions of the passes given every label, ask for each label once,
 * and ask for fewer than all. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "clouds.h"
#include "harness.h"
#include "method/poisson.h"

/* A labeller that reads a table of true labels and counts the questions
 * per point (the passes here run on one thread, or ask from territories
 * that never share a point). */
typedef struct table {
    const uint8_t *truth;
    uint8_t *asked;
    size_t questions;
} table;

static int ask(void *ctx, uint32_t point)
{
    table *t = ctx;
    t->asked[point]++;
#pragma omp atomic
    t->questions++;
    return t->truth[point];
}

/* The 300 000-point test cloud of poisson_threads_keep_the_one_thread_samples
 * (enough for the pass on several threads), with a band of sharp points
 * and scattered ones. */
static cloud wide_cloud(uint8_t *edge)
{
    size_t n = 300000;
    cloud c = {n, malloc(3 * n * sizeof(double)), malloc(n * sizeof(uint64_t))};
    uint64_t st = 5;
    for (size_t i = 0; i < n; i++) {
        double x = 200 * unit(&st), y = 120 * unit(&st);
        double z = i % 5 == 0 ? 10 * unit(&st) : 2 * sin(x / 15) * cos(y / 11);
        c.xyz[3 * i] = x, c.xyz[3 * i + 1] = y, c.xyz[3 * i + 2] = z;
        c.gid[i] = 7 * i + 3;
        edge[i] = fabs(x - 100) < 3 || i % 97 == 0;
    }
    return c;
}

TEST(poisson_labels_on_demand_keep_the_samples)
{
    uint8_t *edge = malloc(300000), *unknown = malloc(300000), *asked = malloc(300000);
    cloud c = wide_cloud(edge);
    uint32_t *want = malloc(c.n * 4), *got = malloc(c.n * 4);
    wpd_error err;
    for (double r = 0.6; r < 10; r *= 4)
        for (int threads = 1; threads <= 3; threads++) {
            wpd_poisson_input in = {c.xyz, c.gid, edge, NULL, c.n, NULL, 0, r, 3, threads};
            long a = wpd_poisson_pass(&in, want, &err);
            memset(unknown, WPD_LABEL_UNKNOWN, c.n);
            memset(asked, 0, c.n);
            table t = {edge, asked, 0};
            in.edge = unknown;
            wpd_poisson *ps = wpd_poisson_prepare(&in, &err);
            CHECK(ps != NULL);
            if (!ps)
                continue;
            wpd_poisson_set_labeller(ps, ask, &t);
            long b = wpd_poisson_run(ps, r, got, &err);
            /* A second pass on the context asks for nothing it knows. */
            size_t first = t.questions;
            long b2 = wpd_poisson_run(ps, r, got, &err);
            wpd_poisson_release(ps);
            size_t twice = 0;
            for (size_t i = 0; i < c.n; i++)
                twice += asked[i] > 1;
            CHECK_MSG(a > 0 && a == b && b == b2 && memcmp(want, got, (size_t)a * 4) == 0,
                      "r %g, %d threads: %ld vs %ld kept", r, threads, a, b);
            CHECK_MSG(twice == 0 && t.questions == first && first < c.n / 2,
                      "r %g, %d threads: %zu of %zu labels asked, %zu twice", r, threads, first,
                      c.n, twice);
            if (threads == 1)
                printf("     r %-4g: %zu of %zu labels asked\n", r, first, c.n);
        }
    free(edge); free(unknown); free(asked); free(want); free(got);
    cloud_free(&c);
}

/* One three-valued pass over all points of c (some blind, some not wanted,
 * three fixed points) with the labels given (edge) or asked (t); writes
 * 1 kept, 2 removed, 3 unknown per point. */
static long certain(const cloud *c, const uint8_t *edge, table *t, const uint8_t *blind,
                    const uint8_t *wanted, uint8_t *status)
{
    static const double fixed[9] = {1, 1, 0, 4, 4, 0.5, 0, 0, 0};
    static const uint8_t fixed_edge[3] = {0, 1, 0};
    uint32_t *kept = malloc(c->n * 4), *unk = malloc(c->n * 4);
    wpd_poisson_certain_input ci = {{c->xyz, c->gid, edge, NULL, c->n, fixed, 3, 1.0, 9, 1},
                                    blind, fixed_edge, wanted};
    wpd_error err;
    size_t nu = 0;
    long m = -1;
    wpd_poisson *ps = wpd_poisson_prepare_certain(&ci, &err);
    if (ps) {
        if (t)
            wpd_poisson_set_labeller(ps, ask, t);
        m = wpd_poisson_run_certain(ps, 1.0, kept, unk, &nu, &err);
        wpd_poisson_release(ps);
    }
    memset(status, 2, c->n);
    for (long i = 0; i < m; i++)
        status[kept[i]] = 1;
    for (size_t i = 0; i < nu; i++)
        status[unk[i]] = 3;
    free(kept);
    free(unk);
    return m;
}

/* The three-valued pass: the same KEPT and the same decisions on wanted
 * points; a point not wanted may be UNKNOWN where the pass given every
 * label removes it (its label was never needed), never the reverse. */
TEST(poisson_certain_labels_on_demand_decide_as_the_labels_given)
{
    for (int kind = 0; kind < NKINDS; kind++) {
        cloud c = make_cloud(kind, 3000, 21);
        uint8_t *edge = malloc(c.n), *unknown = malloc(c.n), *asked = calloc(c.n, 1);
        uint8_t *blind = malloc(c.n), *wanted = malloc(c.n), *a = malloc(c.n), *b = malloc(c.n);
        for (size_t i = 0; i < c.n; i++) {
            uint64_t h = wpd_mix64(i * 31 + (uint64_t)kind);
            edge[i] = h % 5 == 0;
            blind[i] = (h >> 8) % 7 == 0;
            wanted[i] = (h >> 16) % 3 != 0;
            unknown[i] = WPD_LABEL_UNKNOWN;
        }
        table t = {edge, asked, 0};
        long ka = certain(&c, edge, NULL, blind, wanted, a);
        long kb = certain(&c, unknown, &t, blind, wanted, b);
        size_t differ = 0, lazier = 0, blind_asked = 0;
        for (size_t i = 0; i < c.n; i++) {
            if (a[i] != b[i] && (wanted[i] || blind[i] || !(a[i] == 2 && b[i] == 3)))
                differ++;
            lazier += a[i] != b[i];
            blind_asked += blind[i] && asked[i];
        }
        CHECK_MSG(ka > 0 && ka == kb && differ == 0 && blind_asked == 0,
                  "%s: %ld vs %ld kept, %zu decisions differ, %zu blind labels asked",
                  kind_name[kind], ka, kb, differ, blind_asked);
        CHECK_MSG(t.questions < c.n, "%s: %zu of %zu labels asked", kind_name[kind],
                  t.questions, c.n);
        printf("     %-9s %zu of %zu labels asked, %zu removed points left unknown\n",
               kind_name[kind], t.questions, c.n, lazier);
        free(edge); free(unknown); free(asked); free(blind); free(wanted); free(a); free(b);
        cloud_free(&c);
    }
}

/* A context given UNKNOWN labels and no labeller refuses to run. */
TEST(poisson_unknown_labels_need_a_labeller)
{
    double xyz[6] = {0, 0, 0, 5, 0, 0};
    uint64_t gid[2] = {1, 2};
    uint8_t edge[2] = {WPD_LABEL_UNKNOWN, 0};
    uint32_t out[2];
    wpd_poisson_input in = {xyz, gid, edge, NULL, 2, NULL, 0, 1.0, 7, 1};
    wpd_error err = {0};
    CHECK(wpd_poisson_pass(&in, out, &err) < 0 && err.code == WPD_E_USAGE);
}
