/* collection.c - a collection's state and its nights (collection.h): where
 * it lives, reading and writing it, checking a night's command against
 * it, and the state after a night. */
#include "resample/collection.h"

#include <errno.h>
#include <fcntl.h>
#include <libgen.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "common/fullio.h"
#include "common/json.h"
#include "common/version.h"
#include "io/cloud.h"

enum { STATE_MAX = 1 << 30 }; /* bytes: some 2 M inputs */

int wpd_collection_locate(wpd_collection *c, const char *outdir, const char *path,
                          wpd_error *err)
{
    memset(c, 0, sizeof *c);
    char a[1024], b[1024];
    const char *label = outdir ? outdir : path;
    if (strlen(label) >= sizeof a)
        return wpd_fail(err, WPD_E_USAGE, "%.64s...: path too long", label);
    snprintf(c->label, sizeof c->label, "%s", label);
    if (outdir) {
        snprintf(c->dir, sizeof c->dir, "%s", outdir);
        snprintf(c->state, sizeof c->state, "%s/.wpd-collection", outdir);
        return 0;
    }
    snprintf(a, sizeof a, "%s", path);
    snprintf(b, sizeof b, "%s", path);
    snprintf(c->dir, sizeof c->dir, "%s", dirname(a));
    snprintf(c->append, sizeof c->append, "%s", basename(b));
    snprintf(c->state, sizeof c->state, "%s/.%s.wpd-collection", c->dir, c->append);
    return 0;
}

void wpd_coll_options_free(wpd_coll_options *o)
{
    free(o->drop), free(o->keep), free(o->class_field);
    o->drop = o->keep = o->class_field = NULL;
}

/* Everything read from a state file; the location stays. */
static void clear_state(wpd_collection *c)
{
    for (int i = 0; i < c->noutputs; i++)
        free(c->outputs[i].name);
    for (int i = 0; i < c->ninputs; i++)
        free(c->inputs[i].name), free(c->inputs[i].output);
    for (int i = 0; i < c->npending; i++)
        free(c->pending[i].from), free(c->pending[i].to);
    free(c->outputs), free(c->inputs), free(c->pending), free(c->by_name);
    c->by_name = NULL;
    wpd_coll_options_free(&c->opt);
    c->outputs = NULL, c->inputs = NULL, c->pending = NULL;
    c->noutputs = c->ninputs = c->npending = 0;
    c->exists = 0;
}

void wpd_collection_free(wpd_collection *c)
{
    clear_state(c);
}

void wpd_night_free(wpd_night *n)
{
    for (int i = 0; n->fresh && i < n->nnew; i++)
        free(n->fresh[i].name), free(n->fresh[i].output);
    free(n->fresh);
    free(n->fixed);
    memset(n, 0, sizeof *n);
}

char *wpd_coll_class_list(const uint8_t *set)
{
    size_t cap = 64, len = 0;
    char *s = malloc(cap);
    for (long k = 0; s && set && k <= WPD_CLASS_MAX; k++) {
        if (!set[k])
            continue;
        long hi = k;
        while (hi < WPD_CLASS_MAX && set[hi + 1])
            hi++;
        if (len + 32 > cap) {
            char *grown = realloc(s, cap *= 2);
            if (!grown) {
                free(s);
                return NULL;
            }
            s = grown;
        }
        len += (size_t)(hi > k ? sprintf(s + len, "%s%ld-%ld", len ? "," : "", k, hi)
                               : sprintf(s + len, "%s%ld", len ? "," : "", k));
        k = hi;
    }
    if (s)
        s[len] = '\0';
    return s;
}

static int compare_names(const void *a, const void *b)
{
    return strcmp(((const wpd_coll_name *)a)->name, ((const wpd_coll_name *)b)->name);
}

void wpd_coll_names_sort(wpd_coll_name *names, int n)
{
    qsort(names, (size_t)n, sizeof *names, compare_names);
}

int wpd_coll_names_find(const wpd_coll_name *names, int n, const char *name)
{
    wpd_coll_name key = {name, 0};
    const wpd_coll_name *hit = n ? bsearch(&key, names, (size_t)n, sizeof *names,
                                           compare_names) : NULL;
    return hit ? hit->at : -1;
}

const wpd_coll_input *wpd_collection_find(const wpd_collection *c, const char *name)
{
    int at = c->by_name ? wpd_coll_names_find(c->by_name, c->ninputs, name) : -1;
    return at >= 0 ? &c->inputs[at] : NULL;
}

/* ------------------------------------------------------------ the file */

