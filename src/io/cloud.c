#include "io/cloud.h"

#include "io/reader.h"
#include "io/record_cache.h"
#include "common/tmpdir.h"

#include <limits.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

struct wpd_cloud {
    int nfiles;
    wpd_header *headers;      /* one per file (owned copies) */
    int current;              /* file being read, nfiles when done */
    wpd_reader *reader;       /* open reader of file `current`, or NULL */
    uint64_t dropped_closed;  /* dropped points of files already finished */
    uint64_t *delivered;      /* [nfiles] points returned per file since rewind */
    int all_seek;             /* every file's reader can seek */
    int bounded;              /* reads stop at the end of a stretch (wpd_cloud_seek_stretch) */
    const wpd_point_filter *filter; /* classes delivered, or NULL: all */
    uint64_t filtered;        /* finite points the filter skipped */
    wpd_record_cache **cache; /* [nfiles] decoded records kept, or NULL */
    int owns_cache;           /* 0 in a reopened copy: the caches are shared */
    char cache_dir[PATH_MAX]; /* their private directory (owner), or "" */
};

/* Two dimensions agree if everything but a coordinate's scale/offset does. */
static int same_dim(const wpd_dim *a, const wpd_dim *b, int is_coordinate)
{
    if (strcmp(a->name, b->name) || a->type != b->type || a->offset != b->offset ||
        a->bit_shift != b->bit_shift || a->bit_count != b->bit_count ||
        a->scaled != b->scaled)
        return 0;
    return is_coordinate || !a->scaled || (a->scale == b->scale && a->add == b->add);
}

static int check_same_layout(const wpd_header *first, const wpd_header *h, wpd_error *err)
{
    const wpd_schema *a = &first->schema, *b = &h->schema;
    int same = first->format == h->format && a->record_size == b->record_size &&
               a->ndims == b->ndims;
    if (same && h->format == WPD_FMT_LAS)
        same = first->las.pdrf == h->las.pdrf;
    for (uint32_t i = 0; same && i < a->ndims; i++) {
        int coord = (int)i == a->dim_x || (int)i == a->dim_y || (int)i == a->dim_z;
        same = same_dim(&a->dims[i], &b->dims[i], coord);
    }
    if (!same)
        return wpd_fail(err, WPD_E_INPUT,
                        "%s: point layout differs from %s (inputs read as one cloud "
                        "must have the same format and dimensions)",
                        h->path, first->path);
    return 0;
}

wpd_cloud *wpd_cloud_open(const char *const *paths, int n, wpd_error *err)
{
    wpd_cloud *c = calloc(1, sizeof *c);
    if (!c || !(c->headers = calloc((size_t)(n > 0 ? n : 1), sizeof *c->headers)) ||
        !(c->delivered = calloc((size_t)(n > 0 ? n : 1), sizeof *c->delivered))) {
        if (c)
            free(c->headers);
        free(c);
        wpd_fail(err, WPD_E_MEMORY, "out of memory opening %d inputs", n);
        return NULL;
    }
    c->all_seek = 1;
    for (int i = 0; i < n; i++) {
        wpd_reader *r = wpd_reader_open(paths[i], err);
        if (!r)
            goto fail;
        /* The reader knows (the header alone does not say for PLY whose
         * vertices follow elements with lists) and is open here anyway. */
        c->all_seek &= wpd_reader_can_seek(r);
        int rc = wpd_header_copy(&c->headers[i], wpd_reader_header(r));
        wpd_reader_close(r);
        c->nfiles = i + 1;
        if (rc) {
            wpd_fail(err, WPD_E_MEMORY, "%s: out of memory", paths[i]);
            goto fail;
        }
        if (i > 0 && check_same_layout(&c->headers[0], &c->headers[i], err))
            goto fail;
    }
    return c;
fail:
    wpd_cloud_close(c);
    return NULL;
}

int wpd_cloud_nfiles(const wpd_cloud *c) { return c->nfiles; }

