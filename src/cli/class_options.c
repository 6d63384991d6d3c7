/* class_options.c - parsing and checking the class options (class_options.h). */
#include "cli/class_options.h"
#include "cli/report.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* A class number: digits only, in 0..WPD_CLASS_MAX. Returns 0 or -1. */
static int parse_class(const char *s, const char *end, long *out)
{
    if (s == end || end - s > 6)
        return -1;
    long v = 0;
    for (const char *p = s; p < end; p++) {
        if (*p < '0' || *p > '9')
            return -1;
        v = 10 * v + (*p - '0');
    }
    if (v > WPD_CLASS_MAX)
        return -1;
    *out = v;
    return 0;
}

int wpd_class_list_parse(const char *text, uint8_t **set, wpd_error *err)
{
    if (!*set && !(*set = calloc(WPD_CLASS_MAX + 1, 1)))
        return wpd_fail(err, WPD_E_MEMORY, "out of memory");
    const char *s = text;
    for (;;) {
        const char *end = strchr(s, ',');
        end = end ? end : s + strlen(s);
        const char *dash = memchr(s, '-', (size_t)(end - s));
        long lo, hi;
        int bad = dash ? parse_class(s, dash, &lo) || parse_class(dash + 1, end, &hi) || lo > hi
                       : parse_class(s, end, &lo);
        if (bad)
            return wpd_fail(err, WPD_E_USAGE, "class list '%s': '%.*s' is not a class (0-%d) "
                            "or a range lo-hi", text, (int)(end - s), s, WPD_CLASS_MAX);
        for (long c = lo; c <= (dash ? hi : lo); c++)
            (*set)[c] = 1;
        if (!*end)
            return 0;
        s = end + 1;
    }
}

int wpd_class_count_parse(const char *text, wpd_class_args *a, wpd_error *err)
{
    const char *eq = strchr(text, '=');
    long cls;
    char *end = NULL;
    double v = 0;
    if (eq) {
        errno = 0;
        v = strtod(eq + 1, &end);
        if (end && (*end == 'k' || *end == 'K'))
            v *= 1e3, end++;
        else if (end && *end == 'M')
            v *= 1e6, end++;
    }
    if (!eq || parse_class(text, eq, &cls) || end == eq + 1 || *end || errno || !(v >= 1) ||
        v > 1e18 || v != (double)(uint64_t)v)
        return wpd_fail(err, WPD_E_USAGE, "--class-count '%s': want CLASS=N (a class 0-%d, "
                        "N a positive count, e.g. 2=100k)", text, WPD_CLASS_MAX);
    wpd_class_request *grown = realloc(a->counts, (size_t)(a->ncounts + 1) * sizeof *grown);
    if (!grown)
        return wpd_fail(err, WPD_E_MEMORY, "out of memory");
    a->counts = grown;
    a->counts[a->ncounts++] = (wpd_class_request){cls, (uint64_t)v};
    return 0;
}

int wpd_class_args_used(const wpd_class_args *a)
{
    return a->drop || a->keep || a->ncounts;
}

int wpd_class_args_check(const wpd_class_args *a, wpd_error *err)
{
    for (long c = 0; a->drop && a->keep && c <= WPD_CLASS_MAX; c++)
        if (a->drop[c] && a->keep[c])
            return wpd_fail(err, WPD_E_USAGE, "class %ld is both dropped and kept", c);
    for (int i = 0; i < a->ncounts; i++) {
        long c = a->counts[i].cls;
        if ((a->drop && a->drop[c]) || (a->keep && a->keep[c]))
            return wpd_fail(err, WPD_E_USAGE, "class %ld has a count and is %s", c,
                            a->drop && a->drop[c] ? "dropped" : "kept");
        for (int j = 0; j < i; j++)
            if (a->counts[j].cls == c)
                return wpd_fail(err, WPD_E_USAGE, "class %ld has two counts", c);
    }
    return 0;
}

int wpd_class_args_resolve(const wpd_class_args *a, const wpd_cloud *cloud,
                           wpd_class_options *out, wpd_error *err)
{
    const wpd_header *h = wpd_cloud_header(cloud, 0);
    const char *name = a->field ? a->field : "classification";
    int d = wpd_schema_find(&h->schema, name);
    if (d < 0)
        return wpd_fail(err, WPD_E_USAGE, "%s: no field '%s' to read the classes from%s",
                        h->path, name, a->field ? "" : " (name one with --class-field)");
    const wpd_dim *f = &h->schema.dims[d];
    if (!wpd_type_is_int(f->type) || f->scaled)
        return wpd_fail(err, WPD_E_USAGE, "%s: field '%s' is not an integer field: it cannot "
                        "hold classes", h->path, name);
    memset(out, 0, sizeof *out);
    out->field = *f;
    out->drop = a->drop;
    out->keep = a->keep;
    out->counts = a->counts;
    out->ncounts = a->ncounts;
    out->rest_percent = -1;
    return 0;
}

void wpd_class_args_free(wpd_class_args *a)
{
    free(a->drop);
    free(a->keep);
    free(a->counts);
    memset(a, 0, sizeof *a);
}

void wpd_class_print_summary(const wpd_class_result *c)
{
    for (int i = 0; i < c->nlines; i++) {
        const wpd_class_line *l = &c->lines[i];
        printf("  class %ld (%s): %llu -> %llu points\n", l->cls, wpd_class_role_name(l->role),
               (unsigned long long)l->in, (unsigned long long)l->out);
    }
    for (int i = 0; i < c->ngroups; i++) {
        const wpd_class_group *g = &c->groups[i];
        if (g->points == 0 || g->whole)
            continue;
        if (g->cls < 0)
            printf("  classes not named: radius %.6g\n", g->run.radius);
        else
            printf("  class %ld on its own: radius %.6g\n", g->cls, g->run.radius);
    }
}
