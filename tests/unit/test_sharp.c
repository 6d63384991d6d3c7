/* test_sharp.c - sharp-feature labels on capped neighbourhoods: a point's
 * label depends only on the points within the cap, so a block labels its
 * points (and its inner halo) as the whole cloud does. */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "clouds.h"
#include "core/grid.h"
#include "core/knn.h"
#include "harness.h"
#include "wpd/sharp.h"

#define SHARP_K 13

static void detect(const double *xyz, size_t n, double cap, int threads, uint8_t *edge)
{
    wpd_grid g = {0};
    wpd_error err;
    if (wpd_grid_build_knn(&g, xyz, NULL, n, SHARP_K, 0.5, threads, &err) == 0)
        wpd_detect_sharp_capped(&g, 0, n, SHARP_K, cap, WPD_SHARP_THRESHOLD, edge, threads);
    wpd_grid_free(&g);
}

TEST(sharp_capped_labels_depend_only_on_the_points_within_cap)
{
    for (int kind = 0; kind < NKINDS; kind++) {
        cloud c = make_cloud(kind, 4000, 5);
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
        CHECK_MSG(memcmp(a, b, n) == 0, "%s: labels depend on the threads", kind_name[kind]);
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
        CHECK_MSG(moved == 0, "%s: %zu labels change with the point order", kind_name[kind], moved);
        /* Blocks: own points first, then the halo within H; labels exact
         * for every point closer than H - cap to the box. */
        double H = 2.5, cap = 1.0;
        size_t wrong = 0, checked = 0;
        for (int t = 0; t < 4; t++) {
            box bx;
            for (int k = 0; k < 3; k++) {
                bx.lo[k] = (kind == BLOB ? -4 : 0) + 6 * unit(&st);
                bx.hi[k] = bx.lo[k] + 2 + 6 * unit(&st);
            }
            if (kind != BLOB) { /* across the plane or the lattice's slab */
                bx.lo[2] = -1;
                bx.hi[2] = 0.2 + 2 * unit(&st);
            }
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
            CHECK(wpd_grid_build_knn(&g, shuffled, NULL, m, SHARP_K, 0.5, 2, &err) == 0);
            /* Own points and the halo separately: the range form. */
            memset(blk, 7, m);
            wpd_detect_sharp_capped(&g, 0, nown, SHARP_K, cap, WPD_SHARP_THRESHOLD, blk, 2);
            wpd_detect_sharp_capped(&g, nown, m, SHARP_K, cap, WPD_SHARP_THRESHOLD, blk, 2);
            wpd_grid_free(&g);
            for (size_t j = 0; j < m; j++) {
                CHECK(blk[j] <= 1);
                if (box_dist(&bx, shuffled + 3 * j) < H - cap) {
                    checked++;
                    wrong += blk[j] != a[perm[j]];
                }
            }
        }
        CHECK_MSG(wrong == 0 && checked > 100, "%s: %zu of %zu block labels differ",
                  kind_name[kind], wrong, checked);
        CHECK_MSG(kind == PLANE || sharp > 0, "%s: no sharp point", kind_name[kind]);
        free(a); free(b); free(p); free(blk); free(shuffled); free(perm);
        cloud_free(&c);
    }
}

TEST(sharp_capped_needs_five_points_and_matches_the_uncapped_detector)
{
    /* A lone tetrahedron of 4 points (variation well above the threshold)
     * and a lone cluster of 6: with cap 1, only the cluster can be sharp. */
    double xyz[3 * 10] = {0, 0, 0, 0.3, 0, 0, 0, 0.3, 0, 0, 0, 0.3,
                          10, 10, 10, 10.3, 10, 10, 10, 10.3, 10, 10, 10, 10.3,
                          10.3, 10.3, 10, 10, 10.3, 10.3};
    uint8_t e[10];
    detect(xyz, 10, 1.0, 1, e);
    CHECK(e[0] == 0 && e[1] == 0 && e[2] == 0 && e[3] == 0);
    CHECK(e[4] == 1 && e[9] == 1);
    /* With no cap and no equal distances, the same neighbours in the same
     * order as wpd_detect_sharp: the same labels. */
    cloud c = make_cloud(BLOB, 3000, 8);
    uint8_t *a = malloc(c.n), *b = malloc(c.n);
    wpd_grid g = {0};
    wpd_error err;
    CHECK(wpd_grid_build_knn(&g, c.xyz, NULL, c.n, SHARP_K, 0.5, 2, &err) == 0);
    wpd_detect_sharp(&g, c.n, SHARP_K, WPD_SHARP_THRESHOLD, a, 2);
    wpd_detect_sharp_capped(&g, 0, c.n, SHARP_K, INFINITY, WPD_SHARP_THRESHOLD, b, 2);
    wpd_grid_free(&g);
    CHECK(memcmp(a, b, c.n) == 0);
    free(a);
    free(b);
    cloud_free(&c);
}
