/* test_sharp.c - the sharp-feature detector: the crease test on folded
 * surfaces, labels on capped neighbourhoods that depend only on the points
 * within the cap (so a block labels its points, and its inner halo, as the
 * whole cloud does), the support rule against a brute-force oracle, and
 * precision and recall against the ground truth of `wpd synth --edge-truth`. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "clouds.h"
#include "core/grid.h"
#include "core/knn.h"
#include "harness.h"
#include "io/cloud.h"
#include "tools/synth/synth.h"
#include "method/crease.h"
#include "method/sharp.h"

static void detect(const double *xyz, size_t n, double cap, int threads, uint8_t *edge)
{
    wpd_grid g = {0};
    wpd_error err;
    if (wpd_grid_build(&g, xyz, NULL, n, 0.5, threads, &err) == 0)
        wpd_detect_sharp_capped(&g, 0, n, cap, edge, threads);
    wpd_grid_free(&g);
}

/* A roof-like surface over [0, 12]^2 with spacing about h: ridges along y
 * at x = 3 and 9, valleys at x = 0, 6 and 12, slopes `slope`, noise sd
 * `noise`, points jittered off a grid. Distance from (x, y) in plan to the
 * nearest crease line: |x - nearest multiple of 3|. */
static cloud folds(double h, double slope, double noise, uint64_t seed)
{
    size_t side = (size_t)(12 / h), n = side * side;
    cloud c = {n, malloc(3 * n * sizeof(double)), malloc(n * sizeof(uint64_t))};
    uint64_t st = seed;
    for (size_t j = 0; j < side; j++)
        for (size_t i = 0; i < side; i++) {
            double *p = c.xyz + 3 * (j * side + i);
            p[0] = h * (i + 0.3 * unit(&st));
            p[1] = h * (j + 0.3 * unit(&st));
            double u = fmod(p[0], 6.0);
            p[2] = slope * (u < 3 ? u : 6 - u) + noise * gauss(&st);
            c.gid[j * side + i] = j * side + i;
        }
    return c;
}

static double crease_plan_dist(const double *p)
{
    double u = fmod(p[0], 3.0);
    return fmin(u, 3 - u);
}

TEST(sharp_labels_the_creases_of_a_folded_surface_and_nothing_else)
{
    /* Slopes of 0.5 (dihedral 2 atan 0.5 = 53 degrees) and 0.2 (23, below
     * the 30 degree minimum); noise a tenth of the spacing. */
    for (int gentle = 0; gentle < 2; gentle++) {
        cloud c = folds(0.1, gentle ? 0.2 : 0.5, 0.01, 4);
        uint8_t *e = calloc(c.n, 1);
        detect(c.xyz, c.n, INFINITY, 2, e);
        size_t on = 0, on_hit = 0, off_hit = 0;
        for (size_t i = 0; i < c.n; i++) {
            const double *p = c.xyz + 3 * i;
            if (p[0] < 0.8 || p[0] > 11.2 || p[1] < 0.8 || p[1] > 11.2)
                continue; /* the cloud's border */
            double d = crease_plan_dist(p);
            if (d < 0.02)
                on++, on_hit += e[i];
            else if (d > 0.1)
                off_hit += e[i];
        }
        if (gentle) {
            CHECK_MSG(on_hit == 0 && off_hit == 0, "23 degree creases: %zu + %zu labelled",
                      on_hit, off_hit);
        } else {
            CHECK_MSG(on > 100 && on_hit > 0.9 * on, "%zu of %zu crease points labelled",
                      on_hit, on);
            CHECK_MSG(off_hit < on / 20, "%zu points off the creases labelled", off_hit);
        }
        free(e);
        cloud_free(&c);
    }
}

