/* cmd_resample.c - `wpd resample IN... -o OUT -n N`: Weighted Poisson-disk
 * resampling of a cloud held in memory (one block). */
#include "cli/commands.h"
#include "io/cloud.h"
#include "io/layout.h"
#include "io/writer.h"
#include "wpd/smooth.h"
#include "wpd/wpd.h"

#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>

static const char *usage_text =
    "usage: wpd resample IN... -o OUT -n N [options]\n"
    "Resamples the points of IN (several inputs are one cloud) to exactly N points\n"
    "with even, isotropic spacing (Weighted Poisson-disk resampling), keeping every\n"
    "attribute of each selected point; coordinates move by the tangent smoothing.\n"
    "  -o, --output FILE     output (.las or .ply); must not exist unless --force\n"
    "  -n, --count N         points to keep: a number (k, M suffixes) or a\n"
    "                        percentage of the input (\"10%\"); N >= input copies it\n"
    "      --lambda L        area overlap factor of the radius estimate (0.68)\n"
    "      --voxel-frac F    voxel edge / largest extent for the paper's estimate (0.05)\n"
    "      --radius-estimate paper|multiscale   first radius (multiscale)\n"
    "  -k N                  neighbours for normals and smoothing (13)\n"
    "      --iterations N    smoothing iterations (5)\n"
    "      --no-smooth       Poisson sample only: no point moves\n"
    "      --sharp           detect sharp features, sample them at r/2, keep them fixed\n"
    "      --seed S          visiting order of the Poisson pass (0)\n"
    "      --smooth-mode M   centroid (Lloyd step, default), vertex-mean (the authors'\n"
    "                        release) or cotan (eq. 8 as printed; moves nothing)\n"
    "      --free-surface    do not project smoothed points back onto the input surface\n"
    "      --threads T       OpenMP threads (default: all cores)\n"
    "      --ascii           ascii PLY output\n"
    "      --force           replace OUT if it exists\n"
    "  -q, --quiet           print nothing on success\n";

typedef struct resample_options {
    const char *output;
    const char *count_text;
    int quiet;
    wpd_params params;
    wpd_write_options write;
} resample_options;

/* ---------------------------------------------------------------- loading */

/* The whole cloud in memory: records and coordinates relative to origin. */
typedef struct loaded_cloud {
    size_t n;
    uint32_t record_size;
    uint8_t *records;
    double *xyz;              /* relative to origin */
    uint64_t *gid;            /* 0..n-1 */
    double origin[3];
} loaded_cloud;

static void loaded_free(loaded_cloud *c)
{
    free(c->records);
    free(c->xyz);
    free(c->gid);
    memset(c, 0, sizeof *c);
}

static int load_cloud(wpd_cloud *cloud, loaded_cloud *out, wpd_error *err)
{
    memset(out, 0, sizeof *out);
    uint64_t cap = wpd_cloud_count(cloud);
    out->record_size = wpd_cloud_header(cloud, 0)->schema.record_size;
    out->records = malloc(cap ? cap * out->record_size : 1);
    out->xyz = malloc((cap ? cap : 1) * 3 * sizeof *out->xyz);
    out->gid = malloc((cap ? cap : 1) * sizeof *out->gid);
    wpd_batch b;
    if (!out->records || !out->xyz || !out->gid ||
        wpd_batch_init(&b, 65536, out->record_size)) {
        loaded_free(out);
        return wpd_fail(err, WPD_E_MEMORY, "out of memory loading %llu points",
                        (unsigned long long)cap);
    }
    long got;
    while ((got = wpd_cloud_read(cloud, &b, NULL, err)) > 0) {
        memcpy(out->records + out->n * out->record_size, b.records, b.n * out->record_size);
        memcpy(out->xyz + 3 * out->n, b.xyz, b.n * 3 * sizeof *b.xyz);
        out->n += b.n;
    }
    wpd_batch_free(&b);
    if (got < 0) {
        loaded_free(out);
        return -1;
    }
    wpd_bounds bounds;
    wpd_bounds_reset(&bounds);
    wpd_bounds_add(&bounds, out->xyz, out->n);
    for (int k = 0; k < 3; k++)
        out->origin[k] = out->n ? bounds.min[k] : 0.0;
    for (size_t i = 0; i < out->n; i++) {
        out->gid[i] = i;
        for (int k = 0; k < 3; k++)
            out->xyz[3 * i + k] -= out->origin[k];
    }
    return 0;
}

/* ---------------------------------------------------------------- writing */

static wpd_format format_from_name(const char *path)
{
    const char *dot = strrchr(path, '.');
    if (dot && !strcasecmp(dot, ".las"))
        return WPD_FMT_LAS;
    if (dot && !strcasecmp(dot, ".ply"))
        return WPD_FMT_PLY;
    return WPD_FMT_NONE;
}

