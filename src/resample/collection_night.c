/* collection_night.c - a night of a collection (collection.h): the
 * command checked against the state, the inputs sorted into new,
 * unchanged and changed ones, the plan handed to every rank, and the state
 * after the night. */
#include "resample/collection.h"

#include <libgen.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "common/bytes.h"
#include "common/version.h"
#include "io/cloud.h"

/* The reach of a later night (collection.h): every phase looks at most
 * 3 r from a new input point (the Poisson pass r, the exact count's costs
 * the halo 2.5 r, smoothing's guard 1.55 r around a sample that moved
 * less than r). */
#define REACH_RADII 3.0

static const char *name_of(const char *path)
{
    const char *slash = strrchr(path, '/');
    return slash ? slash + 1 : path;
}

/* ------------------------------------------------------------ the checks */

static const char *estimate_name(int method)
{
    return method == WPD_RADIUS_PAPER ? "paper" : "multiscale";
}

/* One line naming the option whose value differs from the state's. */
static int contradicts(const wpd_collection *c, const char *option, const char *ours,
                       const char *theirs, wpd_error *err)
{
    return wpd_fail(err, WPD_E_USAGE, "%s: the collection was resampled with %s %s, this run "
                    "has %s (resample the collection with --rebuild to change it)", c->label,
                    option, theirs, ours);
}

static int check_text(const wpd_collection *c, const char *option, const char *ours,
                      const char *theirs, wpd_error *err)
{
    ours = ours && *ours ? ours : "(none)";
    theirs = theirs && *theirs ? theirs : "(none)";
    return strcmp(ours, theirs) ? contradicts(c, option, ours, theirs, err) : 0;
}

static int check_number(const wpd_collection *c, const char *option, double ours,
                        double theirs, wpd_error *err)
{
    char a[40], b[40];
    snprintf(a, sizeof a, "%.17g", ours);
    snprintf(b, sizeof b, "%.17g", theirs);
    return ours != theirs ? contradicts(c, option, a, b, err) : 0;
}

static int check_options(const wpd_collection *c, const wpd_night_request *req, wpd_error *err)
{
    const wpd_coll_options *o = &req->opt, *s = &c->opt;
    char seed[2][24];
    snprintf(seed[0], sizeof seed[0], "%llu", (unsigned long long)o->seed);
    snprintf(seed[1], sizeof seed[1], "%llu", (unsigned long long)s->seed);
    if (check_number(c, "--lambda", o->lambda, s->lambda, err) ||
        check_number(c, "--voxel-frac", o->voxel_frac, s->voxel_frac, err) ||
        check_text(c, "--radius-estimate", estimate_name(o->radius_method),
                   estimate_name(s->radius_method), err) ||
        check_number(c, "-k", o->k, s->k, err) ||
        check_number(c, "--iterations", o->iterations, s->iterations, err) ||
        check_number(c, "--even-steps", o->even_steps, s->even_steps, err) ||
        check_text(c, "smoothing", o->smooth ? "on" : "off (--no-smooth)",
                   s->smooth ? "on" : "off (--no-smooth)", err) ||
        check_text(c, "--sharp", o->sharp ? "on" : "off", s->sharp ? "on" : "off", err) ||
        check_text(c, "--seed", seed[0], seed[1], err) ||
        check_text(c, "--drop-class", o->drop, s->drop, err) ||
        check_text(c, "--keep-class", o->keep, s->keep, err) ||
        check_text(c, "--class-field", o->class_field, s->class_field, err))
        return -1;
    if (req->spacing > 0 && !(c->spacing && req->spacing == c->radius)) {
        char a[40], b[64];
        snprintf(a, sizeof a, "%.17g", req->spacing);
        snprintf(b, sizeof b, c->spacing ? "%.17g" : "radius %.17g (from -n)", c->radius);
        return contradicts(c, "--spacing", a, b, err);
    }
    return 0;
}

/* Every output the state lists is there with the size it had: a folder
 * edited by hand must not be mistaken for the collection. */
static int check_outputs(const wpd_collection *c, wpd_error *err)
{
    for (int i = 0; i < c->noutputs; i++) {
        const wpd_coll_output *o = &c->outputs[i];
        char path[1400];
        struct stat st;
        snprintf(path, sizeof path, "%s/%s", c->dir, o->name);
        if (stat(path, &st) != 0)
            return wpd_fail(err, WPD_E_INPUT, "%s: %s, an output of the collection, is missing "
                            "(the folder was changed by hand?): resample the collection with "
                            "--rebuild", c->label, path);
        if ((uint64_t)st.st_size != o->size)
            return wpd_fail(err, WPD_E_INPUT, "%s: %s has %lld bytes, the collection wrote %llu "
                            "(the folder was changed by hand?): resample the collection with "
                            "--rebuild", c->label, path, (long long)st.st_size,
                            (unsigned long long)o->size);
    }
    return 0;
}

