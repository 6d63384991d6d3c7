/* cmd_resample.c - `wpd resample IN... -o OUT -n N`: Weighted Poisson-disk
 * resampling of a cloud held in memory (one block). */
#include "cli/class_options.h"
#include "cli/commands.h"
#include "cli/report.h"
#include "cli/resample_collection.h"
#include "cli/run_ranks.h"
#include "resample/output.h"
#include "resample/read.h"
#include "common/outfile.h"
#include "common/tmpdir.h"
#include "io/cloud.h"
#include "io/layout.h"
#include "tools/metrics/metrics.h"
#include "resample/classes.h"
#include "resample/resample.h"
#include "method/smooth.h"

#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <libgen.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

typedef struct resample_options {
    const char *output;       /* one output, or NULL with per_input */
    const char *per_input;    /* directory for one output per input */
    const char *count_text;
    const char *tmpdir;
    const char *report;       /* JSON report path, or NULL */
    size_t mem_bytes;         /* 0: default */
    int min_tiles;
    int skip_existing;        /* --per-input: skip inputs whose output is newer */
    int append;               /* -o OUT --append: OUT is a collection (docs/ingest.md) */
    int rebuild;              /* --rebuild: the collection from scratch */
    double spacing;           /* --spacing D: the collection's radius, or 0 */
    wpd_cli_collection *coll; /* --per-input or --append: the collection, else NULL */
    int quiet, verbose;
    int metrics;              /* quality summary (wpd metrics) of the result */
    int edge_label;           /* write the sharp labels as the field "edge" */
    wpd_class_args classes;   /* --drop-class, --keep-class, --class-count, --class-field */
    wpd_progress progress;
    wpd_params params;
    wpd_write_options write;
    const wpd_par *par;       /* the ranks: rank 0 writes, all agree on the outcome */
} resample_options;

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

/* Parses a byte size: a number with an optional K, M, G or T suffix
 * (powers of 1024). Returns 0 or -1. */
static int parse_size(const char *text, size_t *out)
{
    char *end;
    double v = strtod(text, &end);
    if (end == text || !(v > 0))
        return -1;
    static const char units[] = "KMGT";
    const char *u = *end ? strchr(units, *end == 'k' ? 'K' : *end) : NULL;
    if (*end && (!u || (end[1] && strcmp(end + 1, "B") && strcmp(end + 1, "iB"))))
        return -1;
    if (u)
        v *= pow(1024.0, (double)(u - units + 1));
    if (v > 1e18)
        return -1;
    *out = (size_t)v;
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
       OPT_FREE_SURFACE, OPT_PER_INPUT, OPT_MEM, OPT_TMPDIR, OPT_MIN_TILES, OPT_REPORT,
       OPT_SKIP_EXISTING, OPT_METRICS, OPT_EDGE_LABEL, OPT_DROP_CLASS, OPT_KEEP_CLASS,
       OPT_CLASS_COUNT, OPT_CLASS_FIELD, OPT_EVEN, OPT_APPEND, OPT_REBUILD, OPT_SPACING };

/* The class options: 0, or -2 with the one-line error printed. */
static int parse_class_option(int c, const char *arg, wpd_class_args *a)
{
    wpd_error err = {0};
    int rc = c == OPT_DROP_CLASS ? wpd_class_list_parse(arg, &a->drop, &err)
             : c == OPT_KEEP_CLASS ? wpd_class_list_parse(arg, &a->keep, &err)
                                   : wpd_class_count_parse(arg, a, &err);
    if (rc)
        fprintf(stderr, "wpd resample: %s\n", err.msg);
    return rc ? -2 : 0;
}

