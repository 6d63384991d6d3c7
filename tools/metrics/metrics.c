/* metrics.c - the paper's quality measures of a resampled cloud against its
 * original (formulas in metrics.h). */
#include "tools/metrics/metrics.h"

#include "common/json.h"
#include "common/outfile.h"
#include "core/grid.h"
#include "core/knn.h"
#include "core/pca.h"
#include "core/voronoi.h"
#include "io/cloud.h"
#include "io/reader.h"

#include <getopt.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Queries are answered in chunks so that the neighbour lists of a billion
 * points never have to exist at once. */
#define CHUNK 65536

/* ---- statistics ---- */

/* Running count, min, max, mean and squared deviation (Welford: exact enough
 * for a CV near 0 where sum-of-squares would cancel). Fed serially, in point
 * order, so the result is independent of the thread count. */
typedef struct accumulator {
    uint64_t n;
    double min, max, mean, m2;
} accumulator;

static void acc_init(accumulator *a)
{
    a->n = 0;
    a->min = INFINITY;
    a->max = -INFINITY;
    a->mean = a->m2 = 0;
}

static void acc_add(accumulator *a, double x)
{
    a->n++;
    if (x < a->min)
        a->min = x;
    if (x > a->max)
        a->max = x;
    double delta = x - a->mean;
    a->mean += delta / (double)a->n;
    a->m2 += delta * (x - a->mean);
}

static void acc_finish(const accumulator *a, wpd_metrics_stats *s)
{
    s->count = a->n;
    if (a->n == 0) {
        s->min = s->max = s->range = s->mean = s->std = s->cv = NAN;
        return;
    }
    s->min = a->min;
    s->max = a->max;
    s->range = a->max - a->min;
    s->mean = a->mean;
    s->std = sqrt(a->m2 > 0 ? a->m2 / (double)a->n : 0);
    s->cv = s->std / s->mean; /* NaN for 0/0 (all distances zero) */
    if (s->std == 0)
        s->cv = 0;
}

/* ---- grids ---- */

static void extent_of(const double *xyz, size_t n, double ext[3])
{
    wpd_bounds b;
    wpd_bounds_reset(&b);
    wpd_bounds_add(&b, xyz, n);
    for (int a = 0; a < 3; a++)
        ext[a] = n ? b.max[a] - b.min[a] : 0;
}

/* Builds a grid over the n points with about 8 points per occupied cell, so
 * that a 12-NN query is usually answered by the 27 cells around it. The first
 * guess assumes a surface as large as half the bounding box's surface; the
 * cell is then rescaled from the observed occupancy (a surface's occupancy
 * grows with cell^2). */
static int build_grid(wpd_grid *g, const double *xyz, size_t n, int threads, wpd_error *err)
{
    double ext[3];
    extent_of(xyz, n, ext);
    double area = ext[0] * ext[1] + ext[1] * ext[2] + ext[0] * ext[2];
    double longest = fmax(ext[0], fmax(ext[1], ext[2]));
    if (!(area > 0))
        area = longest * longest;
    double cell = area > 0 ? 2.8 * sqrt(area / (double)n) : 1.0;
    if (!(cell > 0) || !isfinite(cell))
        cell = 1.0;
    for (int attempt = 0;; attempt++) {
        if (wpd_grid_build(g, xyz, NULL, n, cell, threads, err))
            return -1;
        double per_cell = (double)n / (double)(g->nruns ? g->nruns : 1);
        if (attempt == 3 || (per_cell >= 3 && per_cell <= 24) || n < 64)
            return 0;
        double next = cell * sqrt(8.0 / per_cell);
        if (!(next > 0) || !isfinite(next) || (longest > 0 && next > 4 * longest))
            return 0;
        wpd_grid_free(g);
        cell = next;
    }
}

/* ---- per-point measures of the resampled cloud ---- */

/* Area of r_i's Voronoi cell among its cnt neighbours nb[] projected on its
 * PCA tangent plane; NaN when the cell is open or there are too few
 * neighbours. */
