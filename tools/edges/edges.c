/* edges.c - `wpd edges` (see edges.h): the sharp-feature detector on
 * every point of a cloud, measured against a truth field, and the
 * labelled cloud written out.
 */
#include "tools/edges/edges.h"

#include <getopt.h>
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/outfile.h"
#include "tools/edges/edges_write.h"
#include "io/cloud.h"
#include "method/crease.h"
#include "method/sharp.h"

/* The cloud in memory: frame coordinates and, with a truth field, its
 * value per point. */
typedef struct points {
    size_t n, cap;
    double *xyz;
    uint8_t *truth;           /* NULL without --truth */
    double origin[3];
} points;

static void points_free(points *p)
{
    free(p->xyz);
    free(p->truth);
    memset(p, 0, sizeof *p);
}

static int grow(points *p, size_t more, int with_truth)
{
    if (p->n + more <= p->cap)
        return 0;
    size_t cap = p->cap ? p->cap : 1 << 16;
    while (cap < p->n + more)
        cap *= 2;
    double *xyz = realloc(p->xyz, cap * 3 * sizeof *xyz);
    if (xyz)
        p->xyz = xyz;
    uint8_t *t = with_truth ? realloc(p->truth, cap) : NULL;
    if (t)
        p->truth = t;
    if (!xyz || (with_truth && !t))
        return -1;
    p->cap = cap;
    return 0;
}

/* Appends batch b; truth values are DIM's, clamped to 0..255. */
static int add_batch(points *p, const wpd_batch *b, const wpd_dim *truth)
{
    if (grow(p, b->n, truth != NULL))
        return -1;
    memcpy(p->xyz + 3 * p->n, b->xyz, b->n * 3 * sizeof *b->xyz);
    for (size_t i = 0; truth && i < b->n; i++) {
        double v = wpd_dim_get(truth, b->records + i * b->record_size);
        p->truth[p->n + i] = (uint8_t)(v > 0 ? (v < 255 ? v : 255) : 0);
    }
    p->n += b->n;
    return 0;
}

/* Moves the points into the frame whose origin is their minimum corner. */
static void to_frame(points *p)
{
    for (int a = 0; a < 3; a++) {
        double lo = INFINITY;
        for (size_t i = 0; i < p->n; i++)
            lo = fmin(lo, p->xyz[3 * i + a]);
        p->origin[a] = lo;
        for (size_t i = 0; i < p->n; i++)
            p->xyz[3 * i + a] -= lo;
    }
}

static int load(wpd_cloud *cloud, const char *truth_name, points *p, wpd_error *err)
{
    const wpd_header *h = wpd_cloud_header(cloud, 0);
    const wpd_dim *truth = NULL;
    if (truth_name) {
        int d = wpd_schema_find(&h->schema, truth_name);
        if (d < 0)
            return wpd_fail(err, WPD_E_USAGE, "%s: no dimension %s", h->path, truth_name);
        truth = &h->schema.dims[d];
    }
    wpd_batch b;
    if (wpd_batch_init(&b, 65536, h->schema.record_size))
        return wpd_fail(err, WPD_E_MEMORY, "%s: out of memory", h->path);
    long got;
    int rc = 0;
    while (rc == 0 && (got = wpd_cloud_read(cloud, &b, NULL, err)) > 0)
        if (add_batch(p, &b, truth))
            rc = wpd_fail(err, WPD_E_MEMORY, "%s: out of memory for %zu points", h->path, p->n);
    wpd_batch_free(&b);
    if (rc == 0 && got < 0)
        rc = -1;
    if (rc == 0 && p->n == 0)
        rc = wpd_fail(err, WPD_E_INPUT, "%s: no point with finite coordinates", h->path);
    if (rc == 0 && p->n > (size_t)UINT32_MAX - 2)
        rc = wpd_fail(err, WPD_E_INPUT, "%s: too many points", h->path);
    if (rc == 0)
        to_frame(p);
    return rc;
}

/* A grid cell of about two spacings: the detector's neighbourhoods hold up
 * to 64 points. */
static double grid_cell(const points *p)
{
    double lo[3], hi[3];
    wpd_point_bounds(p->xyz, NULL, p->n, lo, hi, 0);
    double e[3] = {hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]};
    /* The two largest extents span the surface. */
    double a = fmax(e[0], fmax(e[1], e[2])), c = fmin(e[0], fmin(e[1], e[2]));
    double b = e[0] + e[1] + e[2] - a - c;
    double area = a * fmax(b, a * 1e-3);
    double cell = 2 * sqrt(area / (double)p->n);
    return cell > 0 ? cell : 1.0;
}