TEST(sharp_crease_test_rejects_volumes_and_planes)
{
    CHECK(fabs(cos(WPD_CREASE_MIN_DEGREES * M_PI / 180) - WPD_CREASE_COS_MIN) < 1e-15);
    uint64_t st = 9;
    double pts[3 * 64], p[3] = {0, 0, 0};
    /* A blob (a tree crown, multiple returns). */
    for (int i = 0; i < 64; i++)
        for (int a = 0; a < 3; a++)
            pts[3 * i + a] = 0.3 * gauss(&st);
    CHECK(wpd_crease_test(pts, 64, p, 0.1) != WPD_CREASE_ON);
    /* A plane. */
    for (int i = 0; i < 64; i++) {
        pts[3 * i] = unit(&st) - 0.5, pts[3 * i + 1] = unit(&st) - 0.5;
        pts[3 * i + 2] = 0.3 * pts[3 * i] + 0.002 * gauss(&st);
    }
    CHECK(wpd_crease_test(pts, 64, p, 0.1) == WPD_CREASE_FLAT);
    /* Two planes crossing (an X, not a fold). */
    for (int i = 0; i < 64; i++) {
        double t = 2 * unit(&st) - 1, y = unit(&st) - 0.5;
        pts[3 * i] = t, pts[3 * i + 1] = y, pts[3 * i + 2] = i % 2 ? t : -t;
    }
    CHECK(wpd_crease_test(pts, 64, p, 0.1) != WPD_CREASE_ON);
    /* A right-angle fold, p on its line. */
    for (int i = 0; i < 64; i++) {
        double t = unit(&st), y = unit(&st) - 0.5;
        pts[3 * i] = i % 2 ? t : 0, pts[3 * i + 1] = y, pts[3 * i + 2] = i % 2 ? 0 : t;
    }
    CHECK(wpd_crease_test(pts, 64, p, 0.1) == WPD_CREASE_ON);
    double q[3] = {0.3, 0, 0};
    CHECK(wpd_crease_test(pts, 64, q, 0.1) == WPD_CREASE_NEAR);
}

/* The sharp rule by brute force (sharp.h), as an oracle: the spacing from
 * the 12th nearest other point closer than cap, the crease test on the
 * nearest WPD_KNN_MAX points closer than both cap and WPD_SHARP_REACH
 * spacings in (d2, x, y, z) order, then the support: another point, not at
 * the same place, closer than WPD_SHARP_SUPPORT spacings and cap, on a
 * crease by the test. */
typedef struct near_pt {
    double d2;
    const double *p;
} near_pt;

static int near_order(const void *va, const void *vb)
{
    const near_pt *a = va, *b = vb;
    if (a->d2 != b->d2)
        return a->d2 < b->d2 ? -1 : 1;
    for (int k = 0; k < 3; k++)
        if (a->p[k] != b->p[k])
            return a->p[k] < b->p[k] ? -1 : 1;
    return 0;
}

static int brute_crease(const double *xyz, size_t n, size_t i, double cap, near_pt *a,
                        double *spacing)
{
    const double *q = xyz + 3 * i;
    size_t m = 0;
    for (size_t j = 0; j < n; j++) {
        const double *p = xyz + 3 * j;
        double d2 = (p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1]) +
                    (p[2] - q[2]) * (p[2] - q[2]);
        if (d2 < cap * cap)
            a[m++] = (near_pt){d2, p};
    }
    if (m <= WPD_SHARP_SPACING_K)
        return WPD_CREASE_SMALL_FACE;
    qsort(a, m, sizeof *a, near_order);
    *spacing = sqrt(a[WPD_SHARP_SPACING_K].d2 * M_PI / WPD_SHARP_SPACING_K);
    double reach = fmin(WPD_SHARP_REACH * *spacing, cap);
    double pts[3 * WPD_KNN_MAX];
    int got = 0;
    for (size_t j = 0; j < m && got < WPD_KNN_MAX && a[j].d2 < reach * reach; j++, got++)
        memcpy(pts + 3 * got, a[j].p, 3 * sizeof(double));
    return wpd_crease_test(pts, got, q, *spacing);
}