/* 1 when a PLY output's x, y or z is float32 and float32 spacing at the
 * output's magnitude is coarser than precision: smoothed positions would
 * be rounded away (float32 UTM northings are spaced half a metre apart). */
static int needs_wider_coordinates(const wpd_header *out, const wpd_bounds *b, double precision)
{
    if (out->format != WPD_FMT_PLY)
        return 0;
    const wpd_schema *s = &out->schema;
    int axes[3] = {s->dim_x, s->dim_y, s->dim_z};
    for (int k = 0; k < 3; k++) {
        if (axes[k] < 0 || s->dims[axes[k]].type != WPD_F32)
            continue;
        double mag = fmax(fabs(b->min[k]), fabs(b->max[k]));
        if (mag > 0 && ldexp(1.0, ilogb(mag) - 23) > precision)
            return 1;
    }
    return 0;
}

/* Writes the selected records (index[i] into c) with coordinates xyz (block
 * frame; NULL: unchanged) in the layout planned for the output format.
 * precision: the coordinate resolution the moved positions need. */
static int write_selection(const loaded_cloud *c, const wpd_header *in, const uint32_t *index,
                           const double *xyz, size_t count, double precision,
                           const resample_options *opt, wpd_error *err)
{
    wpd_bounds bounds;
    wpd_bounds_reset(&bounds);
    for (size_t i = 0; i < count; i++) {
        double p[3];
        for (int k = 0; k < 3; k++)
            p[k] = (xyz ? xyz[3 * i + k] : c->xyz[3 * index[i] + k]) + c->origin[k];
        wpd_bounds_add(&bounds, p, 1);
    }
    wpd_header out;
    wpd_layout_map map;
    if (wpd_layout_plan(in, &bounds, format_from_name(opt->output), &out, &map, err))
        return -1;
    if (xyz && needs_wider_coordinates(&out, &bounds, precision) &&
        wpd_layout_widen_coordinates(in, &out, &map, err)) {
        wpd_header_free(&out);
        return -1;
    }
    wpd_batch src, dst;
    int rc = -1;
    wpd_writer *w = NULL;
    if (wpd_batch_init(&src, 65536, in->schema.record_size) ||
        wpd_batch_init(&dst, 65536, out.schema.record_size)) {
        wpd_fail(err, WPD_E_MEMORY, "out of memory");
        goto done;
    }
    if (!(w = wpd_writer_open(opt->output, &out, &opt->write, err)))
        goto done;
    for (size_t start = 0; start < count; start += src.cap) {
        src.n = count - start < src.cap ? count - start : src.cap;
        for (size_t i = 0; i < src.n; i++) {
            uint32_t j = index[start + i];
            memcpy(src.records + i * src.record_size, c->records + (size_t)j * c->record_size,
                   c->record_size);
            for (int k = 0; k < 3; k++)
                src.xyz[3 * i + k] =
                    (xyz ? xyz[3 * (start + i) + k] : c->xyz[3 * j + k]) + c->origin[k];
        }
        wpd_layout_apply(&map, &in->schema, &out.schema, &src, &dst);
        if (wpd_writer_write(w, &dst, err))
            goto done;
    }
    rc = wpd_writer_close(w, err);
    w = NULL;
done:
    wpd_writer_abort(w);
    wpd_batch_free(&src);
    wpd_batch_free(&dst);
    wpd_header_free(&out);
    return rc;
}

/* ---------------------------------------------------------------- options */

/* Parses "N", "Nk", "NM" or "P%" of total. Returns 0 or -1. */
static int parse_count(const char *text, uint64_t total, uint64_t *out)
{
    char *end;
    errno = 0;
    double v = strtod(text, &end);
    if (end == text || errno || !isfinite(v) || v < 0)
        return -1;
    if (*end == '%' && !end[1])
        v = nearbyint(v / 100.0 * (double)total);
    else if ((*end == 'k' || *end == 'K') && !end[1])
        v *= 1e3;
    else if (*end == 'M' && !end[1])
        v *= 1e6;
    else if (*end)
        return -1;
    if (v != floor(v) || v > 1e18)
        return -1;
    *out = (uint64_t)v;
    return 0;
}

static int parse_positive(const char *text, double lo, double hi, double *out)
{
    char *end;
    double v = strtod(text, &end);
    if (end == text || *end || !(v >= lo && v <= hi))
        return -1;
    *out = v;
    return 0;
}

enum { OPT_LAMBDA = 256, OPT_VOXEL, OPT_ITER, OPT_NOSMOOTH, OPT_SHARP, OPT_SEED,
       OPT_THREADS, OPT_ASCII, OPT_FORCE, OPT_RADIUS_EST, OPT_SMOOTH_MODE,
       OPT_FREE_SURFACE };