const wpd_header *wpd_cloud_header(const wpd_cloud *c, int i) { return &c->headers[i]; }

uint64_t wpd_cloud_count(const wpd_cloud *c)
{
    uint64_t total = 0;
    for (int i = 0; i < c->nfiles; i++)
        total += c->headers[i].point_count;
    return total;
}

int wpd_cloud_declared_bounds(const wpd_cloud *c, wpd_bounds *out)
{
    wpd_bounds_reset(out);
    if (c->filter) /* the headers' box is all classes' */
        return 0;
    for (int i = 0; i < c->nfiles; i++) {
        const wpd_header *h = &c->headers[i];
        if (h->format != WPD_FMT_LAS)
            return 0;
        for (int a = 0; a < 3; a++) {
            if (!isfinite(h->las.min[a]) || !isfinite(h->las.max[a]) ||
                h->las.min[a] > h->las.max[a])
                return 0;
            out->min[a] = fmin(out->min[a], h->las.min[a]);
            out->max[a] = fmax(out->max[a], h->las.max[a]);
        }
        out->count += h->point_count;
    }
    for (int a = 0; a < 3; a++) /* finite faces can still be too far apart */
        if (!isfinite(out->max[a] - out->min[a]))
            return 0;
    return c->nfiles > 0;
}

int wpd_bounds_tight(const wpd_bounds *declared, const wpd_bounds *actual)
{
    if (declared->count != actual->count || actual->count == 0)
        return 0;
    double longest = 0;
    for (int a = 0; a < 3; a++)
        longest = fmax(longest, actual->max[a] - actual->min[a]);
    double slack = 1e-6 * longest;
    for (int a = 0; a < 3; a++)
        if (!(declared->min[a] <= actual->min[a] && declared->max[a] >= actual->max[a] &&
              actual->min[a] - declared->min[a] <= slack &&
              declared->max[a] - actual->max[a] <= slack))
            return 0;
    return 1;
}

static void close_current(wpd_cloud *c)
{
    if (c->reader) {
        c->dropped_closed += wpd_reader_dropped(c->reader);
        wpd_reader_close(c->reader);
        c->reader = NULL;
    }
}

long wpd_class_of(const wpd_dim *f, const uint8_t *record)
{
    double v = wpd_dim_get(f, record);
    return v >= 0 && v <= WPD_CLASS_MAX && v == (long)v ? (long)v : -1;
}

long wpd_class_checked(const wpd_dim *f, const uint8_t *record, const char *path,
                       wpd_error *err)
{
    long cls = wpd_class_of(f, record);
    if (cls < 0)
        return wpd_fail(err, WPD_E_INPUT, "%s: field %s holds %g, not a class (an integer in "
                        "0-%d)", path, f->name, wpd_dim_get(f, record), WPD_CLASS_MAX);
    return cls;
}

/* Keeps the points of b whose class the filter accepts, in order. Returns
 * how many, or -1 with err set (a class out of range). */
static long apply_filter(wpd_cloud *c, wpd_batch *b, wpd_error *err)
{
    const wpd_point_filter *f = c->filter;
    size_t rs = b->record_size, kept = 0;
    for (size_t i = 0; i < b->n; i++) {
        const uint8_t *rec = b->records + i * rs;
        long cls = wpd_class_checked(&f->field, rec, c->headers[c->current].path, err);
        if (cls < 0)
            return -1;
        if (!f->accept[cls])
            continue;
        if (kept != i) {
            memmove(b->records + kept * rs, rec, rs);
            memcpy(b->xyz + 3 * kept, b->xyz + 3 * i, 3 * sizeof *b->xyz);
        }
        kept++;
    }
    c->filtered += b->n - kept;
    b->n = kept;
    return (long)kept;
}

/* Opens the reader of file f (the current one), with its cache if any. */
static int open_current(wpd_cloud *c, int f, wpd_error *err)
{
    if (!(c->reader = wpd_reader_open(c->headers[f].path, err)))
        return -1;
    wpd_reader_use_cache(c->reader, c->cache ? c->cache[f] : NULL);
    return 0;
}

