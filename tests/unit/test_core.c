/* test_core.c - the WPD core: sorts, grid, kNN, PCA, tangent Voronoi cells. */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "common/hugepage.h"
#include "core/grid.h"
#include "core/hash.h"
#include "core/knn.h"
#include "core/pca.h"
#include "core/sort.h"
#include "core/voronoi.h"
#include "harness.h"

/* Deterministic uniform numbers in [0, 1). */
static double unit(uint64_t *state)
{
    *state = wpd_mix64(*state + 0x9e3779b97f4a7c15ULL);
    return (double)(*state >> 11) * 0x1p-53;
}

/* A mix of a dense plane, a sparse blob and a few far outliers, placed far
 * from the origin in part, to exercise cell sizes and far queries. */
static double *mixed_points(size_t n, uint64_t seed)
{
    double *xyz = malloc(3 * n * sizeof *xyz);
    uint64_t s = seed;
    for (size_t i = 0; i < n; i++) {
        double *p = xyz + 3 * i;
        if (i % 10 < 7) { /* plane z = 0.1 x */
            p[0] = 10 * unit(&s);
            p[1] = 10 * unit(&s);
            p[2] = 0.1 * p[0];
        } else if (i % 10 < 9) { /* blob */
            p[0] = 5 + unit(&s);
            p[1] = 5 + unit(&s);
            p[2] = 3 + 2 * unit(&s);
        } else if (i % 100 == 9) { /* outlier */
            p[0] = 1000 * unit(&s);
            p[1] = -300;
            p[2] = 50;
        } else { /* duplicates of an earlier point */
            memcpy(p, xyz + 3 * (i / 2), 3 * sizeof *p);
        }
    }
    return xyz;
}

/* The k nearest by a full scan: insertion into a list sorted by (d2, i). */
static void brute_knn(const double *xyz, size_t n, const double q[3], int k, uint32_t self,
                      uint32_t *idx, double *d2, int *cnt)
{
    *cnt = 0;
    for (size_t i = 0; i < n; i++) {
        if (i == self)
            continue;
        double dx = xyz[3 * i] - q[0], dy = xyz[3 * i + 1] - q[1], dz = xyz[3 * i + 2] - q[2];
        double d = dx * dx + dy * dy + dz * dz;
        if (*cnt == k && !(d < d2[k - 1])) /* ties keep the smaller index, seen first */
            continue;
        int j = *cnt < k ? (*cnt)++ : k - 1;
        while (j > 0 && d < d2[j - 1]) {
            d2[j] = d2[j - 1];
            idx[j] = idx[j - 1];
            j--;
        }
        d2[j] = d;
        idx[j] = (uint32_t)i;
    }
}

TEST(core_radix_sort_orders_pairs_stably)
{
    size_t n = 5000;
    uint64_t *k1 = malloc(n * 8), *tk = malloc(n * 8);
    uint32_t *v1 = malloc(n * 4), *tv = malloc(n * 4);
    for (size_t i = 0; i < n; i++) {
        k1[i] = wpd_mix64(i) >> 30; /* 34 bits, with some repeats below */
        if (i % 17 == 0)
            k1[i] = k1[i / 2];
        v1[i] = (uint32_t)i;
    }
    wpd_radix_sort_u64(k1, v1, n, 34, tk, tv);
    for (size_t i = 1; i < n; i++)
        CHECK_MSG(k1[i - 1] < k1[i] || (k1[i - 1] == k1[i] && v1[i - 1] < v1[i]),
                  "radix order broken at %zu", i);
    for (size_t i = 0; i < n; i++)
        CHECK(k1[i] == (v1[i] % 17 == 0 ? wpd_mix64(v1[i] / 2) >> 30 : wpd_mix64(v1[i]) >> 30) ||
              v1[i] % 17 == 0);
    free(k1); free(tk); free(v1); free(tv);
}

/* The threaded sort gives the sequential sort's pairs, for 1-4 threads and
 * odd and even numbers of passes (the result comes back from the scratch). */
