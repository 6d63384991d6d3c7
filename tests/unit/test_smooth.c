/* test_smooth.c - what smoothing must keep (method/smooth_guard.h): the
 * Poisson spacing (no pair closer than 0.75 r), the cover of the input (no
 * input point ends farther from the samples than max(r, before)), samples
 * off a surface still, the same bytes for any thread count. */
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
#include "method/smooth_guard.h"
#include "method/smooth_surface.h"

static double unit(uint64_t *state)
{
    *state = wpd_mix64(*state + 0x9e3779b97f4a7c15ULL);
    return (double)(*state >> 11) * 0x1p-53;
}

/* An input cloud, its Poisson sample at radius r and a grid over it. */
typedef struct cloud {
    size_t n, m;
    double *xyz;      /* [3n] input */
    uint64_t *gid;
    double *s;        /* [3m] samples */
    wpd_grid surface;
} cloud;

static void cloud_free(cloud *c)
{
    free(c->xyz);
    free(c->gid);
    free(c->s);
    wpd_grid_free(&c->surface);
}

/* Samples c's input at radius r; drops every drop-th sample (0: none), as
 * the exact count does, which leaves holes the Voronoi moves rush into. */
static void sample(cloud *c, double r, int drop)
{
    wpd_error err;
    uint32_t *idx = malloc(c->n * sizeof *idx);
    wpd_poisson_input in = {c->xyz, c->gid, NULL, NULL, c->n, NULL, 0, r, 3, 2};
    long m = wpd_poisson_pass(&in, idx, &err);
    c->s = malloc(3 * (size_t)(m > 0 ? m : 1) * sizeof *c->s);
    c->m = 0;
    for (long i = 0; i < m; i++)
        if (!drop || i % drop != drop - 1)
            memcpy(c->s + 3 * c->m++, c->xyz + 3 * (size_t)idx[i], 3 * sizeof *c->s);
    free(idx);
    wpd_grid_build(&c->surface, c->xyz, NULL, c->n, r / 2, 2, &err);
}

static cloud alloc_cloud(size_t cap)
{
    cloud c = {0};
    c.xyz = malloc(3 * cap * sizeof *c.xyz);
    c.gid = malloc(cap * sizeof *c.gid);
    return c;
}

/* A jittered grid of spacing h on z = 0 (or on a cylinder of radius
 * `bend` around the y axis when bend > 0), side x side points. */
static cloud sheet(int side, double h, double bend, uint64_t seed)
{
    cloud c = alloc_cloud((size_t)side * side);
    for (int y = 0; y < side; y++)
        for (int x = 0; x < side; x++) {
            double u = h * (x + 0.8 * (unit(&seed) - 0.5)), v = h * (y + 0.8 * (unit(&seed) - 0.5));
            double *p = c.xyz + 3 * c.n;
            p[0] = bend > 0 ? bend * sin(u / bend) : u;
            p[1] = v;
            p[2] = bend > 0 ? bend * cos(u / bend) : 0;
            c.gid[c.n] = c.n;
            c.n++;
        }
    return c;
}

/* 5 Voronoi steps and, in turn with them, `even` even-spacing steps
 * (smooth_even.h). */
static int smooth(cloud *c, double *t, double r, int threads, int even, wpd_smooth_stats *st)
{
    wpd_error err;
    memcpy(t, c->s, 3 * c->m * sizeof *t);
    wpd_smooth_input in = {t, c->m, NULL, NULL, NULL, 0, &c->surface, 0, 13, 5, r, threads,
                           {0, 0, 0}, even, NULL, 0};
    return wpd_smooth(&in, st, &err);
}

/* Smallest distance between two of the m points (brute force). */
static double min_spacing(const double *p, size_t m)
{
    double best = INFINITY;
    for (size_t i = 0; i < m; i++)
        for (size_t j = i + 1; j < m; j++) {
            double dx = p[3 * i] - p[3 * j], dy = p[3 * i + 1] - p[3 * j + 1],
                   dz = p[3 * i + 2] - p[3 * j + 2];
            best = fmin(best, dx * dx + dy * dy + dz * dz);
        }
    return sqrt(best);
}