static int parse_option(int c, const char *arg, resample_options *o)
{
    wpd_params *p = &o->params;
    double v;
    switch (c) {
    case 'o': o->output = arg; return 0;
    case 'n': o->count_text = arg; return 0;
    case 'q': o->quiet = 1; return 0;
    case 'v': o->verbose = 1; return 0;
    case 'k': if (parse_positive(arg, 3, 64, &v)) return -1; p->k = (int)v; return 0;
    case OPT_LAMBDA: return parse_positive(arg, 1e-3, 1e3, &p->lambda);
    case OPT_VOXEL: return parse_positive(arg, 1e-6, 1, &p->voxel_frac);
    case OPT_ITER: if (parse_positive(arg, 0, 1000, &v)) return -1; p->iterations = (int)v; return 0;
    case OPT_EVEN: if (parse_positive(arg, 0, 1000, &v)) return -1; p->even_iterations = (int)v; return 0;
    case OPT_NOSMOOTH: p->smooth = 0; return 0;
    case OPT_SHARP: p->sharp = 1; return 0;
    case OPT_SEED: if (parse_positive(arg, 0, 1.8e19, &v)) return -1;
        p->seed = strtoull(arg, NULL, 10); return 0;
    case OPT_THREADS: if (parse_positive(arg, 1, 1024, &v)) return -1; p->threads = (int)v; return 0;
    case OPT_ASCII: o->write.ply_ascii = 1; return 0;
    case OPT_FORCE: o->write.overwrite = 1; return 0;
    case OPT_SMOOTH_MODE:
        fprintf(stderr, "wpd resample: --smooth-mode was removed: smoothing moves a sample "
                "to its Voronoi cell's centroid (docs/algorithm.md)\n");
        return -2;
    case OPT_FREE_SURFACE:
        fprintf(stderr, "wpd resample: --free-surface was removed: smoothed samples always "
                "stay on the input surface (docs/algorithm.md)\n");
        return -2;
    case OPT_PER_INPUT: o->per_input = arg; return 0;
    case OPT_TMPDIR: o->tmpdir = arg; return 0;
    case OPT_REPORT: o->report = arg; return 0;
    case OPT_SKIP_EXISTING: o->skip_existing = 1; return 0;
    case OPT_APPEND: o->append = 1; return 0;
    case OPT_REBUILD: o->rebuild = 1; return 0;
    case OPT_SPACING: return parse_positive(arg, 1e-300, 1e300, &o->spacing);
    case OPT_METRICS: o->metrics = 1; return 0;
    case OPT_EDGE_LABEL: o->edge_label = 1; return 0;
    case OPT_DROP_CLASS: case OPT_KEEP_CLASS: case OPT_CLASS_COUNT:
        return parse_class_option(c, arg, &o->classes);
    case OPT_CLASS_FIELD: o->classes.field = arg; return 0;
    case OPT_MEM: return parse_size(arg, &o->mem_bytes);
    case OPT_MIN_TILES: if (parse_positive(arg, 1, 1e6, &v)) return -1; o->min_tiles = (int)v; return 0;
    case OPT_RADIUS_EST:
        if (!strcmp(arg, "paper")) p->radius_method = WPD_RADIUS_PAPER;
        else if (!strcmp(arg, "multiscale")) p->radius_method = WPD_RADIUS_MULTISCALE;
        else return -1;
        return 0;
    default: return -1;
    }
}

/* The collection's options (docs/ingest.md): 0, or -1 with the line
 * printed. */
static int check_collection_options(const resample_options *o)
{
    const char *bad = NULL;
    if (o->append && !o->output)
        bad = "--append goes with -o OUT";
    else if ((o->rebuild || o->spacing) && !o->per_input && !o->append)
        bad = "--rebuild and --spacing go with a collection: --per-input DIR or -o OUT --append";
    else if (o->append && wpd_format_is_laz_name(o->output))
        bad = "--append writes LAS or PLY: appending to LAZ would encode every old record "
              "again (docs/ingest.md)";
    else if (o->classes.ncounts && (o->per_input || o->append))
        bad = "--class-count does not go with a collection (--per-input, --append): each "
              "class group would need a radius of its own (docs/ingest.md)";
    if (bad)
        fprintf(stderr, "wpd resample: %s\n", bad);
    return bad ? -1 : 0;
}

/* Fills o from argv; returns -1 (the error printed) on error, 1 for --help.
 * Options that were removed keep their names here, for the one line that
 * says so. */
