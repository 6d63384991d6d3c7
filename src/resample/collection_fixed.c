/* collection_fixed.c - what a night reads besides its inputs
 * (collection.h): the file facts and boxes of its new inputs, and the
 * samples earlier nights wrote within reach of them. Only the outputs
 * whose samples' box (from the state) comes within reach of a new input's
 * box are opened, and in them only the records of those inputs: a night
 * reads the neighbours of its tiles, not the collection. */
#include "resample/collection.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "io/reader.h"

enum { FIXED_BATCH = 65536 };

/* Squared distance from point p to box b (min x y z, max x y z). */
static double box_distance2(const double b[6], const double p[3])
{
    double s = 0;
    for (int a = 0; a < 3; a++) {
        double d = p[a] < b[a] ? b[a] - p[a] : p[a] > b[3 + a] ? p[a] - b[3 + a] : 0;
        s += d * d;
    }
    return s;
}

/* Squared distance between boxes a and b (empty boxes: infinite). */
static double box_gap2(const double a[6], const double b[6])
{
    double s = 0;
    for (int k = 0; k < 3; k++) {
        if (!(a[k] <= a[3 + k]) || !(b[k] <= b[3 + k]))
            return INFINITY;
        double d = a[k] > b[3 + k] ? a[k] - b[3 + k] : b[k] > a[3 + k] ? b[k] - a[3 + k] : 0;
        s += d * d;
    }
    return s;
}

/* ------------------------------------------------------------ new inputs */

/* The box of every finite point of r's file (a pass over it). */
static int points_box(wpd_reader *r, double b[6], wpd_error *err)
{
    wpd_batch batch;
    if (wpd_batch_init(&batch, FIXED_BATCH, wpd_reader_header(r)->schema.record_size))
        return wpd_fail(err, WPD_E_MEMORY, "out of memory");
    wpd_reader_positions_only(r, 1);
    for (int a = 0; a < 3; a++)
        b[a] = INFINITY, b[3 + a] = -INFINITY;
    long got;
    while ((got = wpd_reader_read(r, &batch, err)) > 0)
        for (long i = 0; i < got; i++)
            for (int a = 0; a < 3; a++) {
                double v = batch.xyz[3 * i + a];
                b[a] = fmin(b[a], v), b[3 + a] = fmax(b[3 + a], v);
            }
    wpd_batch_free(&batch);
    return got < 0 ? -1 : 0;
}

/* One input's facts: its file's size and mtime, and its box (a LAS
 * header's when it has one; the engine's scan checks it against the
 * points). */
static int input_facts(const char *path, wpd_coll_input *e, wpd_error *err)
{
    struct stat st;
    if (stat(path, &st) != 0)
        return wpd_fail_errno(err, "%s: cannot read", path);
    const char *slash = strrchr(path, '/');
    if (!(e->name = strdup(slash ? slash + 1 : path)))
        return wpd_fail(err, WPD_E_MEMORY, "out of memory");
    e->size = (uint64_t)st.st_size;
    e->mtime_ns = (int64_t)st.st_mtim.tv_sec * 1000000000 + st.st_mtim.tv_nsec;
    wpd_reader *r = wpd_reader_open(path, err);
    if (!r)
        return -1;
    const wpd_header *h = wpd_reader_header(r);
    int declared = h->format == WPD_FMT_LAS;
    for (int a = 0; a < 3 && declared; a++) {
        declared = isfinite(h->las.min[a]) && isfinite(h->las.max[a]) &&
                   h->las.min[a] <= h->las.max[a];
        e->bounds[a] = h->las.min[a], e->bounds[3 + a] = h->las.max[a];
    }
    int rc = declared ? 0 : points_box(r, e->bounds, err);
    wpd_reader_close(r);
    return rc;
}

int wpd_collection_facts(char *const *inputs, wpd_night *night, wpd_error *err)
{
    night->fresh = calloc((size_t)(night->nnew ? night->nnew : 1), sizeof *night->fresh);
    if (!night->fresh)
        return wpd_fail(err, WPD_E_MEMORY, "out of memory");
    for (int k = 0; k < night->nnew; k++)
        if (input_facts(inputs[k], &night->fresh[k], err))
            return -1;
    return 0;
}

/* ------------------------------------------------------------ fixed samples */

typedef struct gather {
    const wpd_night *night;
    double reach2;
    const uint8_t *keep;      /* kept classes, or NULL */
    int class_dim;            /* their field in the output's schema */
    double *xyz;              /* grows */
    size_t n, cap;
} gather;