long wpd_cloud_read(wpd_cloud *c, wpd_batch *b, int *file, wpd_error *err)
{
    while (c->current < c->nfiles) {
        if (!c->reader && open_current(c, c->current, err))
            return -1;
        long got = wpd_reader_read(c->reader, b, err);
        if (got > 0 && c->filter && (got = apply_filter(c, b, err)) == 0)
            continue; /* nothing of this batch is wanted: read on */
        if (got != 0) {
            if (file)
                *file = c->current;
            if (got > 0)
                c->delivered[c->current] += (uint64_t)got;
            return got;
        }
        if (c->bounded) /* the stretch ends here, not the file */
            break;
        close_current(c);
        c->current++;
    }
    b->n = 0;
    return 0;
}

wpd_cloud *wpd_cloud_reopen(const wpd_cloud *c, wpd_error *err)
{
    const char **paths = malloc((size_t)c->nfiles * sizeof *paths);
    if (!paths) {
        wpd_fail(err, WPD_E_MEMORY, "out of memory");
        return NULL;
    }
    for (int i = 0; i < c->nfiles; i++)
        paths[i] = c->headers[i].path;
    wpd_cloud *copy = wpd_cloud_open(paths, c->nfiles, err);
    free(paths);
    if (copy) {
        copy->filter = c->filter;
        copy->cache = c->cache;
    }
    return copy;
}

int wpd_cloud_cache_records(wpd_cloud *c, const char *base, wpd_error *err)
{
    int compressed = 0;
    for (int i = 0; i < c->nfiles; i++)
        compressed |= c->headers[i].format == WPD_FMT_LAS && c->headers[i].las.laz.compressed;
    if (c->cache || !compressed)
        return 0;
    if (!(c->cache = calloc((size_t)c->nfiles, sizeof *c->cache)))
        return wpd_fail(err, WPD_E_MEMORY, "out of memory");
    c->owns_cache = 1;
    /* one directory for every input: a run may read thousands */
    if (wpd_tmpdir_create(base, "wpd-cache", c->cache_dir, sizeof c->cache_dir, err)) {
        c->cache_dir[0] = '\0';
        return -1;
    }
    for (int i = 0; i < c->nfiles; i++) {
        wpd_reader *r = wpd_reader_open(c->headers[i].path, err);
        int rc = r ? wpd_reader_new_cache(r, c->cache_dir, i, &c->cache[i], err) : -1;
        wpd_reader_close(r);
        if (rc)
            return -1;
    }
    close_current(c); /* reopened with its cache */
    return 0;
}

uint64_t wpd_cloud_cache_hits(const wpd_cloud *c)
{
    uint64_t hits = 0;
    for (int i = 0; c->cache && i < c->nfiles; i++)
        hits += c->cache[i] ? wpd_record_cache_hits(c->cache[i]) : 0;
    return hits;
}

int wpd_cloud_can_seek(const wpd_cloud *c) { return c->all_seek; }

int wpd_cloud_seek_stretch(wpd_cloud *c, uint64_t index, uint64_t count, wpd_error *err)
{
    int f = 0;
    while (f < c->nfiles && index >= c->headers[f].point_count)
        index -= c->headers[f++].point_count;
    c->bounded = 1;
    if (f != c->current)
        close_current(c); /* its dropped points are counted on */
    c->current = f;
    if (f == c->nfiles)
        return 0; /* at the end: reads return 0 */
    if (!c->reader && open_current(c, f, err))
        return -1;
    if (!wpd_reader_can_seek(c->reader))
        return wpd_fail(err, WPD_E_USAGE, "%s: records of this format cannot be positioned",
                        c->headers[f].path);
    uint64_t end = count < c->headers[f].point_count - index ? index + count
                                                             : c->headers[f].point_count;
    return wpd_reader_seek_range(c->reader, index, end, err);
}