/* Largest distance from an input point to its nearest sample. */
static double cover_radius(const cloud *c, const double *p, size_t m)
{
    wpd_error err;
    wpd_grid g = {0};
    wpd_grid_build(&g, p, NULL, m, 1, 1, &err);
    double worst = 0;
    for (size_t i = 0; i < c->n; i++) {
        uint32_t id;
        double d2;
        wpd_knn(&g, c->xyz + 3 * i, 1, WPD_NO_SELF, INFINITY, 0, &id, &d2);
        worst = fmax(worst, sqrt(d2));
    }
    wpd_grid_free(&g);
    return worst;
}

TEST(smooth_keeps_the_poisson_spacing_on_a_jittered_plane_and_a_cylinder)
{
    double r = 1;
    for (int shape = 0; shape < 2; shape++) {
        /* Every 4th sample dropped: holes a Voronoi step runs into. */
        cloud c = sheet(90, 0.25, shape ? 4 : 0, 7 + (uint64_t)shape);
        sample(&c, r, 4);
        CHECK(c.m > 200 && min_spacing(c.s, c.m) >= r);
        double *t = malloc(3 * c.m * sizeof *t), *t1 = malloc(3 * c.m * sizeof *t1);
        wpd_smooth_stats st, st1;
        CHECK(smooth(&c, t, r, 2, 3, &st) == 0 && smooth(&c, t1, r, 1, 3, &st1) == 0);
        double d = min_spacing(t, c.m);
        CHECK_MSG(d >= WPD_SMOOTH_KEEP * r, "shape %d: two samples %.3f r apart", shape, d / r);
        CHECK_MSG(memcmp(t, t1, 3 * c.m * sizeof *t) == 0, "shape %d: threads changed the result",
                  shape);
        /* It still smooths: most samples moved, some moves were cut. */
        size_t moved = 0;
        for (size_t i = 0; i < 3 * c.m; i += 3)
            moved += memcmp(t + i, c.s + i, 3 * sizeof *t) != 0;
        CHECK_MSG(moved > c.m / 2 && st.shortened > 0, "shape %d: %zu of %zu moved, %zu cut",
                  shape, moved, c.m, st.shortened);
        free(t);
        free(t1);
        cloud_free(&c);
    }
}

/* Adds a pole of radius rad and height h standing on the sheet at (11, 11):
 * a thin upright feature whose samples a tangent-plane move would carry
 * off it, onto the ground. */
static void add_pole(cloud *c, double rad, double h, uint64_t seed)
{
    enum { POLE = 3000 };
    c->xyz = realloc(c->xyz, 3 * (c->n + POLE) * sizeof *c->xyz);
    c->gid = realloc(c->gid, (c->n + POLE) * sizeof *c->gid);
    for (int i = 0; i < POLE; i++) {
        double a = 2 * M_PI * unit(&seed), *q = c->xyz + 3 * c->n;
        q[0] = 11 + rad * cos(a);
        q[1] = 11 + rad * sin(a);
        q[2] = h * unit(&seed);
        c->gid[c->n] = c->n;
        c->n++;
    }
}

TEST(smooth_opens_no_hole_in_the_input)
{
    /* The input's distance to the nearest sample may not grow past
     * max(r, what it was) anywhere: on a plane with samples dropped and on
     * a plane with a pole (without the guard, the pole's samples slid off
     * it: the top of the taller pole ended 1.077 r from the nearest sample). */
    double r = 1;
    for (int shape = 0; shape < 3; shape++) {
        cloud c = sheet(90, 0.25, 0, 15 + (uint64_t)shape);
        if (shape)
            add_pole(&c, 0.4, shape == 1 ? 1.5 : 2.5, 103 + (uint64_t)shape);
        sample(&c, r, shape ? 0 : 3);
        double before = cover_radius(&c, c.s, c.m);
        double *t = malloc(3 * c.m * sizeof *t);
        wpd_smooth_stats st;
        CHECK(smooth(&c, t, r, 2, 3, &st) == 0);
        double after = cover_radius(&c, t, c.m);
        CHECK_MSG(after <= fmax(r, before) * (1 + 1e-6),
                  "shape %d: hole %.4f r after, %.4f r before", shape, after / r, before / r);
        free(t);
        cloud_free(&c);
    }
}