static int parse_option(int c, const char *arg, resample_options *o)
{
    wpd_params *p = &o->params;
    double v;
    switch (c) {
    case 'o': o->output = arg; return 0;
    case 'n': o->count_text = arg; return 0;
    case 'q': o->quiet = 1; return 0;
    case 'k': if (parse_positive(arg, 3, 64, &v)) return -1; p->k = (int)v; return 0;
    case OPT_LAMBDA: return parse_positive(arg, 1e-3, 1e3, &p->lambda);
    case OPT_VOXEL: return parse_positive(arg, 1e-6, 1, &p->voxel_frac);
    case OPT_ITER: if (parse_positive(arg, 0, 1000, &v)) return -1; p->iterations = (int)v; return 0;
    case OPT_NOSMOOTH: p->smooth = 0; return 0;
    case OPT_SHARP: p->sharp = 1; return 0;
    case OPT_SEED: if (parse_positive(arg, 0, 1.8e19, &v)) return -1;
        p->seed = strtoull(arg, NULL, 10); return 0;
    case OPT_THREADS: if (parse_positive(arg, 1, 1024, &v)) return -1; p->threads = (int)v; return 0;
    case OPT_ASCII: o->write.ply_ascii = 1; return 0;
    case OPT_FORCE: o->write.overwrite = 1; return 0;
    case OPT_SMOOTH_MODE:
        if (!strcmp(arg, "centroid")) p->smooth_mode = WPD_SMOOTH_CENTROID;
        else if (!strcmp(arg, "vertex-mean")) p->smooth_mode = WPD_SMOOTH_VERTEX_MEAN;
        else if (!strcmp(arg, "cotan")) p->smooth_mode = WPD_SMOOTH_COTAN;
        else return -1;
        return 0;
    case OPT_FREE_SURFACE: p->keep_on_surface = 0; return 0;
    case OPT_RADIUS_EST:
        if (!strcmp(arg, "paper")) p->radius_method = WPD_RADIUS_PAPER;
        else if (!strcmp(arg, "multiscale")) p->radius_method = WPD_RADIUS_MULTISCALE;
        else return -1;
        return 0;
    default: return -1;
    }
}

/* Fills o from argv; returns -1 (usage printed) on error, 1 for --help. */
static int parse_args(int argc, char **argv, resample_options *o, int *first_input)
{
    static const struct option longopts[] = {
        {"output", required_argument, 0, 'o'}, {"count", required_argument, 0, 'n'},
        {"quiet", no_argument, 0, 'q'}, {"lambda", required_argument, 0, OPT_LAMBDA},
        {"voxel-frac", required_argument, 0, OPT_VOXEL},
        {"iterations", required_argument, 0, OPT_ITER},
        {"no-smooth", no_argument, 0, OPT_NOSMOOTH}, {"sharp", no_argument, 0, OPT_SHARP},
        {"seed", required_argument, 0, OPT_SEED}, {"threads", required_argument, 0, OPT_THREADS},
        {"ascii", no_argument, 0, OPT_ASCII}, {"force", no_argument, 0, OPT_FORCE},
        {"radius-estimate", required_argument, 0, OPT_RADIUS_EST},
        {"smooth-mode", required_argument, 0, OPT_SMOOTH_MODE},
        {"free-surface", no_argument, 0, OPT_FREE_SURFACE},
        {"help", no_argument, 0, 'h'}, {0, 0, 0, 0}};
    memset(o, 0, sizeof *o);
    wpd_params_default(&o->params);
    int c, idx;
    optind = 1;
    while ((c = getopt_long(argc, argv, "o:n:k:qh", longopts, &idx)) != -1) {
        if (c == 'h') {
            fputs(usage_text, stdout);
            return 1;
        }
        if (c == '?' || parse_option(c, optarg, o)) {
            if (c != '?')
                fprintf(stderr, "wpd resample: invalid value '%s' for %s\n", optarg,
                        c < 256 ? (char[]){'-', (char)c, 0} : longopts[idx].name);
            fputs(usage_text, stderr);
            return -1;
        }
    }
    if (optind >= argc || !o->output || !o->count_text) {
        fprintf(stderr, "wpd resample: need inputs, -o OUT and -n N\n");
        fputs(usage_text, stderr);
        return -1;
    }
    if (format_from_name(o->output) == WPD_FMT_NONE) {
        fprintf(stderr, "wpd resample: %s: output must end in .las or .ply\n", o->output);
        return -1;
    }
    *first_input = optind;
    return 0;
}

/* ---------------------------------------------------------------- running */

static int output_is_input(char **inputs, int n, const char *out)
{
    struct stat so, si;
    if (stat(out, &so) != 0)
        return 0;
    for (int i = 0; i < n; i++)
        if (stat(inputs[i], &si) == 0 && si.st_dev == so.st_dev && si.st_ino == so.st_ino)
            return 1;
    return 0;
}