/* The file names of inputs[0..n), sorted (each with its place among the
 * inputs), in a new array; NULL with err set when out of memory. */
static wpd_coll_name *sorted_names(char *const *inputs, int n, wpd_error *err)
{
    wpd_coll_name *names = malloc((size_t)(n > 0 ? n : 1) * sizeof *names);
    if (!names) {
        wpd_fail(err, WPD_E_MEMORY, "out of memory");
        return NULL;
    }
    for (int i = 0; i < n; i++)
        names[i] = (wpd_coll_name){name_of(inputs[i]), i};
    wpd_coll_names_sort(names, n);
    return names;
}

/* --rebuild replaces every output: each input of the state must be given,
 * or its output would stay beside a state that no longer knows it. */
static int check_rebuild(const wpd_collection *c, char *const *inputs, int n, wpd_error *err)
{
    wpd_coll_name *given = sorted_names(inputs, n, err);
    if (!given)
        return -1;
    int rc = 0;
    for (int i = 0; rc == 0 && i < c->ninputs; i++)
        if (wpd_coll_names_find(given, n, c->inputs[i].name) < 0)
            rc = wpd_fail(err, WPD_E_USAGE, "%s: --rebuild resamples the whole collection: "
                          "its input %s is not among the inputs", c->label, c->inputs[i].name);
    free(given);
    return rc;
}

/* ------------------------------------------------------------ the inputs */

/* Two inputs of one file name (a collection tells its inputs by name). */
static int twice(char *const *inputs, int n, wpd_error *err)
{
    wpd_coll_name *names = sorted_names(inputs, n, err);
    if (!names)
        return -1;
    int rc = 0;
    for (int i = 1; rc == 0 && i < n; i++)
        if (!strcmp(names[i - 1].name, names[i].name))
            rc = wpd_fail(err, WPD_E_USAGE, "%s and %s: one file name twice (a collection "
                          "tells its inputs by name)", inputs[names[i - 1].at],
                          inputs[names[i].at]);
    free(names);
    return rc;
}

/* New inputs first (in the order given), the unchanged ones after; a
 * changed one is refused. order[k]: the input now at place k. */
static int sort_inputs(const wpd_collection *c, char *const *inputs, int n, int *order,
                       wpd_night *night, wpd_error *err)
{
    int k = 0;
    for (int pass = 0; pass < 2; pass++)
        for (int i = 0; i < n; i++) {
            const wpd_coll_input *e = night->later ? wpd_collection_find(c, name_of(inputs[i])) : NULL;
            struct stat st;
            if (e && stat(inputs[i], &st) != 0)
                return wpd_fail_errno(err, "%s: cannot read", inputs[i]);
            int same = e && (uint64_t)st.st_size == e->size &&
                       (int64_t)st.st_mtim.tv_sec * 1000000000 + st.st_mtim.tv_nsec ==
                           e->mtime_ns;
            if (pass == 0 && e && !same)
                return wpd_fail(err, WPD_E_USAGE, "%s: already in the collection %s (written on "
                                "night %d); resample the collection with --rebuild to take "
                                "the new version", inputs[i], c->label, e->night);
            if ((pass == 0) == !e)
                order[k++] = i;
        }
    /* --per-input refuses them as outputs written twice (output.h) */
    if (c->append[0] && twice(inputs, n, err))
        return -1;
    night->skipped = 0;
    for (int i = 0; i < n; i++)
        night->skipped += night->later && wpd_collection_find(c, name_of(inputs[i])) != NULL;
    night->nnew = n - night->skipped;
    return 0;
}

static void apply_order(char **inputs, int n, const int *order)
{
    char **was = malloc((size_t)(n ? n : 1) * sizeof *was);
    if (!was)
        return; /* callers check the order came through: see plan_here */
    memcpy(was, inputs, (size_t)n * sizeof *was);
    for (int k = 0; k < n; k++)
        inputs[k] = was[order[k]];
    free(was);
}

/* ------------------------------------------------------------ the plan */