TEST(core_radix_sort_threads_same_as_sequential)
{
    size_t n = WPD_SORT_PARALLEL_MIN + 12345;
    uint64_t *k1 = malloc(n * 8), *k2 = malloc(n * 8), *tk = malloc(n * 8);
    uint32_t *v1 = malloc(n * 4), *v2 = malloc(n * 4), *tv = malloc(n * 4);
    for (int bits = 20; bits <= 34; bits += 14)
        for (int threads = 1; threads <= 4; threads++) {
            for (size_t i = 0; i < n; i++) {
                uint64_t low = i % 3 ? 0 : 1; /* some keys repeated */
                k1[i] = k2[i] = (wpd_mix64(i) >> (64 - bits)) & ~low;
                v1[i] = v2[i] = (uint32_t)i;
            }
            wpd_radix_sort_u64(k1, v1, n, bits, tk, tv);
            wpd_radix_sort_u64_threads(k2, v2, n, bits, tk, tv, threads);
            size_t diff = 0;
            for (size_t i = 0; i < n; i++)
                diff += k1[i] != k2[i] || v1[i] != v2[i];
            CHECK_MSG(diff == 0, "%zu pairs differ (%d bits, %d threads)", diff, bits, threads);
        }
    free(k1); free(k2); free(tk); free(v1); free(v2); free(tv);
}

TEST(core_grid_holds_every_point_once_in_its_cell)
{
    size_t n = 4000;
    double *xyz = mixed_points(n, 1);
    wpd_grid g = {0};
    wpd_error err;
    CHECK(wpd_grid_build(&g, xyz, NULL, n, 0.7, 2, &err) == 0);
    uint8_t *seen = calloc(n, 1);
    for (size_t s = 0; s < g.n; s++) {
        CHECK(g.id[s] < n);
        seen[g.id[s]]++;
        CHECK(memcmp(g.xyz + 3 * s, xyz + 3 * (size_t)g.id[s], 24) == 0);
    }
    size_t once = 0;
    for (size_t i = 0; i < n; i++)
        once += seen[i] == 1;
    CHECK_MSG(once == n, "%zu of %zu points found exactly once", once, n);
    /* Each point lies in the slot range of its own cell. */
    for (size_t i = 0; i < n; i += 37) {
        int64_t c[3];
        for (int a = 0; a < 3; a++)
            c[a] = wpd_grid_coord(&g, a, xyz[3 * i + a]);
        uint32_t b, e;
        CHECK(wpd_grid_cell(&g, c[0], c[1], c[2], &b, &e));
        int found = 0;
        for (uint32_t s = b; s < e; s++)
            found |= g.id[s] == i;
        CHECK_MSG(found, "point %zu not in its cell", i);
    }
    /* Rebuilding into the same grid over a subset reuses it. */
    uint32_t subset[3] = {5, 900, 3999};
    CHECK(wpd_grid_build(&g, xyz, subset, 3, 2.0, 1, &err) == 0);
    CHECK(g.n == 3);
    wpd_grid_free(&g);
    free(seen);
    free(xyz);
}

TEST(core_knn_matches_brute_force)
{
    size_t n = 3000;
    double *xyz = mixed_points(n, 2);
    wpd_error err;
    double cells[3] = {0.05, 0.8, 40};
    int ks[3] = {1, 5, 13};
    uint64_t s = 3;
    for (int c = 0; c < 3; c++) {
        wpd_grid g = {0};
        CHECK(wpd_grid_build(&g, xyz, NULL, n, cells[c], 2, &err) == 0);
        for (int t = 0; t < 200; t++) {
            double q[3];
            uint32_t self = WPD_NO_SELF;
            if (t % 2) {
                self = (uint32_t)(unit(&s) * n);
                memcpy(q, xyz + 3 * self, sizeof q);
            } else {
                q[0] = 20 * unit(&s) - 5;
                q[1] = t % 10 == 0 ? 500 : 12 * unit(&s);
                q[2] = 6 * unit(&s) - 1;
            }
            int k = ks[t % 3];
            uint32_t idx[16], bidx[16];
            double d2[16], bd2[16];
            int bc;
            int got = wpd_knn(&g, q, k, self, INFINITY, t % 4 == 0 ? 0.01 : 0, idx, d2);
            brute_knn(xyz, n, q, k, self, bidx, bd2, &bc);
            CHECK_MSG(got == bc, "cell %g query %d: %d found, brute force %d", cells[c], t, got, bc);
            int same = got == bc;
            for (int j = 0; j < got && j < bc; j++)
                same &= idx[j] == bidx[j] && d2[j] == bd2[j];
            CHECK_MSG(same, "cell %g query %d (k %d): neighbours differ from brute force",
                      cells[c], t, k);
            /* Slots name the same points. */
            uint32_t slot[16];
            int gs = wpd_knn_slots(&g, q, k, self, INFINITY, 0, slot, NULL);
            CHECK(gs == got);
            for (int j = 0; j < gs && j < got; j++)
                CHECK(g.id[slot[j]] == idx[j]);
        }
        wpd_grid_free(&g);
    }
    /* max_dist limits the answer. */
    wpd_grid g = {0};
    CHECK(wpd_grid_build(&g, xyz, NULL, n, 0.5, 1, &err) == 0);
    double far[3] = {-100, -100, -100};
    uint32_t idx[4];
    CHECK(wpd_knn(&g, far, 4, WPD_NO_SELF, 10, 0, idx, NULL) == 0);
    wpd_grid_free(&g);
    free(xyz);
}