static double voronoi_area(const double *res, uint32_t i, const uint32_t *nb, int cnt)
{
    if (cnt < 3)
        return NAN;
    uint32_t idx[WPD_METRICS_K_VORONOI + 1];
    idx[0] = i; /* first: the plane fit works relative to idx[0] */
    memcpy(idx + 1, nb, (size_t)cnt * sizeof *nb);
    wpd_plane pl;
    wpd_plane_fit(res, idx, cnt + 1, &pl);
    double u[3], v[3];
    wpd_tangent_frame(pl.normal, u, v);
    const double *p = res + 3 * (size_t)i;
    double q[2 * WPD_METRICS_K_VORONOI];
    for (int j = 0; j < cnt; j++) {
        const double *x = res + 3 * (size_t)nb[j];
        double d[3] = {x[0] - p[0], x[1] - p[1], x[2] - p[2]};
        q[2 * j] = d[0] * u[0] + d[1] * u[1] + d[2] * u[2];
        q[2 * j + 1] = d[0] * v[0] + d[1] * v[1] + d[2] * v[2];
    }
    wpd_voronoi_cell cell;
    wpd_voronoi_cell_2d(q, cnt, 0, &cell);
    return cell.closed ? cell.area : NAN;
}

/* Mean distance to the first min(cnt, k_local) neighbours; NaN without any. */
static double local_mean(const double *d2, int cnt)
{
    int k = cnt < WPD_METRICS_K_LOCAL ? cnt : WPD_METRICS_K_LOCAL;
    if (k == 0)
        return NAN;
    double s = 0;
    for (int j = 0; j < k; j++)
        s += sqrt(d2[j]);
    return s / k;
}

/* Buffers for one chunk of queries. */
typedef struct chunk_buffers {
    uint32_t *self, *idx, *idx1, *idx_sp;
    double *d2, *d2_1, *nn, *local, *area, *anchor, *d2_sp;
    uint8_t *count, *count1, *count_sp;
} chunk_buffers;

static void chunk_free(chunk_buffers *c)
{
    free(c->self); free(c->idx); free(c->idx1); free(c->idx_sp);
    free(c->d2); free(c->d2_1); free(c->nn); free(c->local); free(c->area);
    free(c->anchor); free(c->d2_sp);
    free(c->count); free(c->count1); free(c->count_sp);
    memset(c, 0, sizeof *c);
}

static int chunk_alloc(chunk_buffers *c, wpd_error *err)
{
    const size_t K = WPD_METRICS_K_VORONOI;
    memset(c, 0, sizeof *c);
    c->self = malloc(CHUNK * sizeof *c->self);
    c->idx = malloc(CHUNK * K * sizeof *c->idx);
    c->idx1 = malloc(CHUNK * sizeof *c->idx1);
    c->d2 = malloc(CHUNK * K * sizeof *c->d2);
    c->d2_1 = malloc(CHUNK * sizeof *c->d2_1);
    c->nn = malloc(CHUNK * sizeof *c->nn);
    c->local = malloc(CHUNK * sizeof *c->local);
    c->area = malloc(CHUNK * sizeof *c->area);
    c->count = malloc(CHUNK);
    c->count1 = malloc(CHUNK);
    c->idx_sp = malloc(CHUNK * WPD_METRICS_K_LOCAL * sizeof *c->idx_sp);
    c->d2_sp = malloc(CHUNK * WPD_METRICS_K_LOCAL * sizeof *c->d2_sp);
    c->anchor = malloc(CHUNK * 3 * sizeof *c->anchor);
    c->count_sp = malloc(CHUNK);
    if (!c->self || !c->idx || !c->idx1 || !c->d2 || !c->d2_1 || !c->nn || !c->local ||
        !c->area || !c->count || !c->count1 || !c->idx_sp || !c->d2_sp || !c->anchor ||
        !c->count_sp) {
        chunk_free(c);
        return wpd_fail(err, WPD_E_MEMORY, "metrics: out of memory for query buffers");
    }
    return 0;
}

typedef struct resampled_accumulators {
    accumulator to_original, local, voronoi, nn, drift;
    uint64_t drift_over;
} resampled_accumulators;

/* Drift of each resampled point in the chunk: d(r, O) over the local
 * spacing of the original at r's nearest original point o (mean distance
 * from o to its WPD_METRICS_K_LOCAL nearest original neighbours). */
static void drift_ratios(const wpd_grid *go, const double *orig, size_t m, int threads,
                         chunk_buffers *c, double *ratio)
{
    const int K = WPD_METRICS_K_LOCAL;
    for (size_t i = 0; i < m; i++)
        memcpy(c->anchor + 3 * i, orig + 3 * (size_t)c->idx1[i], 3 * sizeof *orig);
    wpd_knn_many(go, c->anchor, c->idx1, m, K, INFINITY, c->idx_sp, c->d2_sp, c->count_sp,
                 threads);
    for (size_t i = 0; i < m; i++) {
        double spacing = local_mean(c->d2_sp + i * (size_t)K, c->count_sp[i]);
        double d = sqrt(c->d2_1[i]);
        ratio[i] = d == 0 ? 0 : isnan(spacing) || spacing == 0 ? INFINITY : d / spacing;
    }
}