int wpd_collection_load(wpd_collection *c, wpd_error *err)
{
    clear_state(c);
    int fd = open(c->state, O_RDONLY | O_CLOEXEC);
    if (fd < 0)
        return errno == ENOENT ? 0 : wpd_fail_errno(err, "%s: cannot open", c->state);
    struct stat st;
    char *text = NULL;
    int rc = fstat(fd, &st) ? wpd_fail_errno(err, "%s: cannot read", c->state) : 0;
    if (rc == 0 && (st.st_size <= 0 || st.st_size > STATE_MAX))
        rc = wpd_fail(err, WPD_E_INPUT, "%s: not a wpd collection state (%lld bytes; resample "
                      "the collection with --rebuild)", c->state, (long long)st.st_size);
    if (rc == 0 && !(text = malloc((size_t)st.st_size)))
        rc = wpd_fail(err, WPD_E_MEMORY, "%s: out of memory", c->state);
    if (rc == 0 && wpd_pread_full(fd, text, (size_t)st.st_size, 0) != st.st_size)
        rc = wpd_fail_errno(err, "%s: cannot read", c->state);
    close(fd);
    if (rc == 0)
        rc = wpd_collection_parse(c, text, (size_t)st.st_size, c->state, err);
    free(text);
    if (rc)
        clear_state(c);
    return rc;
}

static void put_box(FILE *f, const double b[6])
{
    fputc('[', f);
    for (int k = 0; k < 6; k++) {
        if (k)
            fputs(", ", f);
        wpd_json_number(f, b[k]);
    }
    fputc(']', f);
}

static void put_options(FILE *f, const wpd_coll_options *o)
{
    fputs("  \"options\": {\"lambda\": ", f);
    wpd_json_number(f, o->lambda);
    fputs(", \"voxel_frac\": ", f);
    wpd_json_number(f, o->voxel_frac);
    fprintf(f, ", \"radius_estimate\": \"%s\", \"k\": %d, \"iterations\": %d, "
               "\"even_steps\": %d, \"smooth\": %s, \"sharp\": %s, \"seed\": %llu, "
               "\"drop_class\": ",
            o->radius_method == WPD_RADIUS_PAPER ? "paper" : "multiscale", o->k, o->iterations,
            o->even_steps, o->smooth ? "true" : "false", o->sharp ? "true" : "false",
            (unsigned long long)o->seed);
    wpd_json_string(f, o->drop ? o->drop : "");
    fputs(", \"keep_class\": ", f);
    wpd_json_string(f, o->keep ? o->keep : "");
    fputs(", \"class_field\": ", f);
    wpd_json_string(f, o->class_field ? o->class_field : "");
    fputs("},\n", f);
}

static void put_input(FILE *f, const wpd_coll_input *e)
{
    fputs("    {\"name\": ", f);
    wpd_json_string(f, e->name);
    fprintf(f, ", \"size\": %llu, \"mtime_ns\": %lld, \"bounds\": ",
            (unsigned long long)e->size, (long long)e->mtime_ns);
    put_box(f, e->bounds);
    fputs(", \"output\": ", f);
    wpd_json_string(f, e->output);
    fprintf(f, ", \"first\": %llu, \"points\": %llu, \"output_bounds\": ",
            (unsigned long long)e->first, (unsigned long long)e->points);
    put_box(f, e->out_bounds);
    fprintf(f, ", \"night\": %d}", e->night);
}

int wpd_collection_format(const wpd_collection *c, char **text, size_t *len)
{
    FILE *f = open_memstream(text, len);
    if (!f)
        return -1;
    fprintf(f, "{\n  \"format\": \"wpd-collection\",\n  \"version\": %d,\n  \"wpd\": ",
            WPD_COLLECTION_FORMAT);
    wpd_json_string(f, c->wpd_version);
    fputs(",\n  \"radius\": ", f);
    wpd_json_number(f, c->radius);
    fputs(",\n  \"density_factor\": ", f);
    wpd_json_number(f, c->factor);
    fprintf(f, ",\n  \"spacing\": %s,\n", c->spacing ? "true" : "false");
    put_options(f, &c->opt);
    fprintf(f, "  \"nights\": %d,\n  \"outputs\": [", c->nights);
    for (int i = 0; i < c->noutputs; i++) {
        fputs(i ? ",\n    {\"name\": " : "\n    {\"name\": ", f);
        wpd_json_string(f, c->outputs[i].name);
        fprintf(f, ", \"size\": %llu}", (unsigned long long)c->outputs[i].size);
    }
    fputs(c->noutputs ? "\n  ],\n  \"inputs\": [" : "],\n  \"inputs\": [", f);
    for (int i = 0; i < c->ninputs; i++) {
        fputs(i ? ",\n" : "\n", f);
        put_input(f, &c->inputs[i]);
    }
    fputs(c->ninputs ? "\n  ],\n  \"pending\": [" : "],\n  \"pending\": [", f);
    for (int i = 0; i < c->npending; i++) {
        fputs(i ? ",\n    {\"from\": " : "\n    {\"from\": ", f);
        wpd_json_string(f, c->pending[i].from);
        fputs(", \"to\": ", f);
        wpd_json_string(f, c->pending[i].to);
        fputc('}', f);
    }
    fputs(c->npending ? "\n  ]\n}\n" : "]\n}\n", f);
    return fclose(f) ? -1 : 0;
}
