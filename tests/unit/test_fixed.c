/* test_fixed.c - a run that keeps an earlier run's samples fixed (a
 * collection's later night, resample.h: fixed_radius, density_factor,
 * fixed_xyz): the left half of a scene, then the right half at the left
 * half's radius with the left's samples near the seam fixed. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "core/hash.h"
#include "harness.h"
#include "io/cloud.h"
#include "resample/resample.h"
#include "spill/run_merge.h"

static double unit(uint64_t *state)
{
    *state = wpd_mix64(*state + 0x9e3779b97f4a7c15ULL);
    return (double)(*state >> 11) * 0x1p-53;
}

/* A jittered, gently rolling terrain over x in [x0, x1), y in [0, 40). */
static size_t terrain(double x0, double x1, double spacing, uint64_t seed, double **xyz)
{
    size_t cap = (size_t)((x1 - x0) / spacing + 2) * (size_t)(40 / spacing + 2), n = 0;
    *xyz = malloc(3 * cap * sizeof **xyz);
    uint64_t st = seed;
    for (double y = 0; y < 40; y += spacing)
        for (double x = x0; x < x1 && n < cap; x += spacing, n++) {
            double *p = *xyz + 3 * n;
            p[0] = x + 0.3 * spacing * (unit(&st) - 0.5);
            p[1] = y + 0.3 * spacing * (unit(&st) - 0.5);
            p[2] = 0.5 * sin(p[0] / 7) + 0.3 * cos(p[1] / 5);
        }
    return n;
}

/* Resamples the n points of xyz (written as a PLY file) with o. The
 * samples come back in global-index order in *out (3 x count doubles). */
static int resample(const double *xyz, size_t n, wpd_resample_options *o, wpd_resample_result *r,
                    double **out)
{
    char path[1100];
    snprintf(path, sizeof path, "%s/fixed-cloud.ply", test_tmp_dir());
    FILE *f = fopen(path, "wb");
    if (!f)
        return -1;
    fprintf(f, "ply\nformat binary_little_endian 1.0\nelement vertex %zu\nproperty double x\n"
               "property double y\nproperty double z\nend_header\n", n);
    fwrite(xyz, 3 * sizeof(double), n, f);
    fclose(f);
    wpd_error err = {0};
    const char *paths[1] = {path};
    wpd_cloud *cloud = wpd_cloud_open(paths, 1, &err);
    o->mem_bytes = (size_t)1 << 30;
    o->tmpdir = test_tmp_dir();
    int rc = cloud ? wpd_resample_run(cloud, o, r, &err) : -1;
    wpd_cloud_close(cloud);
    unlink(path);
    if (rc) {
        fprintf(stderr, "  wpd_resample_run: %s\n", err.msg);
        return -1;
    }
    wpd_run_merge *m;
    *out = malloc((r->count ? r->count : 1) * 3 * sizeof **out);
    if (!*out || wpd_run_merge_open(r->samples, WPD_RUN_MERGE_BUDGET, &m, &err))
        return -1;
    size_t got = 0;
    for (wpd_sample_view v; wpd_run_merge_next(m, UINT64_MAX, &v, &err) == 0 && v.n;) {
        if (got + v.n > r->count)
            break;
        memcpy(*out + 3 * got, v.xyz, 3 * v.n * sizeof **out);
        got += v.n;
    }
    wpd_run_merge_close(m);
    return got == r->count ? 0 : -1;
}

/* The smallest distance from a point of a to a point of b. */
static double closest(const double *a, size_t na, const double *b, size_t nb)
{
    double best = INFINITY;
    for (size_t i = 0; i < na; i++)
        for (size_t j = 0; j < nb; j++) {
            const double *p = a + 3 * i, *q = b + 3 * j;
            double d = hypot(hypot(p[0] - q[0], p[1] - q[1]), p[2] - q[2]);
            best = d < best ? d : best;
        }
    return best;
}

TEST(fixed_samples_of_an_earlier_night_join_without_a_seam)
{
    double *left, *right, *s1 = NULL;
    size_t nl = terrain(0, 30, 0.4, 11, &left), nr = terrain(30, 60, 0.4, 12, &right);
    wpd_resample_options o = {.target = 800};
    wpd_params_default(&o.params);
    o.params.smooth = 0;
    wpd_resample_result first;
    CHECK(resample(left, nl, &o, &first, &s1) == 0);
    double r = first.radius, f = (double)first.count / (double)first.poisson_count;
    /* The left samples within reach (3 r) of the right half, fixed. */
    double *fixed = malloc(3 * first.count * sizeof *fixed);
    size_t nfixed = 0;
    for (size_t i = 0; i < first.count; i++)
        if (s1[3 * i] >= 30 - 3 * r)
            memcpy(fixed + 3 * nfixed++, s1 + 3 * i, 3 * sizeof *fixed);
    CHECK(nfixed > 10);
    double *s2[3] = {NULL, NULL, NULL};
    size_t count[3] = {0, 0, 0};
    for (int k = 0; k < 3; k++) { /* in memory, 4 tiles; then smoothed in 4 tiles */
        wpd_resample_options o2 = {.target = 5, .fixed_radius = r, .density_factor = f,
                                   .fixed_xyz = fixed, .nfixed = nfixed, .min_tiles = k ? 4 : 0};
        wpd_params_default(&o2.params);
        o2.params.smooth = k == 2;
        wpd_resample_result second;
        CHECK(resample(right, nr, &o2, &second, &s2[k]) == 0);
        count[k] = second.count;
        /* density wins over the count: round(f x the pass), one pass at r */
        CHECK_MSG(second.count == (size_t)nearbyint(f * (double)second.poisson_count) &&
                      second.passes == 1 && second.radius == r,
                  "%zu of %zu kept, %d passes, radius %g (r %g)", second.count,
                  second.poisson_count, second.passes, second.radius, r);
        double gap = closest(s2[k], second.count, fixed, nfixed);
        /* the Poisson pass keeps r from the fixed samples; smoothing's
         * guard 0.82 r */
        CHECK_MSG(gap >= (k == 2 ? 0.82 : 1.0) * r * (1 - 1e-12), "run %d: a sample %g from "
                  "a fixed one (r %g)", k, gap, r);
        wpd_resample_result_free(&second);
    }
    CHECK_MSG(count[0] == count[1] && memcmp(s2[0], s2[1], 3 * count[0] * sizeof(double)) == 0,
              "4 tiles give other samples than one block (%zu / %zu)", count[0], count[1]);
    /* Density, not the count: as many per unit area as the left half has. */
    CHECK_MSG(fabs((double)count[0] / (double)first.count - 1) < 0.06, "%zu right, %zu left",
              count[0], first.count);
    for (int k = 0; k < 3; k++)
        free(s2[k]);
    wpd_resample_result_free(&first);
    free(fixed), free(s1), free(left), free(right);
}