/* Every measure that loops over the resampled points. */
static void resampled_pass(const wpd_grid *go, const double *orig, const wpd_grid *gr,
                           const double *res, size_t n_res, int threads, chunk_buffers *c,
                           resampled_accumulators *acc)
{
    const int K = WPD_METRICS_K_VORONOI;
    for (size_t start = 0; start < n_res; start += CHUNK) {
        size_t m = n_res - start < CHUNK ? n_res - start : CHUNK;
        const double *q = res + 3 * start;
        for (size_t i = 0; i < m; i++)
            c->self[i] = (uint32_t)(start + i);
        wpd_knn_many(go, q, NULL, m, 1, INFINITY, c->idx1, c->d2_1, c->count1, threads);
        wpd_knn_many(gr, q, c->self, m, K, INFINITY, c->idx, c->d2, c->count, threads);
#pragma omp parallel for num_threads(threads) schedule(dynamic, 256)
        for (size_t i = 0; i < m; i++) {
            int cnt = c->count[i];
            const double *d2 = c->d2 + i * (size_t)K;
            c->nn[i] = cnt ? sqrt(d2[0]) : NAN;
            c->local[i] = local_mean(d2, cnt);
            c->area[i] = voronoi_area(res, c->self[i], c->idx + i * (size_t)K, cnt);
        }
        drift_ratios(go, orig, m, threads, c, c->anchor); /* anchor reused for ratios */
        for (size_t i = 0; i < m; i++) {
            acc_add(&acc->drift, c->anchor[i]);
            acc->drift_over += c->anchor[i] > 1.0;
            acc_add(&acc->to_original, sqrt(c->d2_1[i]));
            if (!isnan(c->nn[i]))
                acc_add(&acc->nn, c->nn[i]);
            if (!isnan(c->local[i]))
                acc_add(&acc->local, c->local[i]);
            if (!isnan(c->area[i]))
                acc_add(&acc->voronoi, c->area[i]);
        }
    }
}

/* Distance from every original point to the nearest resampled point. */
static void original_pass(const wpd_grid *gr, const double *orig, size_t n_orig, int threads,
                          chunk_buffers *c, accumulator *to_resampled)
{
    for (size_t start = 0; start < n_orig; start += CHUNK) {
        size_t m = n_orig - start < CHUNK ? n_orig - start : CHUNK;
        wpd_knn_many(gr, orig + 3 * start, NULL, m, 1, INFINITY, c->idx1, c->d2_1, c->count1,
                     threads);
        for (size_t i = 0; i < m; i++)
            acc_add(to_resampled, sqrt(c->d2_1[i]));
    }
}

/* A, rho and the other figures derived from the accumulated statistics. */
static void derive(wpd_metrics *m)
{
    m->hausdorff = fmax(m->to_original.max, m->to_resampled.max);
    m->voronoi_skipped = m->resampled_points - m->voronoi.count;
    double n = (double)m->resampled_points;
    if (m->voronoi.count == 0) {
        m->surface_area = m->poisson_radius = NAN;
        return;
    }
    /* mean closed area * n == sum of closed areas * n / closed */
    m->surface_area = m->voronoi.mean * n;
    double r_max = sqrt(m->surface_area / (2 * sqrt(3.0) * n));
    m->poisson_radius = m->nn.count ? 0.5 * m->nn.min / r_max : NAN;
}