static int parse_args(int argc, char **argv, resample_options *o, int *first_input)
{
    static const struct option longopts[] = {
        {"output", required_argument, 0, 'o'}, {"count", required_argument, 0, 'n'},
        {"quiet", no_argument, 0, 'q'}, {"verbose", no_argument, 0, 'v'},
        {"lambda", required_argument, 0, OPT_LAMBDA},
        {"voxel-frac", required_argument, 0, OPT_VOXEL},
        {"iterations", required_argument, 0, OPT_ITER},
        {"even-steps", required_argument, 0, OPT_EVEN},
        {"no-smooth", no_argument, 0, OPT_NOSMOOTH}, {"sharp", no_argument, 0, OPT_SHARP},
        {"seed", required_argument, 0, OPT_SEED}, {"threads", required_argument, 0, OPT_THREADS},
        {"ascii", no_argument, 0, OPT_ASCII}, {"force", no_argument, 0, OPT_FORCE},
        {"radius-estimate", required_argument, 0, OPT_RADIUS_EST},
        {"smooth-mode", required_argument, 0, OPT_SMOOTH_MODE},
        {"free-surface", no_argument, 0, OPT_FREE_SURFACE},
        {"per-input", required_argument, 0, OPT_PER_INPUT}, {"mem", required_argument, 0, OPT_MEM},
        {"tmpdir", required_argument, 0, OPT_TMPDIR}, {"report", required_argument, 0, OPT_REPORT},
        {"skip-existing", no_argument, 0, OPT_SKIP_EXISTING},
        {"append", no_argument, 0, OPT_APPEND}, {"rebuild", no_argument, 0, OPT_REBUILD},
        {"spacing", required_argument, 0, OPT_SPACING},
        {"metrics", no_argument, 0, OPT_METRICS},
        {"edge-label", no_argument, 0, OPT_EDGE_LABEL},
        {"drop-class", required_argument, 0, OPT_DROP_CLASS},
        {"keep-class", required_argument, 0, OPT_KEEP_CLASS},
        {"class-count", required_argument, 0, OPT_CLASS_COUNT},
        {"class-field", required_argument, 0, OPT_CLASS_FIELD},
        {"min-tiles", required_argument, 0, OPT_MIN_TILES},
        {"help", no_argument, 0, 'h'}, {0, 0, 0, 0}};
    memset(o, 0, sizeof *o);
    wpd_params_default(&o->params);
    int c, idx;
    optind = 1;
    while ((c = getopt_long(argc, argv, "o:n:k:qvh", longopts, &idx)) != -1) {
        if (c == 'h') {
            fputs(wpd_resample_usage, stdout);
            return 1;
        }
        int bad = c == '?' ? -1 : parse_option(c, optarg, o);
        if (bad == -2)
            return -1;
        if (bad) {
            if (c != '?')
                fprintf(stderr, "wpd resample: invalid value '%s' for %s\n", optarg,
                        c < 256 ? (char[]){'-', (char)c, 0} : longopts[idx].name);
            fputs(wpd_resample_usage, stderr);
            return -1;
        }
    }
    if (optind >= argc || (!o->count_text && !o->spacing) || !o->output == !o->per_input) {
        fprintf(stderr, "wpd resample: need inputs, -n N and one of -o OUT or --per-input DIR\n");
        fputs(wpd_resample_usage, stderr);
        return -1;
    }
    if (o->skip_existing)
        o->write.overwrite = 1; /* outputs older than their input are replaced */
    if (o->skip_existing && !o->per_input) {
        fprintf(stderr, "wpd resample: --skip-existing goes with --per-input\n");
        return -1;
    }
    if (check_collection_options(o))
        return -1;
    if (o->edge_label && !o->params.sharp) {
        fprintf(stderr, "wpd resample: --edge-label goes with --sharp (the labels come from "
                "its detector)\n");
        return -1;
    }
    wpd_error cerr = {0};
    if (wpd_class_args_check(&o->classes, &cerr)) {
        fprintf(stderr, "wpd resample: %s\n", cerr.msg);
        return -1;
    }
    if (o->output && wpd_format_from_name(o->output) == WPD_FMT_NONE) {
        fprintf(stderr, "wpd resample: %s: output must end in .las, .laz or .ply\n", o->output);
        return -1;
    }
    *first_input = optind;
    wpd_progress_init(&o->progress, o->quiet ? WPD_PROGRESS_QUIET
                                    : o->verbose ? WPD_PROGRESS_VERBOSE : WPD_PROGRESS_AUTO);
    return 0;
}


/* ---------------------------------------------------------------- running */

/* A quarter of the physical memory, at most 4 GiB: room for the other jobs
 * of a shared server. */
static size_t default_mem(void)
{
    long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGE_SIZE);
    size_t quarter = pages > 0 && page > 0 ? (size_t)pages * (size_t)page / 4 : (size_t)1 << 30;
    return quarter < ((size_t)4 << 30) ? quarter : (size_t)4 << 30;
}

/* The lattice the output stores coordinates on, in the frame whose origin
 * is the minimum corner (an input point): multiples of the LAS scale when a
 * LAS output keeps the inputs' common scale and offset; 0 otherwise. */