/* Rank 0's part of wpd_collection_plan: order gets the new order. */
static int plan_here(wpd_collection *c, const wpd_night_request *req, char **inputs, int n,
                     int *order, wpd_night *night, wpd_error *err)
{
    if (wpd_collection_load(c, err)) {
        if (!req->rebuild)
            return -1;
        wpd_error_clear(err); /* --rebuild replaces a state that does not read */
    }
    night->later = c->exists && !req->rebuild;
    if (req->rebuild && c->exists && check_rebuild(c, inputs, n, err))
        return -1;
    if (night->later && (check_options(c, req, err) || check_outputs(c, err)))
        return -1;
    night->number = night->later ? c->nights + 1 : 1;
    night->radius = night->later ? c->radius : req->spacing;
    night->factor = night->later ? c->factor : req->spacing > 0 ? 1 : 0;
    if (sort_inputs(c, inputs, n, order, night, err))
        return -1;
    if (night->nnew == 0)
        return 0;
    char **sorted = malloc((size_t)n * sizeof *sorted);
    if (!sorted)
        return wpd_fail(err, WPD_E_MEMORY, "out of memory");
    for (int k = 0; k < n; k++)
        sorted[k] = inputs[order[k]];
    int rc = wpd_collection_facts(sorted, night, err);
    free(sorted);
    if (rc || !night->later)
        return rc;
    return wpd_collection_fixed(c, night, REACH_RADII * c->radius, req->keep,
                                req->opt.class_field, err);
}

/* The plan as bytes, rank 0 to the others. */
static void pack_plan(const wpd_night *night, const int *order, int n, wpd_bytes *out)
{
    uint64_t head[6] = {(uint64_t)night->number, (uint64_t)night->later,
                        (uint64_t)night->nnew, (uint64_t)night->skipped, night->nfixed,
                        (uint64_t)night->outputs_read};
    for (int k = 0; k < 6; k++)
        wpd_bytes_put_u64(out, head[k]);
    wpd_bytes_put(out, &night->radius, sizeof night->radius);
    wpd_bytes_put(out, &night->factor, sizeof night->factor);
    for (int k = 0; k < n; k++)
        wpd_bytes_put_u64(out, (uint64_t)order[k]);
    wpd_bytes_put(out, night->fixed, 3 * night->nfixed * sizeof *night->fixed);
}

static int unpack_plan(wpd_bytes_in *in, int n, int *order, wpd_night *night, wpd_error *err)
{
    uint64_t head[6];
    for (int k = 0; k < 6; k++)
        head[k] = wpd_bytes_get_u64(in);
    night->number = (int)head[0], night->later = (int)head[1], night->nnew = (int)head[2];
    night->skipped = (int)head[3], night->nfixed = head[4], night->outputs_read = (int)head[5];
    if (wpd_bytes_get(in, &night->radius, sizeof night->radius) ||
        wpd_bytes_get(in, &night->factor, sizeof night->factor) || head[2] > (uint64_t)n ||
        head[4] > in->len / 24)
        return wpd_fail(err, WPD_E_IO, "the collection's plan from rank 0 does not add up");
    for (int k = 0; k < n; k++)
        if ((order[k] = (int)wpd_bytes_get_u64(in)) < 0 || order[k] >= n)
            return wpd_fail(err, WPD_E_IO, "the collection's plan from rank 0 does not add up");
    night->fixed = malloc((night->nfixed ? night->nfixed : 1) * 3 * sizeof *night->fixed);
    if (!night->fixed)
        return wpd_fail(err, WPD_E_MEMORY, "out of memory for %zu fixed samples", night->nfixed);
    if (wpd_bytes_get(in, night->fixed, 3 * night->nfixed * sizeof *night->fixed))
        return wpd_fail(err, WPD_E_IO, "the collection's plan from rank 0 is cut short");
    return 0;
}

/* Every rank gets rank 0's plan (the others' inputs are the same list). */
static int share_plan(const wpd_par *par, int n, int *order, wpd_night *night, wpd_error *err)
{
    int ranks = wpd_par_ranks(par), rank = wpd_par_rank(par);
    wpd_bytes mine = {0};
    if (rank == 0)
        pack_plan(night, order, n, &mine);
    if (mine.failed && err->code == WPD_OK)
        wpd_fail(err, WPD_E_MEMORY, "out of memory for the collection's plan");
    size_t *off = calloc((size_t)ranks, sizeof *off), *len = calloc((size_t)ranks, sizeof *len);
    uint8_t *all = NULL;
    int rc = off && len ? 0 : -1;
    if (rc && err->code == WPD_OK)
        wpd_fail(err, WPD_E_MEMORY, "out of memory");
    if (wpd_par_agree(par, err) || rc ||
        wpd_par_gather_all(par, mine.p, mine.len, &all, off, len, err))
        rc = -1;
    if (rc == 0 && rank != 0) {
        wpd_bytes_in in = {all + off[0], len[0], 0, 0};
        rc = unpack_plan(&in, n, order, night, err);
    }
    free(all), free(off), free(len);
    wpd_bytes_free(&mine);
    return rc;
}