/* A hint is a guess of the k-th distance: the first box is scanned with
 * its bound there, and whatever the guess - far too small, the k-th
 * distance itself or a hair either side of it, far too large, beyond
 * max_dist - the answer is the brute force's, also where fewer than k
 * points exist at all (the box then holds the whole grid). */
TEST(core_knn_hints_never_change_the_answer)
{
    size_t n = 2000;
    double *xyz = mixed_points(n, 5);
    wpd_error err;
    uint64_t s = 9;
    for (int c = 0; c < 2; c++) {
        wpd_grid g = {0};
        size_t m = c ? 9 : n; /* 9 points: fewer than k = 13 */
        CHECK(wpd_grid_build(&g, xyz, NULL, m, c ? 3.0 : 0.6, 1, &err) == 0);
        for (int t = 0; t < 120; t++) {
            uint32_t self = (uint32_t)(unit(&s) * (double)m);
            const double *q = xyz + 3 * (size_t)self;
            int k = t % 2 ? 13 : 7;
            double max_dist = t % 5 == 0 ? 0.7 : INFINITY;
            uint32_t bidx[16];
            double bd2[16];
            int bc;
            brute_knn(xyz, m, q, k, self, bidx, bd2, &bc);
            while (bc > 0 && bd2[bc - 1] > max_dist * max_dist)
                bc--;
            double dk = bc ? sqrt(bd2[bc - 1]) : 1;
            double hints[] = {1e-6, 0.5 * dk, nextafter(dk, 0), dk, nextafter(dk, INFINITY),
                              3 * dk, 1e6};
            for (int h = 0; h < (int)(sizeof hints / sizeof *hints); h++) {
                uint32_t idx[16];
                double d2[16];
                int got = wpd_knn(&g, q, k, self, max_dist, hints[h], idx, d2);
                int same = got == bc;
                for (int j = 0; same && j < got; j++)
                    same = idx[j] == bidx[j] && d2[j] == bd2[j];
                CHECK_MSG(same, "grid %d query %d (k %d) hint %g: %d found, brute force %d",
                          c, t, k, hints[h], got, bc);
            }
        }
        wpd_grid_free(&g);
    }
    free(xyz);
}

TEST(core_knn_many_is_thread_independent)
{
    size_t n = 2000;
    double *xyz = mixed_points(n, 4);
    wpd_grid g = {0};
    wpd_error err;
    CHECK(wpd_grid_build(&g, xyz, NULL, n, 0.4, 2, &err) == 0);
    uint32_t *a = malloc(n * 8 * 4), *b = malloc(n * 8 * 4);
    uint8_t *ca = malloc(n), *cb = malloc(n);
    wpd_knn_many(&g, xyz, NULL, n, 8, INFINITY, a, NULL, ca, 1);
    wpd_knn_many(&g, xyz, NULL, n, 8, INFINITY, b, NULL, cb, 2);
    CHECK(memcmp(a, b, n * 8 * 4) == 0 && memcmp(ca, cb, n) == 0);
    free(a); free(b); free(ca); free(cb);
    wpd_grid_free(&g);
    free(xyz);
}