TEST(smooth_leaves_a_volumetric_blob_still)
{
    /* Points filling a cube (vegetation, multiple returns): no tangent
     * plane, so no sample moves - but for a few on the cube's faces, where
     * the neighbourhood is a half ball. */
    uint64_t seed = 5;
    cloud c = alloc_cloud(40000);
    for (c.n = 0; c.n < 40000; c.n++) {
        for (int a = 0; a < 3; a++)
            c.xyz[3 * c.n + a] = 8 * unit(&seed);
        c.gid[c.n] = c.n;
    }
    sample(&c, 1, 0);
    double *t = malloc(3 * c.m * sizeof *t);
    wpd_smooth_stats st;
    CHECK(smooth(&c, t, 1, 2, 0, &st) == 0); /* Voronoi steps only */
    size_t moved = 0, inside = 0;
    for (size_t i = 0; i < 3 * c.m; i += 3) {
        int in = 1;
        for (int a = 0; a < 3; a++)
            in &= c.s[i + a] > 2 && c.s[i + a] < 6;
        int m = memcmp(t + i, c.s + i, 3 * sizeof *t) != 0;
        moved += m;
        inside += m && in;
    }
    CHECK_MSG(c.m > 300 && inside == 0 && moved <= c.m / 50,
              "%zu of %zu moved (%zu inside), %zu kept still", moved, c.m, inside,
              st.volume_fixed);
    free(t);
    cloud_free(&c);
}

/* The keeper of input point 0 (at the origin, bound 1) after a cover
 * update with samples at pos[0..1], each planning its farthest end as its
 * cap (count[i] ends from ends + 12 i, at most 4); -1 if no sample keeps
 * it, and the owner into *owner. */
static int keeper_with_ends(const double pos[6], const double ends[24], const uint8_t count[2],
                            int with_ends, uint32_t *owner, int *failures_)
{
    wpd_error err;
    double x[3] = {0, 0, 0}, cap[2] = {0, 0};
    for (int i = 0; i < 2; i++)
        for (int j = 0; j < count[i]; j++) {
            const double *e = ends + 12 * i + 3 * j, *p = pos + 3 * i;
            cap[i] = fmax(cap[i], sqrt((e[0] - p[0]) * (e[0] - p[0]) +
                                       (e[1] - p[1]) * (e[1] - p[1]) +
                                       (e[2] - p[2]) * (e[2] - p[2])));
        }
    wpd_grid surface = {0}, samples = {0};
    wpd_cover cover;
    CHECK(wpd_grid_build(&surface, x, NULL, 1, 1, 1, &err) == 0);
    CHECK(wpd_grid_build(&samples, pos, NULL, 2, 1, 1, &err) == 0);
    CHECK(wpd_cover_init(&cover, &surface, pos, 2, 0, 1, NULL, 1, &err) == 0);
    wpd_step_ends e = {ends, count, 4};
    wpd_spacing_guard g = {&samples, pos, 2, cap, NULL, 1, 0, 2, with_ends ? &e : NULL};
    CHECK(wpd_cover_update(&cover, &g, pos, 1, &err) == 0);
    *owner = cover.owner[0];
    int keeper = -1;
    for (int i = 0; i < 2; i++) /* at most one keeper, holding the one point */
        if (cover.first[i + 1] > cover.first[i]) {
            CHECK(keeper == -1 && cover.first[i + 1] - cover.first[i] == 1 &&
                  cover.slot[cover.first[i]] == 0);
            keeper = i;
        }
    CHECK(keeper == -1 || (uint32_t)keeper == *owner); /* the keeper is the owner */
    wpd_cover_free(&cover);
    wpd_grid_free(&surface);
    wpd_grid_free(&samples);
    return keeper;
}