static void output_lattice(wpd_cloud *cloud, const resample_options *o, double res[3])
{
    const wpd_header *first = wpd_cloud_header(cloud, 0);
    res[0] = res[1] = res[2] = 0;
    const char *out = o->output ? o->output : first->path; /* per input: same format */
    if (first->format != WPD_FMT_LAS || wpd_format_from_name(out) != WPD_FMT_LAS)
        return;
    for (int i = 1; i < wpd_cloud_nfiles(cloud); i++)
        for (int k = 0; k < 3; k++)
            if (wpd_cloud_header(cloud, i)->las.scale[k] != first->las.scale[k] ||
                wpd_cloud_header(cloud, i)->las.offset[k] != first->las.offset[k])
                return;
    for (int k = 0; k < 3; k++)
        res[k] = first->las.scale[k];
}

/* Where the spill directory goes: --tmpdir, else $TMPDIR, else the
 * output's directory (buf holds it). */
static const char *spill_dir(const resample_options *o, char *buf, size_t size)
{
    if (o->tmpdir)
        return o->tmpdir;
    const char *env = getenv("TMPDIR");
    if (env && *env)
        return env;
    snprintf(buf, size, "%s", o->output ? o->output : o->per_input);
    return o->output ? dirname(buf) : buf;
}

/* Peak resident memory of this process so far, in KiB: VmHWM, the high
 * water mark of this program's own memory. (getrusage's ru_maxrss is not:
 * Linux carries the parent's resident size at fork over the exec, so a
 * run started by a large process - a Python test driver holding 200 MB -
 * would report that.) */
static long peak_rss_kb(void)
{
    FILE *f = fopen("/proc/self/status", "r");
    char line[256];
    long kb = -1;
    while (f && fgets(line, sizeof line, f))
        if (sscanf(line, "VmHWM: %ld kB", &kb) == 1)
            break;
    if (f)
        fclose(f);
    if (kb >= 0)
        return kb;
    struct rusage ru;
    return getrusage(RUSAGE_SELF, &ru) == 0 ? ru.ru_maxrss : 0;
}

/* The paper's quality measures of the selection against the inputs, as
 * the JSON `wpd metrics --json` prints, in *json (malloc'd). */
static int measure(char *const *inputs, int ninputs, const wpd_selection *sel,
                   const resample_options *o, char **json, wpd_error *err)
{
    double *orig = NULL;
    size_t n_orig = 0;
    wpd_metrics m;
    if (wpd_metrics_load_many((const char *const *)inputs, ninputs, &orig, &n_orig, NULL, err))
        return -1;
    int rc = wpd_metrics_compute(orig, n_orig, sel->xyz_out, sel->n, o->params.threads, &m, err);
    free(orig);
    if (rc)
        return -1;
    size_t len = 0;
    FILE *f = open_memstream(json, &len);
    if (!f)
        return wpd_fail(err, WPD_E_MEMORY, "out of memory for the metrics");
    wpd_metrics_write_json(f, &m);
    fclose(f);
    return 0;
}

static void print_summary(const wpd_run_info *info, const resample_options *o)
{
    const wpd_resample_result *r = info->run;
    const wpd_resample_timings *t = &r->time;
    printf("resampled %llu -> %zu points into %s\n", (unsigned long long)r->input_points,
           r->count, o->output ? o->output : o->per_input);
    if (info->classes)
        wpd_class_print_summary(info->classes);
    printf("  radius %.6g (estimate %.6g, first pass %zu points, %d passes, %zu before the "
           "exact count, %d sweeps)\n", r->radius, r->radius_estimate, r->first_pass_count,
           r->passes, r->poisson_count, r->exact_sweeps);
    if (o->params.smooth)
        printf("  smoothing: %d iterations and %d even steps, %zu points fixed (open Voronoi "
               "cell), %zu pulled back to the input surface, %zu kept still (no surface around "
               "them), %zu isolated, %zu moves shortened for spacing and cover, %zu input "
               "points' nearest samples from the exact count\n",
               o->params.iterations, o->params.even_iterations, r->open_cells,
               r->pulled_to_surface, r->non_surface, r->isolated, r->guarded_moves,
               r->cover_hinted);
    if (o->params.sharp)
        printf("  sharp features: %llu input points labelled, %llu output points%s; labels "
               "computed %llu (only where the Poisson pass needs them)\n",
               (unsigned long long)r->sharp_points, (unsigned long long)r->sharp_samples,
               o->edge_label ? " (field " WPD_EDGE_FIELD ")" : "",
               (unsigned long long)r->sharp_labelled);
    if (r->in_memory)
        printf("  in memory: one tile, no spill\n");
    else
        printf("  tiles: %d in %d colours (largest %llu points), spill %.1f MB -> %.1f MB on "
               "disk, working files beside it up to %.1f MB\n", r->tiles, r->colours,
               (unsigned long long)r->largest_tile, r->spill.raw_bytes / 1e6,
               r->spill.disk_bytes / 1e6, r->work_file_bytes / 1e6);
    printf("  time: bounds %.3f s, scan %.3f, %s %.3f, poisson %.3f, exact %.3f, smooth %.3f, "
           "merge %.3f, records and write %.3f, total %.3f (threads %d)\n", t->bounds, t->scan,
           r->in_memory ? "load" : "tile", t->tile, t->poisson, t->exact, t->smooth, t->merge,
           info->t_write, info->t_total,
           o->params.threads > 0 ? o->params.threads : omp_get_max_threads());
}