TEST(core_grid_handles_empty_and_single_point)
{
    wpd_grid g = {0};
    wpd_error err;
    double p[3] = {1e6, -2e6, 3};
    CHECK(wpd_grid_build(&g, p, NULL, 0, 1.0, 1, &err) == 0);
    uint32_t idx[2];
    CHECK(wpd_knn(&g, p, 2, WPD_NO_SELF, INFINITY, 0, idx, NULL) == 0);
    CHECK(wpd_grid_build(&g, p, NULL, 1, 1.0, 1, &err) == 0);
    CHECK(wpd_knn(&g, p, 2, WPD_NO_SELF, INFINITY, 0, idx, NULL) == 1 && idx[0] == 0);
    CHECK(wpd_knn(&g, p, 2, 0, INFINITY, 0, idx, NULL) == 0);
    wpd_grid_free(&g);
}

TEST(core_pca_fits_a_tilted_plane)
{
    /* Points on the plane with normal (1, 2, 2)/3 through (5, 5, 5), far from 0. */
    double n[3] = {1.0 / 3, 2.0 / 3, 2.0 / 3}, u[3], v[3];
    wpd_tangent_frame(n, u, v);
    double dot_uv = u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
    double dot_un = u[0] * n[0] + u[1] * n[1] + u[2] * n[2];
    CHECK(fabs(dot_uv) < 1e-12 && fabs(dot_un) < 1e-12);
    /* right-handed: u x v = n */
    CHECK(fabs(u[1] * v[2] - u[2] * v[1] - n[0]) < 1e-12);
    double pts[3 * 40];
    uint64_t s = 5;
    for (int i = 0; i < 40; i++) {
        double a = unit(&s) - 0.5, b = unit(&s) - 0.5;
        for (int k = 0; k < 3; k++)
            pts[3 * i + k] = 1e6 + a * u[k] + b * v[k];
    }
    wpd_plane pl;
    wpd_plane_fit(pts, NULL, 40, &pl);
    double c = fabs(pl.normal[0] * n[0] + pl.normal[1] * n[1] + pl.normal[2] * n[2]);
    CHECK_MSG(c > 1 - 1e-9, "normal off by %g", 1 - c);
    CHECK(pl.variation < 1e-9);
    double q[3] = {1e6 + 3 * n[0], 1e6 + 3 * n[1], 1e6 + 3 * n[2]}, out[3];
    wpd_plane_project(&pl, q, out);
    CHECK(fabs(out[0] - 1e6) < 1e-6 && fabs(out[1] - 1e6) < 1e-6 && fabs(out[2] - 1e6) < 1e-6);
    /* An isotropic cloud has variation near 1/3. */
    double blob[3 * 8] = {1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 0, 0, 0};
    wpd_plane_fit(blob, NULL, 8, &pl);
    CHECK(fabs(pl.variation - 1.0 / 3) < 1e-9);
}

TEST(core_eigen_of_symmetric_matrices)
{
    double a[6] = {4, 1, 0, 3, 0, 2}, ev[3], vec[3][3];
    wpd_sym3_eigen(a, ev, vec);
    CHECK(ev[0] <= ev[1] && ev[1] <= ev[2]);
    CHECK(fabs(ev[0] - 2) < 1e-12);
    CHECK(fabs(ev[0] + ev[1] + ev[2] - 9) < 1e-12);
    for (int i = 0; i < 3; i++) { /* A v = lambda v */
        const double *x = vec[i];
        double r0 = 4 * x[0] + 1 * x[1] - ev[i] * x[0];
        double r1 = 1 * x[0] + 3 * x[1] - ev[i] * x[1];
        double r2 = 2 * x[2] - ev[i] * x[2];
        CHECK(fabs(r0) + fabs(r1) + fabs(r2) < 1e-12);
    }
}