TEST(cover_trusts_a_sample_whose_every_end_keeps_the_point)
{
    /* Sample 0 stands 0.5 from the point; its cap says it may end 1.5 from
     * it, past the bound 1; its ends (an even step's tries) say where it
     * may really go. Sample 1 is far away. */
    double pos[6] = {0.5, 0, 0, 5, 5, 0};
    double near[24] = {0.9, 0, 0, 0, 0.9, 0, -0.5, 0.5, 0, 0.3, 0, 0.9};
    double out_first[24] = {1.1, 0, 0, 0, 0.9, 0, -0.5, 0.5, 0, 0.3, 0, 0.9};
    double out_middle[24] = {0.9, 0, 0, 0, 0.9, 0, -0.5, 0.5, 0.9, 0.3, 0, 0.9};
    double out_last[24] = {0.9, 0, 0, 0, 0.9, 0, -0.5, 0.5, 0, 0.3, 0, 1.1};
    uint8_t four[2] = {4, 0}, three[2] = {3, 0};
    uint32_t owner;
    CHECK_MSG(keeper_with_ends(pos, near, four, 0, &owner, failures_) == 0,
              "trusted though it may go anywhere within its cap");
    CHECK_MSG(keeper_with_ends(pos, near, four, 1, &owner, failures_) == -1 && owner == 0,
              "not trusted though every end keeps the point");
    CHECK_MSG(keeper_with_ends(pos, out_first, four, 1, &owner, failures_) == 0,
              "trusted though its first end is 1.1 from the point");
    CHECK_MSG(keeper_with_ends(pos, out_middle, four, 1, &owner, failures_) == 0,
              "trusted though its third end is 1.03 from the point");
    CHECK_MSG(keeper_with_ends(pos, out_last, four, 1, &owner, failures_) == 0,
              "trusted though its last end is 1.14 from the point");
    CHECK_MSG(keeper_with_ends(pos, out_last, three, 1, &owner, failures_) == -1,
              "the ends past the count were read");
}

TEST(cover_trusts_no_sample_that_may_stay_beyond_the_bound)
{
    /* Sample 0, the nearest (0.9), may end 1.2 from the point; sample 1
     * stands 1.05 from it, past the bound, though its one end is within:
     * it may be refused and stay, so the nearest keeps the point. */
    double pos[6] = {0.9, 0, 0, 0, 1.05, 0};
    double ends[24] = {1.2, 0, 0};
    ends[12 + 1] = 0.5;
    uint8_t count[2] = {1, 1};
    uint32_t owner;
    CHECK_MSG(keeper_with_ends(pos, ends, count, 1, &owner, failures_) == 0,
              "sample 1 was trusted from its end alone (owner %u)", owner);
    /* With sample 0's end within the bound too, it keeps its point. */
    ends[0] = 0.95;
    CHECK_MSG(keeper_with_ends(pos, ends, count, 1, &owner, failures_) == -1 && owner == 0,
              "the nearest was not trusted from its end (owner %u)", owner);
}

TEST(a_point_is_on_the_output_lattice_but_for_floating_error_only)
{
    /* lone-star: UTM coordinates relative to the minimum corner, a LAS
     * scale of 0.00025, a millionth of a step of floating error. */
    double res[3] = {0.00025, 0.00025, 0.00025}, none[3] = {0, 0, 0};
    double p[3] = {4.1560000000172295, 0.40500000026077032, 0.30674999999973807}, q[3];
    wpd_round_to_output(res, p, q);
    CHECK(q[0] == 16624 * 0.00025 && q[1] == 1620 * 0.00025 && q[2] == 1227 * 0.00025);
    CHECK_MSG(wpd_on_lattice(res, p, q), "a millionth of a step off counts as off");
    double off[3] = {p[0] + 0.01 * res[0], p[1], p[2]};
    wpd_round_to_output(res, off, q);
    CHECK_MSG(!wpd_on_lattice(res, off, q), "a hundredth of a step off counts as on");
    wpd_round_to_output(none, off, q);
    CHECK_MSG(memcmp(q, off, sizeof q) == 0 && wpd_on_lattice(none, off, q),
              "no lattice: the point moved or is off it");
}