/* The lattice the output stores coordinates on, in the block frame: a LAS
 * output written with the input's scale puts points on multiples of it from
 * the origin, which is an input point (the minimum corner of the first
 * file's points when all share one scale and offset). 0: exact enough. */
static void output_lattice(wpd_cloud *cloud, const resample_options *o, double res[3])
{
    const wpd_header *first = wpd_cloud_header(cloud, 0);
    res[0] = res[1] = res[2] = 0;
    if (first->format != WPD_FMT_LAS || format_from_name(o->output) != WPD_FMT_LAS)
        return;
    for (int i = 1; i < wpd_cloud_nfiles(cloud); i++)
        for (int k = 0; k < 3; k++)
            if (wpd_cloud_header(cloud, i)->las.scale[k] != first->las.scale[k] ||
                wpd_cloud_header(cloud, i)->las.offset[k] != first->las.offset[k])
                return;
    for (int k = 0; k < 3; k++)
        res[k] = first->las.scale[k];
}

static void print_summary(const wpd_result *r, size_t n_in, double load_s, double write_s,
                          const resample_options *o)
{
    const wpd_timings *t = &r->time;
    printf("resampled %zu -> %zu points into %s\n", n_in, r->count, o->output);
    printf("  radius %.6g (estimate %.6g, first pass %zu points, %d passes, %zu before the "
           "exact count)\n", r->radius, r->radius_estimate, r->first_pass_count, r->passes,
           r->poisson_count);
    if (o->params.smooth)
        printf("  smoothing: %d iterations, %zu points fixed (open Voronoi cell), %zu pulled "
               "back to the input surface\n", o->params.iterations, r->open_cells,
               r->pulled_to_surface);
    if (o->params.sharp)
        printf("  sharp features: %zu input points labelled sharp\n", r->sharp_points);
    printf("  time: load %.3f s, radius %.3f, surface %.3f, sharp %.3f, poisson %.3f, exact "
           "%.3f, normals %.3f, smooth %.3f, write %.3f (threads %d)\n",
           load_s, t->radius, t->surface, t->sharp, t->poisson, t->exact, t->normals,
           t->smooth, write_s, o->params.threads > 0 ? o->params.threads : omp_get_max_threads());
}

static int resample(char **inputs, int ninputs, resample_options *o, wpd_error *err)
{
    if (output_is_input(inputs, ninputs, o->output))
        return wpd_fail(err, WPD_E_USAGE, "%s: output is also an input", o->output);
    wpd_cloud *cloud = wpd_cloud_open((const char *const *)inputs, ninputs, err);
    if (!cloud)
        return -1;
    uint64_t target;
    int rc = -1;
    loaded_cloud c = {0};
    wpd_result res = {0};
    if (parse_count(o->count_text, wpd_cloud_count(cloud), &target) || target == 0) {
        wpd_fail(err, WPD_E_USAGE, "-n %s: the point count must be a positive number or "
                 "percentage", o->count_text);
        goto done;
    }
    double t0 = omp_get_wtime();
    if (load_cloud(cloud, &c, err))
        goto done;
    double load_s = omp_get_wtime() - t0;
    if (wpd_cloud_dropped(cloud) && !o->quiet)
        fprintf(stderr, "wpd resample: warning: %llu points with non-finite coordinates "
                "dropped\n", (unsigned long long)wpd_cloud_dropped(cloud));
    if (target >= c.n && !o->quiet)
        fprintf(stderr, "wpd resample: notice: -n %llu >= %zu input points: copying the "
                "input\n", (unsigned long long)target, c.n);
    output_lattice(cloud, o, o->params.resolution);
    wpd_block block = {.n = c.n, .xyz = c.xyz, .gid = c.gid};
    if (wpd_run_block(&block, target, &o->params, &res, err))
        goto done;
    t0 = omp_get_wtime();
    const double *moved = o->params.smooth && target < c.n ? res.xyz : NULL;
    /* Smoothing moves points by fractions of r: keep them to r / 1000. */
    rc = write_selection(&c, wpd_cloud_header(cloud, 0), res.index, moved, res.count,
                         res.radius / 1000, o, err);
    if (rc == 0 && !o->quiet)
        print_summary(&res, c.n, load_s, omp_get_wtime() - t0, o);
done:
    wpd_result_free(&res);
    loaded_free(&c);
    wpd_cloud_close(cloud);
    return rc;
}

int wpd_cmd_resample(int argc, char **argv)
{
    resample_options o;
    int first;
    int rc = parse_args(argc, argv, &o, &first);
    if (rc)
        return rc > 0 ? 0 : WPD_E_USAGE;
    if (o.params.threads > 0)
        omp_set_num_threads(o.params.threads);
    wpd_error err = {0};
    if (resample(argv + first, argc - first, &o, &err))
        return wpd_report_error("resample", &err);
    return 0;
}