/* After the outputs are written: the metrics, the report, then every file
 * renamed into place. The report is written and finished (flushed, closed)
 * before any rename, so that one that cannot be written (disk full, data
 * lost at fsync or close) fails the run with no output in place; it is
 * renamed last, after the outputs it describes. */
static int deliver(wpd_run_info *info, char **metrics_json, const wpd_selection *sel,
                   wpd_output_files *p, const resample_options *o, wpd_error *err)
{
    if (o->metrics && measure(info->inputs, info->ninputs, sel, o, metrics_json, err))
        return -1;
    info->metrics_json = *metrics_json;
    /* A collection's night: its state recorded before the report, which
     * shows it; the state file is the commit (resample/collection.h). */
    if (o->coll && wpd_cli_collection_record(o->coll, info->run, info->classes, p->files,
                                             p->nout, err))
        return -1;
    if (o->report && wpd_report_write(o->report, info, &p->files[p->nout], err))
        return -1;
    if (o->coll ? wpd_collection_commit(&o->coll->c, p->files, p->nout, &p->files[p->nout], err)
                : wpd_outfile_rename_all(p->files, p->nout + 1, err))
        return -1;
    if (o->quiet || (!o->verbose && !isatty(STDOUT_FILENO)))
        return 0;
    print_summary(info, o);
    if (o->coll)
        wpd_cli_collection_print(o->coll, info->run->count, (unsigned long long)info->target,
                                 o->count_text);
    if (*metrics_json)
        printf("  quality (wpd metrics --json): %s", *metrics_json);
    /* The files are in place and complete: a summary that is lost still
     * fails the run, so that it is not lost unseen. */
    return wpd_stdout_flush(err);
}

/* The run by class (resample/classes.h): -n is the count of the classes
 * not named, a percentage one of their points. The merged result moves
 * into res, the classes' facts stay in cr. */
static int run_by_class(wpd_cloud *cloud, const resample_options *o,
                        const wpd_resample_options *ro, wpd_resample_result *res,
                        wpd_class_result *cr, wpd_run_info *info, wpd_error *err)
{
    wpd_class_options co;
    if (wpd_class_args_resolve(&o->classes, cloud, &co, err))
        return -1;
    char *end;
    double percent = strtod(o->count_text ? o->count_text : "0", &end);
    co.rest_count = ro->target;
    if (*end == '%')
        co.rest_percent = percent; /* parse_count checked it */
    /* A collection's radius samples the group whatever -n says: never
     * kept whole for a count (-n is then only compared with). */
    if (ro->fixed_radius > 0)
        co.rest_count = 1, co.rest_percent = -1;
    if (wpd_resample_by_class(cloud, &co, ro, o->quiet, cr, err))
        return -1;
    *res = cr->merged;
    memset(&cr->merged, 0, sizeof cr->merged);
    info->classes = cr;
    if (!(ro->fixed_radius > 0))
        info->target = cr->groups[0].target;
    return 0;
}

/* A collection's night (docs/ingest.md): which inputs are new (*nnew,
 * moved to the front), printed when there is none. Every rank. Returns 0,
 * or -1 with err set. */
static int plan_night(char **inputs, int ninputs, resample_options *o, int *nnew,
                      wpd_error *err)
{
    if (wpd_cli_collection_plan(o->coll, inputs, ninputs, o->write.overwrite, err))
        return -1;
    const wpd_night *n = &o->coll->night;
    *nnew = n->nnew;
    if (n->nnew == 0 && !o->quiet && wpd_par_rank(o->par) == 0)
        printf("every input is in the collection %s already: nothing to do\n",
               o->coll->c.label);
    /* A later night replaces --append's OUT; --rebuild every output. */
    if ((n->later && o->append) || o->rebuild)
        o->write.overwrite = 1;
    return 0;
}

/* The count -n asks for (a later night only compares with it; without -n,
 * --spacing alone: every point). A first night of a collection needs a
 * radius: not a copy of its inputs. */