/* Whether p lies within reach of a new input's box. */
static int within_reach(const gather *g, const double *p)
{
    for (int k = 0; k < g->night->nnew; k++)
        if (box_distance2(g->night->fresh[k].bounds, p) <= g->reach2)
            return 1;
    return 0;
}

static int take(gather *g, const wpd_batch *b, const wpd_schema *schema, size_t got)
{
    for (size_t i = 0; i < got; i++) {
        const double *p = b->xyz + 3 * i;
        if (g->keep) {
            long cls = wpd_class_of(&schema->dims[g->class_dim], b->records + i * b->record_size);
            if (cls >= 0 && g->keep[cls])
                continue; /* a kept point, not a sample */
        }
        if (!within_reach(g, p))
            continue;
        if (g->n == g->cap) {
            size_t cap = g->cap ? 2 * g->cap : 4096;
            double *grown = realloc(g->xyz, 3 * cap * sizeof *grown);
            if (!grown)
                return -1;
            g->xyz = grown, g->cap = cap;
        }
        memcpy(g->xyz + 3 * g->n++, p, 3 * sizeof *p);
    }
    return 0;
}

/* The records first .. first + count - 1 of an opened output. */
static int read_range(gather *g, wpd_reader *r, const char *path, uint64_t first,
                      uint64_t count, wpd_error *err)
{
    const wpd_header *h = wpd_reader_header(r);
    if (first + count > h->point_count)
        return wpd_fail(err, WPD_E_INPUT, "%s: holds %llu points, the collection has records "
                        "up to %llu there (resample the collection with --rebuild)", path,
                        (unsigned long long)h->point_count, (unsigned long long)(first + count));
    wpd_batch b;
    if (wpd_batch_init(&b, FIXED_BATCH, h->schema.record_size))
        return wpd_fail(err, WPD_E_MEMORY, "out of memory");
    int rc = wpd_reader_seek_range(r, first, first + count, err);
    if (rc == 0)
        wpd_reader_positions_only(r, g->keep == NULL);
    long got;
    while (rc == 0 && (got = wpd_reader_read(r, &b, err)) != 0)
        rc = got < 0 ? -1 : take(g, &b, &h->schema, (size_t)got)
                              ? wpd_fail(err, WPD_E_MEMORY, "out of memory for fixed samples")
                              : 0;
    wpd_batch_free(&b);
    return rc;
}

/* Whether the samples of input entry e may come within reach. */
static int entry_near(const gather *g, const wpd_coll_input *e)
{
    for (int k = 0; e->points && k < g->night->nnew; k++)
        if (box_gap2(e->out_bounds, g->night->fresh[k].bounds) <= g->reach2)
            return 1;
    return 0;
}

/* The class field of an opened output (kept classes only). */
static int class_field_of(gather *g, wpd_reader *r, const char *path, const char *field,
                          wpd_error *err)
{
    const char *name = *field ? field : "classification";
    if (g->keep && (g->class_dim = wpd_schema_find(&wpd_reader_header(r)->schema, name)) < 0)
        return wpd_fail(err, WPD_E_INPUT, "%s: no field '%s' to tell its kept classes by",
                        path, name);
    return 0;
}

int wpd_collection_fixed(const wpd_collection *c, wpd_night *night, double reach,
                         const uint8_t *keep, const char *class_field, wpd_error *err)
{
    gather g = {night, reach * reach, keep, -1, NULL, 0, 0};
    wpd_reader *r = NULL;
    const char *open_name = NULL;
    char path[1400];
    int rc = 0;
    /* The state's order (the same on every rank and every run): an output
     * is opened once for a run of its entries (--append: one for all). */
    for (int i = 0; rc == 0 && i < c->ninputs; i++) {
        const wpd_coll_input *e = &c->inputs[i];
        if (!entry_near(&g, e))
            continue;
        if (!open_name || strcmp(open_name, e->output)) {
            wpd_reader_close(r);
            snprintf(path, sizeof path, "%s/%s", c->dir, e->output);
            open_name = e->output;
            night->outputs_read++;
            if (!(r = wpd_reader_open(path, err)) ||
                class_field_of(&g, r, path, class_field ? class_field : "", err)) {
                rc = -1;
                break;
            }
        }
        rc = read_range(&g, r, path, e->first, e->points, err);
    }
    wpd_reader_close(r);
    if (rc) {
        free(g.xyz);
        return -1;
    }
    night->fixed = g.xyz;
    night->nfixed = g.n;
    return 0;
}