void wpd_cloud_add_counts(wpd_cloud *c, const wpd_cloud *from)
{
    for (int i = 0; i < c->nfiles && i < from->nfiles; i++)
        c->delivered[i] += from->delivered[i];
    c->dropped_closed += wpd_cloud_dropped(from);
    c->filtered += from->filtered;
}

int wpd_cloud_rewind(wpd_cloud *c, wpd_error *err)
{
    (void)err;
    close_current(c);
    c->bounded = 0;
    c->current = 0;
    c->dropped_closed = 0;
    c->filtered = 0;
    memset(c->delivered, 0, (size_t)c->nfiles * sizeof *c->delivered);
    return 0;
}

uint64_t wpd_cloud_delivered(const wpd_cloud *c, int i) { return c->delivered[i]; }

uint64_t wpd_cloud_dropped(const wpd_cloud *c)
{
    return c->dropped_closed + (c->reader ? wpd_reader_dropped(c->reader) : 0);
}

void wpd_cloud_set_filter(wpd_cloud *c, const wpd_point_filter *f) { c->filter = f; }

uint64_t wpd_cloud_filtered(const wpd_cloud *c) { return c->filtered; }

void wpd_bounds_reset(wpd_bounds *b)
{
    for (int k = 0; k < 3; k++) {
        b->min[k] = INFINITY;
        b->max[k] = -INFINITY;
    }
    b->count = 0;
}

void wpd_bounds_add(wpd_bounds *b, const double *xyz, size_t n)
{
    double lo[3] = {b->min[0], b->min[1], b->min[2]};
    double hi[3] = {b->max[0], b->max[1], b->max[2]};
    for (size_t i = 0; i < n; i++) {
        for (int k = 0; k < 3; k++) {
            double v = xyz[3 * i + k];
            lo[k] = v < lo[k] ? v : lo[k];
            hi[k] = v > hi[k] ? v : hi[k];
        }
    }
    for (int k = 0; k < 3; k++) {
        b->min[k] = lo[k];
        b->max[k] = hi[k];
    }
    b->count += n;
}

void wpd_bounds_union(wpd_bounds *b, const wpd_bounds *o)
{
    for (int k = 0; k < 3; k++) {
        b->min[k] = o->min[k] < b->min[k] ? o->min[k] : b->min[k];
        b->max[k] = o->max[k] > b->max[k] ? o->max[k] : b->max[k];
    }
    b->count += o->count;
}

int wpd_cloud_bounds(wpd_cloud *c, wpd_bounds *out, wpd_error *err)
{
    wpd_batch b;
    if (wpd_batch_init(&b, 65536, c->headers[0].schema.record_size))
        return wpd_fail(err, WPD_E_MEMORY, "out of memory");
    wpd_bounds_reset(out);
    int rc = wpd_cloud_rewind(c, err);
    long got;
    while (rc == 0 && (got = wpd_cloud_read(c, &b, NULL, err)) > 0)
        wpd_bounds_add(out, b.xyz, b.n);
    if (rc == 0 && got < 0)
        rc = -1;
    wpd_batch_free(&b);
    if (rc == 0)
        rc = wpd_cloud_rewind(c, err);
    return rc;
}

void wpd_cloud_close(wpd_cloud *c)
{
    if (!c)
        return;
    close_current(c);
    for (int i = 0; c->owns_cache && c->cache && i < c->nfiles; i++)
        wpd_record_cache_free(c->cache[i]);
    if (c->owns_cache) {
        free(c->cache);
        if (c->cache_dir[0])
            wpd_tmpdir_remove(c->cache_dir);
    }
    for (int i = 0; i < c->nfiles; i++)
        wpd_header_free(&c->headers[i]);
    free(c->headers);
    free(c->delivered);
    free(c);
}

void wpd_cloud_print_warnings(const wpd_cloud *c, const char *command, FILE *f)
{
    for (int i = 0; i < c->nfiles; i++)
        wpd_warnings_print(f, command, &c->headers[i].warnings);
}