/* Folds with 85 % of the points near their ridges and valleys taken out,
 * and points put back on the ridge at x = 3 one at a time, 2 apart, and on
 * the ridge at x = 9 in pairs 0.1 and 0.5 apart (under a spacing, and
 * between 2 and 3 of them): some crease verdicts stand alone, others have
 * company. */
static cloud lone_creases(void)
{
    cloud f = folds(0.2, 0.5, 0.01, 6);
    uint64_t st = 11;
    cloud c = {0, malloc((3 * f.n + 21) * sizeof(double)), malloc((f.n + 7) * sizeof(uint64_t))};
    static const double put[7][3] = {{3, 3.5, 1.5}, {3, 5.5, 1.5}, {3, 7.5, 1.5},
                                     {9, 5.0, 1.5}, {9, 5.1, 1.5}, {9, 7.0, 1.5},
                                     {9, 7.5, 1.5}};
    for (size_t i = 0; i < f.n + 7; i++) {
        const double *p = i < f.n ? f.xyz + 3 * i : put[i - f.n];
        if (i >= f.n || crease_plan_dist(p) >= 0.2 || unit(&st) >= 0.85) {
            memcpy(c.xyz + 3 * c.n, p, 3 * sizeof(double));
            c.gid[c.n] = c.n;
            c.n++;
        }
    }
    cloud_free(&f);
    return c;
}

TEST(sharp_a_crease_point_needs_another_within_reach)
{
    cloud c = lone_creases();
    size_t n = c.n;
    const double *xyz = c.xyz;
    double cap = 1.5;
    uint8_t *raw = malloc(n), *verdict = malloc(n), *edge = malloc(n);
    double *spacing = malloc(n * sizeof *spacing);
    near_pt *a = malloc(n * sizeof *a);
    for (size_t i = 0; i < n; i++)
        raw[i] = (uint8_t)brute_crease(xyz, n, i, cap, a, &spacing[i]);
    wpd_grid g = {0};
    wpd_error err;
    CHECK(wpd_grid_build(&g, xyz, NULL, n, 0.5, 2, &err) == 0);
    wpd_sharp_verdicts(&g, cap, verdict, 2);
    wpd_detect_sharp_capped(&g, 0, n, cap, edge, 2);
    size_t wrong = 0, on = 0, alone = 0;
    for (size_t i = 0; i < n; i++) {
        int want = raw[i];
        if (raw[i] == WPD_CREASE_ON) {
            double radius = fmin(WPD_SHARP_SUPPORT * spacing[i], cap);
            int company = 0;
            for (size_t j = 0; j < n && !company; j++) {
                double d2 = 0;
                for (int k = 0; k < 3; k++)
                    d2 += (xyz[3 * j + k] - xyz[3 * i + k]) * (xyz[3 * j + k] - xyz[3 * i + k]);
                company = d2 > 0 && d2 < radius * radius && raw[j] == WPD_CREASE_ON;
            }
            want = company ? WPD_CREASE_ON : WPD_SHARP_ALONE;
        }
        on += want == WPD_CREASE_ON;
        alone += want == WPD_SHARP_ALONE;
        wrong += verdict[i] != want || edge[i] != (want == WPD_CREASE_ON);
    }
    CHECK_MSG(wrong == 0, "%zu of %zu verdicts or labels differ from the rule", wrong, n);
    CHECK_MSG(on > 0 && alone > 0, "%zu supported and %zu lone crease points: both wanted", on,
              alone);
    printf("     %zu points: %zu on a supported crease, %zu alone\n", n, on, alone);
    wpd_grid_free(&g);
    free(raw), free(verdict), free(edge), free(spacing), free(a);
    cloud_free(&c);
}