int wpd_collection_plan(wpd_collection *c, const wpd_night_request *req, char **inputs,
                        int ninputs, wpd_night *night, wpd_error *err)
{
    memset(night, 0, sizeof *night);
    int *order = malloc((size_t)(ninputs ? ninputs : 1) * sizeof *order);
    int rc = order ? 0 : wpd_fail(err, WPD_E_MEMORY, "out of memory");
    wpd_error_clear(err);
    if (rc == 0 && wpd_par_rank(req->par) == 0)
        rc = plan_here(c, req, inputs, ninputs, order, night, err);
    if (wpd_par_ranks(req->par) > 1 && share_plan(req->par, ninputs, order, night, err))
        rc = -1;
    if (rc == 0)
        apply_order(inputs, ninputs, order);
    free(order);
    return rc;
}

/* ------------------------------------------------------------ the record */

static char *dup_name(const char *path)
{
    char buf[1200];
    snprintf(buf, sizeof buf, "%s", path);
    return strdup(basename(buf));
}

/* The output named name in c's list (added when new). */
static wpd_coll_output *output_entry(wpd_collection *c, const char *name)
{
    for (int i = 0; i < c->noutputs; i++)
        if (!strcmp(c->outputs[i].name, name))
            return &c->outputs[i];
    wpd_coll_output *grown = realloc(c->outputs, (size_t)(c->noutputs + 1) * sizeof *grown);
    if (!grown)
        return NULL;
    c->outputs = grown;
    wpd_coll_output *o = &c->outputs[c->noutputs];
    if (!(o->name = strdup(name)))
        return NULL;
    o->size = 0;
    c->noutputs++;
    return o;
}

/* A first night: the state from scratch (c's location kept). */
static int start_over(wpd_collection *c, const wpd_night_request *req,
                      const wpd_night_result *res)
{
    wpd_collection_free(c);
    c->radius = res->radius;
    c->factor = res->factor;
    c->spacing = req->spacing > 0;
    c->nights = 0;
    c->opt = req->opt;
    c->opt.drop = strdup(req->opt.drop ? req->opt.drop : "");
    c->opt.keep = strdup(req->opt.keep ? req->opt.keep : "");
    c->opt.class_field = strdup(req->opt.class_field ? req->opt.class_field : "");
    return c->opt.drop && c->opt.keep && c->opt.class_field ? 0 : -1;
}

/* The night's outputs and their renames into c. */
static int record_outputs(wpd_collection *c, const wpd_night_result *res)
{
    c->npending = 0;
    free(c->pending);
    if (!(c->pending = calloc((size_t)(res->nfiles ? res->nfiles : 1), sizeof *c->pending)))
        return -1;
    for (int i = 0; i < res->nfiles; i++) {
        const wpd_outfile *f = &res->files[i];
        struct stat st;
        if (!f->temp_path[0])
            continue;
        if (stat(f->temp_path, &st) != 0)
            return -2;
        wpd_coll_rename *r = &c->pending[c->npending++];
        r->from = dup_name(f->temp_path);
        r->to = dup_name(f->final_path);
        wpd_coll_output *o = r->to ? output_entry(c, r->to) : NULL;
        if (!r->from || !o)
            return -1;
        o->size = (uint64_t)st.st_size;
    }
    return 0;
}

int wpd_collection_record(wpd_collection *c, const wpd_night_request *req,
                          const wpd_night *night, const wpd_night_result *res,
                          wpd_error *err)
{
    if (!night->later && start_over(c, req, res))
        return wpd_fail(err, WPD_E_MEMORY, "out of memory");
    snprintf(c->wpd_version, sizeof c->wpd_version, "%s", WPD_VERSION);
    c->nights = night->number;
    wpd_coll_input *grown = realloc(c->inputs, (size_t)(c->ninputs + night->nnew) *
                                                   sizeof *grown);
    if (!grown)
        return wpd_fail(err, WPD_E_MEMORY, "out of memory");
    c->inputs = grown;
    uint64_t first = res->first;
    for (int k = 0; k < night->nnew; k++) {
        wpd_coll_input *e = &c->inputs[c->ninputs];
        *e = night->fresh[k];
        e->name = strdup(night->fresh[k].name);
        e->output = strdup(c->append[0] ? c->append : night->fresh[k].name);
        c->ninputs++;
        if (!e->name || !e->output)
            return wpd_fail(err, WPD_E_MEMORY, "out of memory");
        e->first = c->append[0] ? first : 0;
        e->points = res->points[k];
        for (int a = 0; a < 3; a++) {
            e->out_bounds[a] = res->bounds[k].min[a];
            e->out_bounds[3 + a] = res->bounds[k].max[a];
        }
        e->night = night->number;
        first += e->points;
    }
    int rc = record_outputs(c, res);
    if (rc == -2)
        return wpd_fail_errno(err, "%s: a finished output is gone", c->label);
    return rc ? wpd_fail(err, WPD_E_MEMORY, "out of memory") : 0;
}