static void tally(const points *p, const uint8_t *edge, const uint8_t *verdict,
                  wpd_edges_summary *s)
{
    s->points = p->n;
    for (size_t i = 0; i < p->n; i++) {
        s->labelled += edge[i];
        if (verdict[i] < 16)
            s->by_verdict[verdict[i]]++;
        if (!p->truth || !p->truth[i])
            continue;
        s->truth++;
        s->true_positive += edge[i];
        s->truth_by_value[p->truth[i]]++;
        s->hit_by_value[p->truth[i]] += edge[i];
        if (!edge[i] && verdict[i] < 16)
            s->missed_by_verdict[verdict[i]]++;
    }
}

/* Labels the points (edge) from the crease test's verdicts, which are
 * tallied too. */
static int label(const points *p, double cap, int threads, uint8_t *edge, wpd_edges_summary *s,
                 wpd_error *err)
{
    wpd_grid g = {0};
    uint8_t *verdict = malloc(p->n);
    if (!verdict)
        return wpd_fail(err, WPD_E_MEMORY, "out of memory for %zu verdicts", p->n);
    if (wpd_grid_build(&g, p->xyz, NULL, p->n, grid_cell(p), threads, err)) {
        free(verdict);
        return -1;
    }
    double t = omp_get_wtime();
    wpd_sharp_verdicts(&g, cap, verdict, threads);
    s->seconds = omp_get_wtime() - t;
    for (size_t i = 0; i < p->n; i++)
        edge[i] = verdict[i] == WPD_CREASE_ON;
    wpd_grid_free(&g);
    tally(p, edge, verdict, s);
    free(verdict);
    return 0;
}

static const char *verdict_name(int v)
{
    static const char *names[WPD_SHARP_ALONE + 1] = {
        "on", "near (beyond the band)", "flat (one plane)", "a face with too few points",
        "rough (not two or three planes)", "shallow (under 30 degrees)", "crossing (not a fold)",
        "one row (a steep face's plane not determined)",
        "alone (no other crease point within 3 spacings)"};
    return v >= 0 && v <= WPD_SHARP_ALONE ? names[v] : "?";
}

static void print_summary(const wpd_edges_summary *s, const char *truth)
{
    printf("points %llu, labelled %llu (%.3f %%), detector %.2f s\n",
           (unsigned long long)s->points, (unsigned long long)s->labelled,
           100.0 * (double)s->labelled / (double)(s->points ? s->points : 1), s->seconds);
    printf("verdicts:");
    for (int v = 0; v <= WPD_SHARP_ALONE; v++)
        printf(" %s %llu%s", verdict_name(v), (unsigned long long)s->by_verdict[v],
               v < WPD_SHARP_ALONE ? "," : "\n");
    if (!truth)
        return;
    double prec = s->labelled ? (double)s->true_positive / (double)s->labelled : 0;
    double rec = s->truth ? (double)s->true_positive / (double)s->truth : 0;
    printf("truth %s != 0: %llu points; precision %.3f, recall %.3f\n", truth,
           (unsigned long long)s->truth, prec, rec);
    for (int v = 1; v < 256; v++)
        if (s->truth_by_value[v])
            printf("  %s = %d: %llu points, recall %.3f\n", truth, v,
                   (unsigned long long)s->truth_by_value[v],
                   (double)s->hit_by_value[v] / (double)s->truth_by_value[v]);
    for (int v = 0; v <= WPD_SHARP_ALONE; v++)
        if (s->missed_by_verdict[v])
            printf("  missed, %s: %llu\n", verdict_name(v),
                   (unsigned long long)s->missed_by_verdict[v]);
}