int wpd_metrics_compute(const double *orig, size_t n_orig, const double *res, size_t n_res,
                        int threads, wpd_metrics *m, wpd_error *err)
{
    memset(m, 0, sizeof *m);
    if (n_orig == 0 || n_res == 0)
        return wpd_fail(err, WPD_E_INPUT, "metrics: the %s cloud has no points",
                        n_orig == 0 ? "original" : "resampled");
    m->original_points = n_orig;
    m->resampled_points = n_res;
    m->k_local = WPD_METRICS_K_LOCAL;
    m->k_voronoi = WPD_METRICS_K_VORONOI;
    double ext[3];
    extent_of(orig, n_orig, ext);
    m->bbox_diagonal = sqrt(ext[0] * ext[0] + ext[1] * ext[1] + ext[2] * ext[2]);

    wpd_grid go = {0}, gr = {0};
    chunk_buffers c;
    if (build_grid(&go, orig, n_orig, threads, err))
        return -1;
    if (build_grid(&gr, res, n_res, threads, err) || chunk_alloc(&c, err)) {
        wpd_grid_free(&go);
        wpd_grid_free(&gr);
        return -1;
    }
    resampled_accumulators acc;
    accumulator to_resampled;
    acc_init(&acc.to_original);
    acc_init(&acc.local);
    acc_init(&acc.voronoi);
    acc_init(&acc.nn);
    acc_init(&acc.drift);
    acc.drift_over = 0;
    acc_init(&to_resampled);
    resampled_pass(&go, orig, &gr, res, n_res, threads, &c, &acc);
    original_pass(&gr, orig, n_orig, threads, &c, &to_resampled);
    chunk_free(&c);
    wpd_grid_free(&go);
    wpd_grid_free(&gr);

    acc_finish(&acc.to_original, &m->to_original);
    acc_finish(&to_resampled, &m->to_resampled);
    acc_finish(&acc.local, &m->local);
    acc_finish(&acc.voronoi, &m->voronoi);
    acc_finish(&acc.nn, &m->nn);
    acc_finish(&acc.drift, &m->drift);
    m->drift_over = acc.drift_over;
    derive(m);
    return 0;
}

/* ---- reading ---- */

static int append_batch(double **xyz, size_t *n, size_t *cap, const wpd_batch *b,
                        const char *path, wpd_error *err)
{
    if (*n + b->n > *cap) {
        size_t want = *cap ? *cap : 65536;
        while (want < *n + b->n)
            want *= 2;
        double *grown = realloc(*xyz, want * 3 * sizeof **xyz);
        if (!grown)
            return wpd_fail(err, WPD_E_MEMORY, "%s: out of memory holding %zu points", path,
                            *n + b->n);
        *xyz = grown;
        *cap = want;
    }
    memcpy(*xyz + 3 * *n, b->xyz, b->n * 3 * sizeof **xyz);
    *n += b->n;
    return 0;
}

int wpd_metrics_load(const char *path, double **xyz, size_t *n, wpd_error *err)
{
    return wpd_metrics_load_many(&path, 1, xyz, n, NULL, err);
}

int wpd_metrics_load_many(const char *const *paths, int npaths, double **xyz, size_t *n,
                          wpd_warnings *warnings, wpd_error *err)
{
    const char *path = paths[0];
    *xyz = NULL;
    *n = 0;
    if (warnings)
        memset(warnings, 0, (size_t)npaths * sizeof *warnings);
    wpd_cloud *cloud = wpd_cloud_open(paths, npaths, err);
    if (!cloud)
        return -1;
    for (int i = 0; warnings && i < npaths; i++)
        warnings[i] = wpd_cloud_header(cloud, i)->warnings;
    wpd_batch b;
    if (wpd_batch_init(&b, 65536, wpd_cloud_header(cloud, 0)->schema.record_size)) {
        wpd_cloud_close(cloud);
        return wpd_fail(err, WPD_E_MEMORY, "%s: out of memory for a read batch", path);
    }
    size_t cap = 0;
    long got;
    int rc = 0;
    while ((got = wpd_cloud_read(cloud, &b, NULL, err)) > 0)
        if ((rc = append_batch(xyz, n, &cap, &b, path, err)))
            break;
    if (got < 0)
        rc = -1;
    if (rc == 0 && *n == 0)
        rc = wpd_fail(err, WPD_E_INPUT, "%s: no point with finite coordinates", path);
    if (rc == 0 && *n > (size_t)UINT32_MAX - 2)
        rc = wpd_fail(err, WPD_E_INPUT, "%s: %zu points, more than the 4294967293 supported",
                      path, *n);
    wpd_batch_free(&b);
    wpd_cloud_close(cloud);
    if (rc) {
        free(*xyz);
        *xyz = NULL;
        *n = 0;
    }
    return rc;
}

/* ---- output ---- */

static double rel(const wpd_metrics *m, double v)
{
    return m->bbox_diagonal > 0 ? v / m->bbox_diagonal : NAN;
}

