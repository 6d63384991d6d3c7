/* test_metrics.c - the quality measures of tools/metrics.c on clouds whose
 * answers are known: identical and shifted clouds, perfect and jittered
 * hexagonal lattices (placed on a tilted plane far from the origin, as
 * georeferenced data is), degenerate clouds, and the authors' sample pair. */
#include "harness.h"
#include "tools/metrics/metrics.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* A tilted plane: origin far from 0, orthonormal in-plane axes e1, e2 and
 * normal nrm = e1 x e2. */
static const double plane_origin[3] = {512345.25, 4918000.5, 2330.0};
static const double e1[3] = {0.8, 0.6, 0.0};
static const double e2[3] = {-0.36, 0.48, 0.8};
static const double nrm[3] = {0.48, -0.64, 0.6};

/* Deterministic uniform numbers in [-1, 1). */
static double jitter(uint64_t *state)
{
    *state = *state * 6364136223846793005ULL + 1442695040888963407ULL;
    return (double)(*state >> 11) / (double)(1ULL << 52) - 1.0;
}

/* rows x cols hexagonal lattice of spacing s on the tilted plane, each point
 * moved in the plane by up to amp * s (amp 0: perfect) and by `lift` along
 * the normal. The patch is a parallelogram spanned by two lattice directions,
 * so every side is a straight lattice row: the cells of its outer ring are
 * open and every closed cell is a regular hexagon (a rectangular patch would
 * have zigzag sides whose cells are closed but larger). Returns a malloc'd
 * array of 3 * rows * cols doubles. */
static double *hex_lattice(int rows, int cols, double s, double amp, double lift)
{
    double *xyz = malloc((size_t)rows * cols * 3 * sizeof *xyz);
    uint64_t state = 12345;
    size_t k = 0;
    for (int j = 0; j < rows; j++)
        for (int i = 0; i < cols; i++, k++) {
            double x = (i + 0.5 * j) * s + amp * s * jitter(&state);
            double y = j * s * sqrt(3.0) / 2 + amp * s * jitter(&state);
            for (int a = 0; a < 3; a++)
                xyz[3 * k + a] = plane_origin[a] + x * e1[a] + y * e2[a] + lift * nrm[a];
        }
    return xyz;
}

TEST(metrics_identical_clouds_have_zero_distances)
{
    double *p = hex_lattice(30, 30, 0.05, 0.2, 0);
    wpd_metrics m;
    wpd_error err = {0};
    CHECK(wpd_metrics_compute(p, 900, p, 900, 0, &m, &err) == 0);
    CHECK(m.original_points == 900 && m.resampled_points == 900);
    CHECK(m.to_original.max == 0 && m.to_resampled.max == 0 && m.hausdorff == 0);
    CHECK(m.to_original.mean == 0 && m.to_resampled.mean == 0);
    CHECK_MSG(m.nn.min > 0.01, "d_min %g", m.nn.min);
    free(p);
}

TEST(metrics_shift_along_normal_gives_hausdorff_d)
{
    const double d = 0.3;
    double *o = hex_lattice(25, 40, 1.0, 0, 0);
    double *r = hex_lattice(25, 40, 1.0, 0, d);
    wpd_metrics m;
    wpd_error err = {0};
    CHECK(wpd_metrics_compute(o, 1000, r, 1000, 0, &m, &err) == 0);
    CHECK_MSG(fabs(m.hausdorff - d) < 1e-6, "hausdorff %.12g", m.hausdorff);
    CHECK_MSG(fabs(m.to_original.max - d) < 1e-6, "%.12g", m.to_original.max);
    CHECK_MSG(fabs(m.to_resampled.max - d) < 1e-6, "%.12g", m.to_resampled.max);
    CHECK_MSG(fabs(m.to_original.mean - d) < 1e-6, "%.12g", m.to_original.mean);
    double diag = m.bbox_diagonal;
    CHECK_MSG(diag > 45 && diag < 80, "diagonal %g", diag);
    free(o);
    free(r);
}

TEST(metrics_hexagonal_lattice_is_perfectly_uniform)
{
    const double s = 0.7;
    double *p = hex_lattice(40, 40, s, 0, 0);
    wpd_metrics m;
    wpd_error err = {0};
    CHECK(wpd_metrics_compute(p, 1600, p, 1600, 0, &m, &err) == 0);
    /* interior cells are regular hexagons; the outer rings are open */
    CHECK_MSG(m.voronoi.count > 1300 && m.voronoi.count < 1600, "closed %llu",
              (unsigned long long)m.voronoi.count);
    CHECK(m.voronoi_skipped == 1600 - m.voronoi.count);
    CHECK_MSG(m.voronoi.cv < 1e-6, "voronoi cv %g", m.voronoi.cv);
    CHECK_MSG(fabs(m.voronoi.mean - sqrt(3.0) / 2 * s * s) < 1e-6, "area %.12g", m.voronoi.mean);
    CHECK_MSG(fabs(m.nn.min - s) < 1e-6, "d_min %.12g", m.nn.min);
    CHECK_MSG(fabs(m.poisson_radius - 1) < 1e-6, "rho %.12g", m.poisson_radius);
    CHECK_MSG(fabs(m.surface_area - 1600 * sqrt(3.0) / 2 * s * s) < 1e-3, "A %g",
              m.surface_area);
    free(p);
}