TEST(sharp_capped_labels_depend_only_on_the_points_within_cap)
{
    for (int kind = 0; kind < 4; kind++) {
        /* The lone creases: labels near a block's border whose support lies
         * beyond it (a label looks 2 caps far). */
        cloud c = kind == 3   ? lone_creases()
                  : kind == 2 ? folds(0.25, 0.6, 0.02, 5)
                              : make_cloud(kind == 0 ? PLANE : QUANTISED, 4000, 5);
        const char *name = kind == 3   ? "lone creases"
                           : kind == 2 ? "folds"
                                       : kind_name[kind == 0 ? PLANE : QUANTISED];
        size_t n = c.n;
        uint8_t *a = malloc(n), *b = malloc(n), *p = malloc(n), *blk = malloc(n);
        double *shuffled = malloc(3 * n * sizeof(double));
        uint32_t *perm = malloc(n * sizeof *perm);
        detect(c.xyz, n, 1.0, 1, a);
        size_t sharp = 0;
        for (size_t i = 0; i < n; i++)
            sharp += a[i];
        /* Threads. */
        detect(c.xyz, n, 1.0, 4, b);
        CHECK_MSG(memcmp(a, b, n) == 0, "%s: labels depend on the threads", name);
        /* Point order (ties among equal distances must not follow it). */
        uint64_t st = 3;
        for (size_t i = 0; i < n; i++)
            perm[i] = (uint32_t)i;
        for (size_t i = n - 1; i > 0; i--) {
            size_t j = (size_t)(unit(&st) * (double)(i + 1));
            uint32_t t = perm[i];
            perm[i] = perm[j];
            perm[j] = t;
        }
        for (size_t i = 0; i < n; i++)
            memcpy(shuffled + 3 * i, c.xyz + 3 * (size_t)perm[i], 3 * sizeof(double));
        detect(shuffled, n, 1.0, 2, p);
        size_t moved = 0;
        for (size_t i = 0; i < n; i++)
            moved += p[i] != a[perm[i]];
        CHECK_MSG(moved == 0, "%s: %zu labels change with the point order", name, moved);
        /* Blocks: own points first, then the halo within H; labels exact
         * for every point closer than H - 2 cap to the box (a label looks
         * that far: sharp.h). */
        double H = 2.5, cap = 1.0;
        size_t wrong = 0, checked = 0;
        for (int t = 0; t < 4; t++) {
            box bx;
            for (int k = 0; k < 3; k++) {
                bx.lo[k] = 6 * unit(&st);
                bx.hi[k] = bx.lo[k] + 2 + 4 * unit(&st);
            }
            bx.lo[2] = -1; /* across the whole height */
            bx.hi[2] = 8;
            size_t nown = 0, m = 0;
            for (int pass = 0; pass < 2; pass++)
                for (size_t i = 0; i < n; i++) {
                    double d = box_dist(&bx, c.xyz + 3 * i);
                    if ((d == 0) == (pass == 0) && d < H) {
                        memcpy(shuffled + 3 * m, c.xyz + 3 * i, 3 * sizeof(double));
                        perm[m++] = (uint32_t)i;
                    }
                }
            for (size_t j = 0; j < m && box_dist(&bx, shuffled + 3 * j) == 0; j++)
                nown++;
            wpd_grid g = {0};
            wpd_error err;
            CHECK(wpd_grid_build(&g, shuffled, NULL, m, 0.5, 2, &err) == 0);
            /* Own points and the halo separately: the range form. */
            memset(blk, 7, m);
            wpd_detect_sharp_capped(&g, 0, nown, cap, blk, 2);
            wpd_detect_sharp_capped(&g, nown, m, cap, blk, 2);
            wpd_grid_free(&g);
            for (size_t j = 0; j < m; j++) {
                CHECK(blk[j] <= 1);
                if (box_dist(&bx, shuffled + 3 * j) < H - WPD_SHARP_DEPTH * cap) {
                    checked++;
                    wrong += blk[j] != a[perm[j]];
                }
            }
        }
        CHECK_MSG(wrong == 0 && checked > 100, "%s: %zu of %zu block labels differ", name,
                  wrong, checked);
        CHECK_MSG(kind < 2 || sharp > 0, "%s: no sharp point", name);
        free(a); free(b); free(p); free(blk); free(shuffled); free(perm);
        cloud_free(&c);
    }
}