static int night_target(const resample_options *o, uint64_t count, uint64_t *target,
                        wpd_error *err)
{
    *target = count;
    if (o->count_text && (parse_count(o->count_text, count, target) || *target == 0))
        return wpd_fail(err, WPD_E_USAGE, "-n %s: the point count must be a positive number or "
                        "percentage", o->count_text);
    if (o->coll && !o->coll->night.later && !o->spacing && *target >= count &&
        !wpd_class_args_used(&o->classes))
        return wpd_fail(err, WPD_E_USAGE, "%s: -n %s keeps every input point: a collection "
                        "needs a spacing (give a smaller -n, or --spacing D)",
                        o->coll->c.label, o->count_text);
    return 0;
}

/* The report is written whatever is there (a cron job rewrites its report
 * every night), but never over an input, an output or a file a collection
 * keeps: refused before any work, as an output that is an input is. The
 * collection's files are checked once its state is read
 * (report_keeps_off_collection): it records earlier nights' outputs. */
static int report_check(const resample_options *o, char *const *inputs, int ninputs,
                        wpd_error *err)
{
    if (!o->report)
        return 0;
    if (wpd_path_is_one_of(o->report, inputs, ninputs))
        return wpd_fail(err, WPD_E_USAGE, "%s: the report would replace an input", o->report);
    if (o->output && wpd_path_same_place(o->report, o->output))
        return wpd_fail(err, WPD_E_USAGE, "%s: the report and the output are one file",
                        o->report);
    char buf[WPD_PATH_BYTES];
    for (int i = 0; o->per_input && i < ninputs; i++)
        if (wpd_path_same_place(o->report, wpd_per_input_path(o->per_input, inputs[i], buf,
                                                              sizeof buf)))
            return wpd_fail(err, WPD_E_USAGE, "%s: the report would replace the output of %s",
                            o->report, inputs[i]);
    return 0;
}

static int report_keeps_off_collection(const resample_options *o, wpd_error *err)
{
    if (o->report && wpd_collection_owns(&o->coll->c, o->report))
        return wpd_fail(err, WPD_E_USAGE, "%s: the report would replace a file the collection "
                        "%s keeps", o->report, o->coll->c.label);
    return 0;
}

/* The run; rank 0 (the writer) also writes the outputs and delivers them
 * once every rank has succeeded. */