TEST(metrics_jitter_raises_density_errors)
{
    double *perfect = hex_lattice(40, 40, 1.0, 0, 0);
    double *jittered = hex_lattice(40, 40, 1.0, 0.15, 0);
    wpd_metrics mp, mj;
    wpd_error err = {0};
    CHECK(wpd_metrics_compute(perfect, 1600, perfect, 1600, 0, &mp, &err) == 0);
    CHECK(wpd_metrics_compute(perfect, 1600, jittered, 1600, 0, &mj, &err) == 0);
    CHECK_MSG(mj.voronoi.cv > mp.voronoi.cv + 0.02, "cv %g vs %g", mj.voronoi.cv,
              mp.voronoi.cv);
    CHECK(mj.voronoi.range > mp.voronoi.range);
    CHECK(mj.local.cv > mp.local.cv);
    CHECK_MSG(mj.poisson_radius < 0.95, "rho %g", mj.poisson_radius);
    CHECK(mj.hausdorff > 0 && mj.hausdorff < 0.5);
    free(perfect);
    free(jittered);
}

static double dist(const double *a, const double *b)
{
    return sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
                (a[2] - b[2]) * (a[2] - b[2]));
}

/* Distances and local density against a brute-force O(n^2) evaluation on
 * random points scattered around a curved sheet. */
TEST(metrics_match_brute_force)
{
    enum { NO = 500, NR = 160 };
    static double o[3 * NO], r[3 * NR];
    uint64_t state = 99;
    for (int i = 0; i < NO + NR; i++) {
        double *p = i < NO ? o + 3 * i : r + 3 * (i - NO);
        double x = 10 * jitter(&state), y = 10 * jitter(&state);
        p[0] = 7e5 + x;
        p[1] = 4e6 + y;
        p[2] = 300 + 0.05 * x * x + 0.3 * jitter(&state);
    }
    wpd_metrics m;
    wpd_error err = {0};
    CHECK(wpd_metrics_compute(o, NO, r, NR, 0, &m, &err) == 0);
    double h_ro = 0, h_or = 0, s_ro = 0, s_or = 0, dmin = INFINITY;
    double lmin = INFINITY, lmax = 0, lsum = 0;
    for (int i = 0; i < NR; i++) {
        double best = INFINITY;
        for (int j = 0; j < NO; j++)
            best = fmin(best, dist(r + 3 * i, o + 3 * j));
        h_ro = fmax(h_ro, best);
        s_ro += best;
        double nb[NR];
        int c = 0;
        for (int j = 0; j < NR; j++)
            if (j != i)
                nb[c++] = dist(r + 3 * i, r + 3 * j);
        double mean6 = 0;
        for (int t = 0; t < 6; t++) { /* selection of the 6 smallest */
            int best_j = t;
            for (int j = t + 1; j < c; j++)
                if (nb[j] < nb[best_j])
                    best_j = j;
            double tmp = nb[t];
            nb[t] = nb[best_j];
            nb[best_j] = tmp;
            mean6 += nb[t] / 6;
        }
        dmin = fmin(dmin, nb[0]);
        lmin = fmin(lmin, mean6);
        lmax = fmax(lmax, mean6);
        lsum += mean6;
    }
    for (int j = 0; j < NO; j++) {
        double best = INFINITY;
        for (int i = 0; i < NR; i++)
            best = fmin(best, dist(r + 3 * i, o + 3 * j));
        h_or = fmax(h_or, best);
        s_or += best;
    }
    CHECK_MSG(fabs(m.to_original.max - h_ro) < 1e-9, "%.12g vs %.12g", m.to_original.max, h_ro);
    CHECK_MSG(fabs(m.to_resampled.max - h_or) < 1e-9, "%.12g vs %.12g", m.to_resampled.max, h_or);
    CHECK(fabs(m.to_original.mean - s_ro / NR) < 1e-9);
    CHECK(fabs(m.to_resampled.mean - s_or / NO) < 1e-9);
    CHECK(fabs(m.nn.min - dmin) < 1e-9);
    CHECK_MSG(fabs(m.local.range - (lmax - lmin)) < 1e-9, "%.12g vs %.12g", m.local.range,
              lmax - lmin);
    CHECK(fabs(m.local.mean - lsum / NR) < 1e-9);
}