static const char *usage_text =
    "usage: wpd edges IN... [--cap R] [--truth DIM] [-o OUT] [--threads T] [--force]\n"
    "Runs the sharp-feature detector of `wpd resample --sharp` on every point of IN\n"
    "(several inputs are one cloud) and prints how many points it labels.\n"
    "  --cap R       neighbourhoods only within R (resample caps them at its radius\n"
    "                estimate, see `wpd resample -v`); default: no cap\n"
    "  --truth DIM   compare with DIM (not 0: a sharp point), e.g. the edge_truth of\n"
    "                `wpd synth --edge-truth`: precision, recall, recall per value,\n"
    "                why the missed points were missed\n"
    "  -o, --output OUT  write the points of IN with the label as field \"edge\"\n"
    "                (.las: an extra byte with its Extra Bytes VLR; .ply: uchar)\n"
    "  --threads T   OpenMP threads (default: all cores)\n"
    "  --force       replace OUT if it exists\n"
    "The cloud is held in memory (about 60 bytes per point).\n";

typedef struct edges_options {
    double cap;
    const char *truth, *output;
    int threads, overwrite;
} edges_options;

/* Fills o; returns -1 to go on, else the exit status (0 after --help). */
static int parse(int argc, char **argv, edges_options *o, int *first)
{
    enum { OPT_CAP = 256, OPT_TRUTH, OPT_THREADS, OPT_FORCE };
    static const struct option longopts[] = {
        {"cap", required_argument, 0, OPT_CAP}, {"truth", required_argument, 0, OPT_TRUTH},
        {"output", required_argument, 0, 'o'}, {"threads", required_argument, 0, OPT_THREADS},
        {"force", no_argument, 0, OPT_FORCE}, {"help", no_argument, 0, 'h'}, {0, 0, 0, 0}};
    *o = (edges_options){INFINITY, NULL, NULL, 0, 0};
    optind = 1;
    int c;
    char *end;
    while ((c = getopt_long(argc, argv, "o:h", longopts, NULL)) != -1) {
        switch (c) {
        case 'h': fputs(usage_text, stdout); return 0;
        case 'o': o->output = optarg; break;
        case OPT_TRUTH: o->truth = optarg; break;
        case OPT_FORCE: o->overwrite = 1; break;
        case OPT_CAP:
            o->cap = strtod(optarg, &end);
            if (*end || !(o->cap > 0)) {
                fprintf(stderr, "wpd edges: --cap '%s': expected a positive length\n", optarg);
                return WPD_E_USAGE;
            }
            break;
        case OPT_THREADS:
            o->threads = (int)strtol(optarg, &end, 10);
            if (*end || o->threads < 1 || o->threads > 1024) {
                fprintf(stderr, "wpd edges: --threads '%s': expected 1..1024\n", optarg);
                return WPD_E_USAGE;
            }
            break;
        default: fputs(usage_text, stderr); return WPD_E_USAGE;
        }
    }
    if (optind >= argc) {
        fprintf(stderr, "wpd edges: no input (see 'wpd edges --help')\n");
        return WPD_E_USAGE;
    }
    *first = optind;
    return -1;
}

static int run(char **inputs, int n, const edges_options *o, wpd_error *err)
{
    if (o->output && wpd_edges_check_output(o->output, inputs, n, o->overwrite, err))
        return -1;
    wpd_cloud *cloud = wpd_cloud_open((const char *const *)inputs, n, err);
    if (!cloud)
        return -1;
    wpd_cloud_print_warnings(cloud, "edges", stderr);
    points p = {0};
    wpd_edges_summary s;
    memset(&s, 0, sizeof s);
    uint8_t *edge = NULL;
    int rc = load(cloud, o->truth, &p, err);
    if (rc == 0 && !(edge = malloc(p.n)))
        rc = wpd_fail(err, WPD_E_MEMORY, "out of memory for %zu labels", p.n);
    if (rc == 0)
        rc = label(&p, o->cap, o->threads, edge, &s, err);
    if (rc == 0 && o->output)
        rc = wpd_edges_write(cloud, edge, p.n, o->output, o->overwrite, err);
    if (rc == 0)
        print_summary(&s, o->truth);
    free(edge);
    points_free(&p);
    wpd_cloud_close(cloud);
    return rc;
}

int wpd_edges_main(int argc, char **argv)
{
    edges_options o;
    int first, rc = parse(argc, argv, &o, &first);
    if (rc >= 0)
        return rc;
    if (o.threads > 0)
        omp_set_num_threads(o.threads);
    wpd_error err = {0};
    if (run(argv + first, argc - first, &o, &err)) {
        fprintf(stderr, "wpd edges: %s\n", err.msg);
        return err.code ? (int)err.code : WPD_E_IO;
    }
    return wpd_stdout_flush(&err) ? err.code : 0;
}