static void json_field(FILE *f, const char *name, double v, int last)
{
    fprintf(f, "  \"%s\": ", name);
    wpd_json_number(f, v);
    fputs(last ? "\n" : ",\n", f);
}

static void json_stats(FILE *f, const char *name, const char *count_name, int k,
                       const wpd_metrics_stats *s, const uint64_t *skipped)
{
    fprintf(f, "  \"%s\": {\"k\": %d, \"%s\": %llu, ", name, k, count_name,
            (unsigned long long)s->count);
    if (skipped)
        fprintf(f, "\"skipped\": %llu, ", (unsigned long long)*skipped);
    const char *keys[] = {"min", "max", "range", "mean", "std", "cv"};
    const double vals[] = {s->min, s->max, s->range, s->mean, s->std, s->cv};
    for (int i = 0; i < 6; i++) {
        fprintf(f, "\"%s\": ", keys[i]);
        wpd_json_number(f, vals[i]);
        fputs(i < 5 ? ", " : "},\n", f);
    }
}

void wpd_metrics_write_json(FILE *f, const wpd_metrics *m)
{
    fprintf(f, "{\n  \"original_points\": %llu,\n  \"resampled_points\": %llu,\n",
            (unsigned long long)m->original_points, (unsigned long long)m->resampled_points);
    json_field(f, "bbox_diagonal", m->bbox_diagonal, 0);
    const char *names[] = {"hausdorff_resampled_to_original", "hausdorff_original_to_resampled",
                           "hausdorff", "mean_resampled_to_original",
                           "mean_original_to_resampled"};
    const double vals[] = {m->to_original.max, m->to_resampled.max, m->hausdorff,
                           m->to_original.mean, m->to_resampled.mean};
    char name[64];
    for (int i = 0; i < 5; i++) {
        json_field(f, names[i], vals[i], 0);
        snprintf(name, sizeof name, "%s_rel", names[i]);
        json_field(f, name, rel(m, vals[i]), 0);
    }
    json_stats(f, "local_density", "points", m->k_local, &m->local, NULL);
    json_stats(f, "voronoi_area", "closed", m->k_voronoi, &m->voronoi, &m->voronoi_skipped);
    json_field(f, "min_spacing", m->nn.min, 0);
    json_field(f, "mean_nn_distance", m->nn.mean, 0);
    json_field(f, "surface_area", m->surface_area, 0);
    json_field(f, "poisson_radius", m->poisson_radius, 0);
    fputs("  \"drift\": {", f);
    fputs("\"max\": ", f);
    wpd_json_number(f, m->drift.max);
    fputs(", \"mean\": ", f);
    wpd_json_number(f, m->drift.mean);
    fprintf(f, ", \"over_local_spacing\": %llu}\n}\n", (unsigned long long)m->drift_over);
}

static void text_line(FILE *f, const char *name, double v)
{
    if (isfinite(v))
        fprintf(f, "%-40s %.9g\n", name, v);
    else
        fprintf(f, "%-40s n/a\n", name);
}

static void text_count(FILE *f, const char *name, uint64_t v)
{
    fprintf(f, "%-40s %llu\n", name, (unsigned long long)v);
}

void wpd_metrics_write_text(FILE *f, const wpd_metrics *m)
{
    text_count(f, "original points", m->original_points);
    text_count(f, "resampled points", m->resampled_points);
    text_line(f, "bbox diagonal (original)", m->bbox_diagonal);
    text_line(f, "hausdorff resampled->original", m->to_original.max);
    text_line(f, "hausdorff original->resampled", m->to_resampled.max);
    text_line(f, "hausdorff (symmetric)", m->hausdorff);
    text_line(f, "mean distance resampled->original", m->to_original.mean);
    text_line(f, "mean distance original->resampled", m->to_resampled.mean);
    text_line(f, "hausdorff resampled->original / diag", rel(m, m->to_original.max));
    text_line(f, "hausdorff original->resampled / diag", rel(m, m->to_resampled.max));
    text_line(f, "hausdorff (symmetric) / diag", rel(m, m->hausdorff));
    text_line(f, "mean resampled->original / diag", rel(m, m->to_original.mean));
    text_line(f, "mean original->resampled / diag", rel(m, m->to_resampled.mean));
    text_line(f, "local density (k=6) range max-min", m->local.range);
    text_line(f, "local density (k=6) mean", m->local.mean);
    text_line(f, "local density (k=6) cv", m->local.cv);
    text_count(f, "voronoi (k=12) closed cells", m->voronoi.count);
    text_count(f, "voronoi (k=12) skipped (open) cells", m->voronoi_skipped);
    text_line(f, "voronoi area range max-min", m->voronoi.range);
    text_line(f, "voronoi area mean", m->voronoi.mean);
    text_line(f, "voronoi area cv", m->voronoi.cv);
    text_line(f, "min spacing d_min", m->nn.min);
    text_line(f, "mean nearest-neighbour distance", m->nn.mean);
    text_line(f, "surface area estimate A", m->surface_area);
    text_line(f, "normalised poisson radius rho", m->poisson_radius);
    text_line(f, "drift / local spacing max", m->drift.max);
    text_line(f, "drift / local spacing mean", m->drift.mean);
    text_count(f, "points drifting beyond local spacing", m->drift_over);
}