TEST(metrics_result_does_not_depend_on_threads)
{
    double *o = hex_lattice(60, 50, 1.0, 0.3, 0);
    double *r = hex_lattice(30, 25, 2.0, 0.3, 0.1);
    wpd_metrics a, b;
    wpd_error err = {0};
    CHECK(wpd_metrics_compute(o, 3000, r, 750, 1, &a, &err) == 0);
    CHECK(wpd_metrics_compute(o, 3000, r, 750, 4, &b, &err) == 0);
    CHECK(memcmp(&a, &b, sizeof a) == 0);
    free(o);
    free(r);
}

TEST(metrics_tiny_and_empty_clouds)
{
    const double one[3] = {1e6, 2e6, 5}, other[3] = {1e6 + 3, 2e6 + 4, 5};
    wpd_metrics m;
    wpd_error err = {0};
    CHECK(wpd_metrics_compute(one, 1, one, 1, 0, &m, &err) == 0);
    CHECK(m.hausdorff == 0 && m.bbox_diagonal == 0);
    CHECK(m.local.count == 0 && isnan(m.local.mean));
    CHECK(m.voronoi.count == 0 && m.voronoi_skipped == 1);
    CHECK(isnan(m.nn.min) && isnan(m.poisson_radius));
    CHECK(wpd_metrics_compute(one, 1, other, 1, 0, &m, &err) == 0);
    CHECK_MSG(fabs(m.hausdorff - 5) < 1e-9, "%g", m.hausdorff);
    double *p = hex_lattice(1, 3, 1.0, 0, 0); /* collinear: no closed cell */
    CHECK(wpd_metrics_compute(p, 3, p, 3, 0, &m, &err) == 0);
    CHECK(m.local.count == 3 && m.voronoi.count == 0 && isnan(m.surface_area));
    free(p);
    CHECK(wpd_metrics_compute(one, 1, one, 0, 0, &m, &err) == -1);
    CHECK(err.code == WPD_E_INPUT && strstr(err.msg, "resampled"));
}

TEST(metrics_load_reads_ply)
{
    char path[512];
    snprintf(path, sizeof path, "%s/metrics.ply", test_tmp_dir());
    FILE *f = fopen(path, "w");
    CHECK(f != NULL);
    if (!f)
        return;
    fputs("ply\nformat ascii 1.0\nelement vertex 3\nproperty double x\nproperty double y\n"
          "property double z\nend_header\n1 2 3\n4 5 6\n7 8 9\n", f);
    fclose(f);
    double *xyz;
    size_t n;
    wpd_error err = {0};
    CHECK(wpd_metrics_load(path, &xyz, &n, &err) == 0);
    CHECK(n == 3 && xyz[0] == 1 && xyz[8] == 9);
    free(xyz);
    snprintf(path, sizeof path, "%s/metrics-missing.ply", test_tmp_dir());
    CHECK(wpd_metrics_load(path, &xyz, &n, &err) == -1 && strstr(err.msg, "metrics-missing"));
}

/* The authors' sample pair: only sanity here; the figures are in the report. */
TEST(metrics_conference_room_sample)
{
    const char *dir = test_data_dir();
    if (!dir)
        return;
    char in[512], out[512];
    snprintf(in, sizeof in, "%s/scans/wpd_conferenceRoom_1_input.ply", dir);
    snprintf(out, sizeof out, "%s/scans/wpd_conferenceRoom_1_output_2000.ply", dir);
    double *o, *r;
    size_t no, nr;
    wpd_error err = {0};
    if (wpd_metrics_load(in, &o, &no, &err))
        return;
    if (wpd_metrics_load(out, &r, &nr, &err) == 0) {
        wpd_metrics m;
        CHECK(wpd_metrics_compute(o, no, r, nr, 0, &m, &err) == 0);
        CHECK(no == 20000 && nr == 2000);
        CHECK(m.hausdorff > 0 && m.hausdorff < m.bbox_diagonal);
        CHECK(m.voronoi.count > 1000 && m.poisson_radius > 0 && m.poisson_radius < 1);
        free(r);
    }
    free(o);
}

TEST(metrics_cli_usage_errors)
{
    char *help[] = {"metrics", "--help", NULL};
    char *bad[] = {"metrics", "only-one.ply", NULL};
    FILE *saved = stdout, *null = fopen("/dev/null", "w");
    if (null) {
        stdout = null; /* keep the usage text out of the log */
        CHECK(wpd_metrics_main(2, help) == 0);
        stdout = saved;
        fclose(null);
    }
    CHECK(wpd_metrics_main(2, bad) == 1);
}