/* What holding places on the surface with a memo and without it gave. */
typedef struct hold_tally {
    int calls, spared, pulled, differ;
} hold_tally;

/* Holds p on the surface with the memo and without it (that result into
 * p) and tallies whether the two differ, whether the memo spared the
 * query (valid, and left as it was) and whether p was pulled back. */
static void hold_both(const wpd_grid *surface, wpd_surface_memo *memo, double p[3],
                      hold_tally *t)
{
    static const double res[3] = {0.001, 0.001, 0.001};
    double with[3];
    memcpy(with, p, sizeof with);
    wpd_surface_memo before = *memo;
    int a = wpd_hold_on_surface(surface, res, memo, with);
    int b = wpd_hold_on_surface(surface, res, NULL, p);
    t->differ += a != b || memcmp(with, p, sizeof with) != 0;
    t->spared += before.valid && memcmp(&before, memo, sizeof *memo) == 0;
    t->pulled += b;
    t->calls++;
}

/* The memo may only spare queries: no place differs, more than
 * calls / share holds and not all are spared, some place is pulled. */
static void check_tally(const hold_tally *t, int share, int *failures_)
{
    CHECK_MSG(t->differ == 0, "%d of %d places differ with the memo", t->differ, t->calls);
    CHECK_MSG(t->spared > t->calls / share && t->spared < t->calls,
              "the memo spared %d of %d holds", t->spared, t->calls);
    CHECK_MSG(t->pulled > 0, "no place was pulled back to the surface");
}

/* A flat 60 x 60 sheet of unit spacing (jittered by seed) with its
 * surface grid, for the memo tests. */
static cloud unit_sheet(uint64_t seed)
{
    cloud c = sheet(60, 1.0, 0, seed);
    wpd_error err;
    if (wpd_grid_build(&c.surface, c.xyz, NULL, c.n, 1.0, 1, &err))
        c.surface.n = 0; /* the tests check it */
    return c;
}

TEST(holding_on_the_surface_gives_the_same_place_with_a_memo_as_without)
{
    /* Samples walking over a jittered sheet in steps of up to a seventh of
     * the input spacing, now and then a step off the sheet far enough to
     * be pulled back: the memo may only spare queries. */
    cloud c = unit_sheet(7);
    CHECK(c.surface.n == c.n);
    uint64_t seed = 11;
    hold_tally t = {0};
    for (int walk = 0; walk < 200; walk++) {
        wpd_surface_memo memo = {{0, 0, 0}, 0, 0, 0};
        double p[3] = {10 + 40 * unit(&seed), 10 + 40 * unit(&seed), 0};
        for (int step = 0; step < 30; step++) {
            double len = step % 10 == 9 ? 3.0 : 0.15;
            for (int a = 0; a < 3; a++)
                p[a] += len * (unit(&seed) - 0.5) * (a == 2 ? 0.5 : 1);
            hold_both(&c.surface, &memo, p, &t);
        }
    }
    check_tally(&t, 10, failures_);
    cloud_free(&c);
}