/* ---- the subcommand ---- */

static const char *usage_text =
    "usage: wpd metrics [--json] ORIGINAL RESAMPLED\n"
    "Measures how well RESAMPLED (LAS, LAZ or PLY) represents ORIGINAL: Hausdorff\n"
    "and mean distances both ways (also divided by the original's bounding-box\n"
    "diagonal), the paper's local density error (k = 6 mean neighbour distance:\n"
    "range, mean, coefficient of variation), its Voronoi density error (cell\n"
    "areas in the tangent plane among 12 neighbours; open cells skipped), the\n"
    "minimum and mean nearest-neighbour spacing and the normalised Poisson-disk\n"
    "radius rho (1 for a perfect hexagonal packing).\n"
    "  --json   one JSON object instead of text\n";

static void shift_to_origin(double *xyz, size_t n, const double o[3])
{
    for (size_t i = 0; i < n; i++)
        for (int a = 0; a < 3; a++)
            xyz[3 * i + a] -= o[a];
}

/* wpd_metrics_load, printing the file's warnings (when it opens). */
static int load(const char *path, double **xyz, size_t *n, wpd_error *err)
{
    wpd_warnings w;
    int rc = wpd_metrics_load_many(&path, 1, xyz, n, &w, err);
    wpd_warnings_print(stderr, "metrics", &w);
    return rc;
}

static int run(const char *orig_path, const char *res_path, int json, wpd_error *err)
{
    double *orig = NULL, *res = NULL;
    size_t n_orig, n_res;
    if (load(orig_path, &orig, &n_orig, err))
        return -1;
    if (load(res_path, &res, &n_res, err)) {
        free(orig);
        return -1;
    }
    wpd_bounds b;
    wpd_bounds_reset(&b);
    wpd_bounds_add(&b, orig, n_orig);
    shift_to_origin(orig, n_orig, b.min);
    shift_to_origin(res, n_res, b.min);
    wpd_metrics m;
    int rc = wpd_metrics_compute(orig, n_orig, res, n_res, 0, &m, err);
    free(orig);
    free(res);
    if (rc)
        return -1;
    if (json)
        wpd_metrics_write_json(stdout, &m);
    else
        wpd_metrics_write_text(stdout, &m);
    return wpd_stdout_flush(err);
}

int wpd_metrics_main(int argc, char **argv)
{
    static const struct option longopts[] = {
        {"json", no_argument, 0, 'j'}, {"help", no_argument, 0, 'h'}, {0, 0, 0, 0}};
    int json = 0, c;
    optind = 1;
    opterr = 0;
    while ((c = getopt_long(argc, argv, "h", longopts, NULL)) != -1) {
        if (c == 'j') {
            json = 1;
        } else if (c == 'h') {
            fputs(usage_text, stdout);
            return 0;
        } else {
            fprintf(stderr, "wpd metrics: unknown option '%s' (see 'wpd metrics --help')\n",
                    argv[optind - 1]);
            return WPD_E_USAGE;
        }
    }
    if (argc - optind != 2) {
        fprintf(stderr, "wpd metrics: expected ORIGINAL and RESAMPLED, got %d file%s "
                "(see 'wpd metrics --help')\n", argc - optind, argc - optind == 1 ? "" : "s");
        return WPD_E_USAGE;
    }
    wpd_error err = {0};
    if (run(argv[optind], argv[optind + 1], json, &err)) {
        fprintf(stderr, "wpd metrics: %s\n", err.msg[0] ? err.msg : "failed");
        return err.code ? (int)err.code : WPD_E_IO;
    }
    return 0;
}