static int resample(char **inputs, int ninputs, resample_options *o, wpd_error *err)
{
    wpd_cloud *cloud = NULL;
    char buf[1024];
    const char *dir = spill_dir(o, buf, sizeof buf);
    if (report_check(o, inputs, ninputs, err))
        return wpd_ranks_outcome(o->par, -1, err);
    if (o->coll) {
        int nnew = 0, rc = plan_night(inputs, ninputs, o, &nnew, err);
        if (!rc && nnew > 0)
            rc = report_keeps_off_collection(o, err);
        if (rc || nnew == 0)
            return wpd_ranks_outcome(o->par, rc, err);
        ninputs = nnew;
    }
    if (wpd_output_check(inputs, ninputs, o->output, o->per_input, o->write.overwrite, err) ||
        !(cloud = wpd_read_open(inputs, ninputs, dir, err)))
        return wpd_ranks_outcome(o->par, -1, err);
    int writer = wpd_par_rank(o->par) == 0, agreed = 0;
    if (!o->quiet)
        wpd_cloud_print_warnings(cloud, "resample", stderr);
    for (int i = 0; o->edge_label && !o->quiet && i < wpd_cloud_nfiles(cloud); i++)
        if (wpd_schema_find(&wpd_cloud_header(cloud, i)->schema, WPD_EDGE_FIELD) >= 0)
            fprintf(stderr, "wpd resample: notice: %s has a field " WPD_EDGE_FIELD ": the "
                    "output's gets the sharp-feature labels\n", wpd_cloud_header(cloud, i)->path);
    uint64_t target;
    int rc = -1;
    wpd_selection sel = {0};
    wpd_resample_result res = {0};
    wpd_class_result classes = {0};
    wpd_output_files pending = {0};
    char *metrics_json = NULL;
    wpd_run_info info = {.ninputs = ninputs, .inputs = inputs, .output = o->output,
                         .per_input = o->per_input, .params = &o->params, .run = &res,
                         .collection = o->coll};
    double t0 = omp_get_wtime();
    if (night_target(o, wpd_cloud_count(cloud), &target, err))
        goto done;
    /* Every rank: with --per-input each may write some of the outputs. */
    if (wpd_output_files_open(&pending, cloud, o->per_input, err))
        goto done;
    if (!o->mem_bytes)
        o->mem_bytes = default_mem();
    if (wpd_ranks_same_budget(o->par, &o->mem_bytes, err))
        goto done;
    output_lattice(cloud, o, o->params.resolution);
    if (target >= wpd_cloud_count(cloud) && !o->quiet && !wpd_class_args_used(&o->classes) &&
        !o->coll)
        fprintf(stderr, "wpd resample: notice: -n %llu >= %llu input points: copying the "
                "input\n", (unsigned long long)target,
                (unsigned long long)wpd_cloud_count(cloud));
    info.target = target;
    info.mem_bytes = o->mem_bytes;
    info.threads = o->params.threads > 0 ? o->params.threads : omp_get_max_threads();
    wpd_resample_options ro = {.target = target, .mem_bytes = o->mem_bytes, .tmpdir = dir,
                               .min_tiles = o->min_tiles, .params = o->params,
                               .progress = &o->progress, .par = o->par};
    if (o->coll)
        wpd_cli_collection_options(o->coll, &ro);
    rc = wpd_class_args_used(&o->classes)
             ? run_by_class(cloud, o, &ro, &res, &classes, &info, err)
             : wpd_resample_run(cloud, &ro, &res, err);
    /* The selection borrows the result's per-file facts; its points come
     * from the runs (or the class groups' runs) while they are written. */
    sel = wpd_output_selection(&res, &classes, o->edge_label);
    if (rc == 0 && o->edge_label && !res.labelled && res.count)
        rc = wpd_fail(err, WPD_E_USAGE, "internal error: no sharp-feature labels to write");
    if (rc == 0 && o->metrics && !(sel.xyz_out = malloc((res.count ? res.count : 1) * 3 *
                                                         sizeof *sel.xyz_out)))
        rc = wpd_fail(err, WPD_E_MEMORY, "out of memory for the metrics");
    /* Where the ranks share the reading no rank reads everything: the scan
     * summed the ranks' counts (a run by class reads whole on rank 0). */
    info.dropped = wpd_par_ranks(o->par) > 1 && !classes.ngroups ? res.dropped
                                                                 : wpd_cloud_dropped(cloud);
    if (rc == 0 && info.dropped && !o->quiet)
        fprintf(stderr, "wpd resample: warning: %llu points with non-finite coordinates "
                "dropped\n", (unsigned long long)info.dropped);
    /* Passes stopped at their limit below n: repeated points are one sample at any radius. */
    if (rc == 0 && !classes.ngroups && res.count < target && target < res.input_points &&
        !o->quiet && !(ro.fixed_radius > 0))
        fprintf(stderr, "wpd resample: warning: %zu points written, not the %llu asked for: "
                "%d Poisson passes down to radius %g kept no more (repeated points?)\n",
                res.count, (unsigned long long)target, res.passes, res.radius);
    double tw = omp_get_wtime();
    /* The records pass reads every input point: progress in those. */
    wpd_progress_phase(&o->progress, "write", res.input_points, "points");
    wpd_selection_target to = {o->output, o->per_input, &o->write, o->mem_bytes,
                               o->params.threads, &o->progress, o->par, dir};
    if (rc == 0)
        rc = wpd_output_write(&sel, cloud, &to, pending.files, &info.writers, err);
    wpd_progress_end(&o->progress);
    info.t_write = omp_get_wtime() - tw;
    info.t_total = omp_get_wtime() - t0;
    info.peak_rss_kb = peak_rss_kb();
    info.records_cached = wpd_cloud_cache_hits(cloud);
    rc = wpd_ranks_run_facts(o->par, rc, &info, err);
    rc = wpd_ranks_outcome(o->par, rc, err);
    agreed = 1;
    /* Outputs another rank wrote are rank 0's to put in place (it has
     * their names): they must outlive this rank. */
    if (rc == 0 && !writer && pending.files)
        wpd_outfile_clear_all(pending.files, pending.nout + 1);
    if (rc == 0 && writer)
        rc = deliver(&info, &metrics_json, &sel, &pending, o, err);
done:
    if (!agreed)
        rc = wpd_ranks_outcome(o->par, rc, err);
    wpd_output_files_close(&pending);
    wpd_resample_result_free(&res);
    wpd_class_result_free(&classes);
    free(sel.xyz_out);
    free(metrics_json);
    wpd_cloud_close(cloud);
    return rc;
}

/* Removes what runs killed outright (SIGKILL, power loss) left behind:
 * their spill, run, blob and record cache directories and, with outputs,
 * temporary outputs. Live runs' are kept. A collection's temporary
 * outputs may be named by its committed state: only rank 0 sweeps them,
 * after the recovery (resample/collection.h). */