TEST(core_voronoi_of_a_hexagonal_neighbourhood)
{
    /* Rings of a hexagonal lattice of spacing 1 around the origin. */
    double q[2 * 18];
    int m = 0;
    for (int i = 0; i < 6; i++) {
        double a = M_PI / 3 * i, b = a + M_PI / 6;
        q[2 * m] = cos(a); q[2 * m + 1] = sin(a); m++;
        q[2 * m] = sqrt(3) * cos(b); q[2 * m + 1] = sqrt(3) * sin(b); m++;
        q[2 * m] = 2 * cos(a); q[2 * m + 1] = 2 * sin(a); m++;
    }
    wpd_voronoi_cell cell;
    wpd_voronoi_cell_2d(q, m, 0, &cell);
    CHECK(cell.closed);
    CHECK_MSG(fabs(cell.area - sqrt(3) / 2) < 1e-12, "area %.15g", cell.area);
    for (int j = 0; j < m; j++) {
        double want = j % 3 == 0 ? 1 / sqrt(3) : 0; /* first ring only */
        CHECK_MSG(fabs(cell.edge[j] - want) < 1e-12, "edge %d = %g, want %g", j, cell.edge[j], want);
        /* cotangent weight (cot 60 + cot 60) / 2 = edge / |q| */
        if (j % 3 == 0)
            CHECK(fabs(cell.edge[j] / 1.0 - 0.5 * (2 / tan(M_PI / 3))) < 1e-12);
    }
    CHECK(fabs(cell.centroid[0]) < 1e-12 && fabs(cell.centroid[1]) < 1e-12);
    CHECK(cell.nverts == 6);
    /* Move the point 0.1 off its lattice site: the cell's centroid points
     * back towards the site, and the closed cell's edges weighted by the
     * cotangent weights sum to zero (eq. 8 would not move it: voronoi.h). */
    double shifted[2 * 18];
    for (int j = 0; j < m; j++) {
        shifted[2 * j] = q[2 * j] - 0.1;
        shifted[2 * j + 1] = q[2 * j + 1];
    }
    wpd_voronoi_cell_2d(shifted, m, 0, &cell);
    CHECK(cell.closed);
    double sx = 0, sy = 0;
    for (int j = 0; j < m; j++) {
        double len = hypot(shifted[2 * j], shifted[2 * j + 1]);
        sx += cell.edge[j] * shifted[2 * j] / len;
        sy += cell.edge[j] * shifted[2 * j + 1] / len;
    }
    CHECK_MSG(fabs(sx) < 1e-12 && fabs(sy) < 1e-12, "edge normals sum (%g, %g)", sx, sy);
    CHECK_MSG(cell.centroid[0] < -0.04 && fabs(cell.centroid[1]) < 1e-12, "centroid (%g, %g)",
              cell.centroid[0], cell.centroid[1]);
}

TEST(core_voronoi_cell_on_a_border_is_open)
{
    /* All neighbours on one side (x > 0): the cell reaches the frame. */
    double q[2 * 5] = {1, 0, 1, 1, 1, -1, 2, 0.5, 0.5, 0.2};
    wpd_voronoi_cell cell;
    wpd_voronoi_cell_2d(q, 5, 0, &cell);
    CHECK(!cell.closed);
    /* Coincident neighbours are ignored, not divided by. */
    double same[2 * 4] = {0, 0, 1, 0, -1, 0.1, 0, 1};
    wpd_voronoi_cell_2d(same, 4, 0, &cell);
    CHECK(cell.edge[0] == 0);
}

TEST(core_calloc_large_is_zeroed_and_checks_overflow)
{
    /* Above the huge-page threshold the memory is advised, then zeroed by
     * hand: it must read as zero like calloc's. */
    size_t count = WPD_HUGE_MIN / sizeof(double) + 1000;
    double *a = wpd_calloc_large(count, sizeof *a);
    CHECK(a != NULL);
    int zero = 1;
    for (size_t i = 0; a && i < count; i += 997)
        zero &= a[i] == 0;
    CHECK(zero && a && a[count - 1] == 0);
    free(a);
    uint8_t *small = wpd_calloc_large(16, 1);
    CHECK(small != NULL && small[15] == 0);
    free(small);
    CHECK(wpd_calloc_large(SIZE_MAX / 2, 4) == NULL);
}