TEST(a_memo_filled_by_a_projection_query_spares_holds_without_changing_them)
{
    /* As smoothing projects a moved sample: a 13-nearest query at p fills
     * the memo (wpd_surface_memo_fill), then the point a little off p
     * (the projection, now and then farther) is held on the surface: the
     * same places as without the memo, and many holds spared. */
    cloud c = unit_sheet(9);
    CHECK(c.surface.n == c.n);
    uint64_t seed = 5;
    hold_tally t = {0};
    for (int i = 0; i < 3000; i++) {
        /* Every other point near the sheet and moved a little (spared),
         * the others off it and moved farther (borderline, pulled). */
        double lift = i % 2 ? 0.4 : 2, off = i % 2 ? 0.1 : 1.5 * unit(&seed);
        double p[3] = {10 + 40 * unit(&seed), 10 + 40 * unit(&seed), lift * (unit(&seed) - 0.5)};
        uint32_t nb[13];
        double d2[13];
        int got = wpd_knn_slots(&c.surface, p, 13, WPD_NO_SELF, INFINITY, 0, nb, d2);
        wpd_surface_memo memo = {{0, 0, 0}, 0, 0, 0};
        wpd_surface_memo_fill(&memo, p, d2, got);
        double q[3];
        for (int a = 0; a < 3; a++)
            q[a] = p[a] + off * (unit(&seed) - 0.5);
        hold_both(&c.surface, &memo, q, &t);
    }
    check_tally(&t, 5, failures_);
    cloud_free(&c);
}

/* Per slot of c's surface, the sample strictly nearest to its point, or
 * WPD_COVER_NO_HINT (a tie); only every `every`-th slot is named. */
static uint32_t *nearest_by_slot(const cloud *c, int every)
{
    uint32_t *near = malloc(c->surface.n * sizeof *near);
    for (size_t s = 0; s < c->surface.n; s++) {
        const double *x = c->surface.xyz + 3 * s;
        double best = INFINITY, second = INFINITY;
        uint32_t at = 0;
        for (size_t j = 0; j < c->m; j++) {
            const double *q = c->s + 3 * j;
            double d = (q[0] - x[0]) * (q[0] - x[0]) + (q[1] - x[1]) * (q[1] - x[1]) +
                       (q[2] - x[2]) * (q[2] - x[2]);
            if (d < best)
                second = best, best = d, at = (uint32_t)j;
            else if (d < second)
                second = d;
        }
        near[s] = best < second && s % (size_t)every == 0 ? at : WPD_COVER_NO_HINT;
    }
    return near;
}

/* The exact count hands smoothing each input point's nearest sample: the
 * cover's first owners and bounds with that hint (for every point, and
 * for every other one; the caller numbers the samples in another order
 * than the cover) are those it finds by itself. */
TEST(cover_starts_from_the_nearest_samples_it_is_given)
{
    cloud c = sheet(60, 0.1, 0, 5);
    double r = 0.4;
    sample(&c, r, 4);
    size_t m = c.m;
    uint32_t *perm = malloc(m * sizeof *perm);
    double *start = malloc(3 * m * sizeof *start);
    for (size_t o = 0; o < m; o++) { /* the cover's sample o is the caller's m - 1 - o */
        perm[o] = (uint32_t)(m - 1 - o);
        memcpy(start + 3 * o, c.s + 3 * perm[o], 3 * sizeof *start);
    }
    wpd_cover plain;
    wpd_error err;
    CHECK(wpd_cover_init(&plain, &c.surface, start, m, 0, r, NULL, 2, &err) == 0);
    for (int every = 1; every <= 2; every++) {
        uint32_t *near = nearest_by_slot(&c, every);
        wpd_cover_hint hint = {near, perm};
        wpd_cover hinted;
        CHECK(wpd_cover_init(&hinted, &c.surface, start, m, 0, r, &hint, 2, &err) == 0);
        size_t named = 0;
        for (size_t s = 0; s < c.surface.n; s++)
            named += near[s] != WPD_COVER_NO_HINT;
        CHECK_MSG(named > c.surface.n / 3, "%zu of %zu points named", named, c.surface.n);
        CHECK(!memcmp(plain.owner, hinted.owner, c.surface.n * sizeof *plain.owner));
        CHECK(!memcmp(plain.bound, hinted.bound, c.surface.n * sizeof *plain.bound));
        wpd_cover_free(&hinted);
        free(near);
    }
    wpd_cover_free(&plain);
    free(perm), free(start);
    cloud_free(&c);
}