static void sweep_leftovers(const resample_options *o, int outputs)
{
    char dir[1024];
    const char *base = spill_dir(o, dir, sizeof dir);
    wpd_tmpdir_sweep_stale(base, "wpd-spill");
    wpd_tmpdir_sweep_stale(base, "wpd-runs");
    wpd_tmpdir_sweep_stale(base, "wpd-blobs");
    wpd_tmpdir_sweep_stale(base, "wpd-cache");
    wpd_output_sweep_parts(base, o->output);
    if (o->output && outputs)
        wpd_outfile_sweep_stale(o->output);
}

/* The run with the output locked (rank 0: locked by the caller): a
 * collection's unfinished night completed or rolled back first, then the
 * leftovers swept. */
static int locked_run(char **inputs, int ninputs, resample_options *o, wpd_error *err)
{
    int writer = wpd_par_rank(o->par) == 0;
    if (o->coll && writer && wpd_cli_collection_recover(o->coll, o->quiet, err))
        return wpd_ranks_outcome(o->par, -1, err);
    sweep_leftovers(o, writer || !o->coll);
    int rc = resample(inputs, ninputs, o, err);
    if (o->coll && o->coll->marked)
        wpd_collection_unmark(&o->coll->c);
    return rc;
}

/* --per-input's folder must exist: a cron line with a mistyped folder is
 * told so in one line, not by a file the run failed to create in it. */
static int per_input_folder_check(const char *dir, wpd_error *err)
{
    struct stat st;
    if (stat(dir, &st) != 0)
        return errno == ENOENT
                   ? wpd_fail(err, WPD_E_USAGE, "%s: no such folder (create it first)", dir)
                   : wpd_fail_errno(err, "%s", dir);
    if (!S_ISDIR(st.st_mode))
        return wpd_fail(err, WPD_E_USAGE, "%s: not a folder (--per-input names a folder)", dir);
    return 0;
}

/* The command after its options are parsed. */
static int run_command(char **inputs, int ninputs, resample_options *o)
{
    if (o->params.threads > 0)
        omp_set_num_threads(o->params.threads);
    wpd_error err = {0};
    if (o->per_input && per_input_folder_check(o->per_input, &err))
        return wpd_par_rank(o->par) == 0 ? wpd_report_error("resample", &err) : (int)err.code;
    if (o->skip_existing &&
        (ninputs = wpd_output_keep_stale(inputs, ninputs, o->per_input)) == 0) {
        if (!o->quiet)
            printf("every output in %s is newer than its input: nothing to do\n", o->per_input);
        return 0;
    }
    const char *target = o->output ? o->output : o->per_input;
    wpd_cli_collection coll;
    int writer = wpd_par_rank(o->par) == 0, lock = -1, rc;
    if ((o->per_input || o->append) &&
        wpd_cli_collection_init(&coll, o->per_input, o->append ? o->output : NULL, &o->params,
                                &o->classes, o->spacing, o->rebuild, o->skip_existing, o->par,
                                &err) == 0)
        o->coll = &coll;
    /* Rank 0 alone takes the output lock; the others learn of its failure
     * in the run's first agreement. */
    if ((o->per_input || o->append) && !o->coll) {
        rc = wpd_ranks_outcome(o->par, -1, &err);
    } else if (writer && (lock = wpd_output_lock(target, &err)) < 0) {
        rc = wpd_ranks_outcome(o->par, -1, &err);
    } else {
        rc = locked_run(inputs, ninputs, o, &err);
        if (writer)
            wpd_output_unlock(lock, target);
    }
    if (o->per_input || o->append)
        wpd_cli_collection_free(&coll);
    if (rc == 0)
        return 0;
    return writer ? wpd_report_error("resample", &err) : (int)err.code;
}

int wpd_cmd_resample(int argc, char **argv, const wpd_par *par)
{
    resample_options o;
    int first;
    int rc = parse_args(argc, argv, &o, &first);
    o.par = par;
    if (rc == 0 && wpd_par_rank(par) != 0) { /* progress and notes from rank 0 */
        o.quiet = 1;
        wpd_progress_init(&o.progress, WPD_PROGRESS_QUIET);
    }
    if (rc == 0)
        rc = run_command(argv + first, argc - first, &o);
    else
        rc = rc > 0 ? 0 : WPD_E_USAGE;
    wpd_class_args_free(&o.classes); /* on every path: also after a usage error */
    return rc;
}
