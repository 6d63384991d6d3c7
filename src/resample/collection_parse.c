/* collection_parse.c - the strict parser of a collection's state
 * (collection.h): exactly the JSON wpd_collection_format writes - its keys
 * in its order, whitespace anywhere JSON allows it - and nothing else.
 * Every other text fails with one line naming the file, the byte and what
 * was expected, before anything is used: a state that was cut short, edited
 * by hand or is not a state at all never half-loads. Lengths and counts are
 * bounded by the text itself (no allocation larger than it), nothing
 * recurses, and a file name must be a plain name in the folder (no '/', not
 * "." or ".."), so a damaged state cannot point at other files. */
#include "resample/collection.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "io/cloud.h"

typedef struct cursor {
    const char *s;
    size_t len, at;
    const char *name;        /* the file, for messages */
    wpd_error *err;
    int failed;
} cursor;

/* The first failure wins; later calls see failed and do nothing. */
static int bad(cursor *c, const char *expected)
{
    if (!c->failed)
        wpd_fail(c->err, WPD_E_INPUT, "%s: not a wpd collection state: at byte %zu, expected "
                 "%s (resample the collection with --rebuild)", c->name, c->at, expected);
    c->failed = 1;
    return -1;
}

static void ws(cursor *c)
{
    while (c->at < c->len && strchr(" \t\r\n", c->s[c->at]) && c->s[c->at])
        c->at++;
}

static int punct(cursor *c, char ch)
{
    static char what[4] = "' '";
    ws(c);
    if (c->failed || c->at >= c->len || c->s[c->at] != ch) {
        what[1] = ch;
        return bad(c, what);
    }
    c->at++;
    return 0;
}

/* Whether the next character is ch (after whitespace); takes it if so. */
static int maybe(cursor *c, char ch)
{
    ws(c);
    if (c->failed || c->at >= c->len || c->s[c->at] != ch)
        return 0;
    c->at++;
    return 1;
}

/* The value of a lowercase hexadecimal digit, or -1 (json.h writes %04x). */
static int hex(char ch)
{
    return ch >= '0' && ch <= '9' ? ch - '0' : ch >= 'a' && ch <= 'f' ? ch - 'a' + 10 : -1;
}

/* A string literal as json.h writes it (escapes: \" \\ and \u00XX for
 * other bytes below 0x20 or from 0x7f), into *out (malloc'd). */
static int string(cursor *c, char **out)
{
    *out = NULL;
    if (punct(c, '"'))
        return -1;
    size_t start = c->at, n = 0;
    char *buf = malloc(c->len - start + 1);
    if (!buf)
        return bad(c, "a string (out of memory)");
    while (c->at < c->len && c->s[c->at] != '"') {
        unsigned char ch = (unsigned char)c->s[c->at++];
        if (ch < 0x20 || ch >= 0x7f)
            break;
        if (ch == '\\') {
            const char *e = c->s + c->at;
            size_t left = c->len - c->at;
            if (left >= 1 && (e[0] == '"' || e[0] == '\\')) {
                ch = (unsigned char)e[0];
                c->at++;
            } else if (left >= 5 && e[0] == 'u' && e[1] == '0' && e[2] == '0' &&
                       hex(e[3]) >= 0 && hex(e[4]) >= 0 && (hex(e[3]) || hex(e[4]))) {
                ch = (unsigned char)(16 * hex(e[3]) + hex(e[4]));
                c->at += 5;
            } else {
                break;
            }
        }
        buf[n++] = (char)ch;
    }
    if (c->at >= c->len || c->s[c->at] != '"') {
        free(buf);
        return bad(c, "a string as wpd writes it");
    }
    c->at++;
    buf[n] = '\0';
    *out = buf;
    return 0;
}

/* "key": */
static int key(cursor *c, const char *k)
{
    char *got;
    if (string(c, &got))
        return -1;
    int same = strcmp(got, k) == 0;
    free(got);
    if (!same) {
        char what[64];
        snprintf(what, sizeof what, "the key \"%s\"", k);
        return bad(c, what);
    }
    return punct(c, ':');
}

/* The characters of a JSON number at the cursor: its length, 0 if none. */
static size_t number_span(const cursor *c)
{
    size_t i = c->at;
    while (i < c->len && strchr("+-0123456789.eE", c->s[i]) && c->s[i])
        i++;
    return i - c->at;
}

static int real(cursor *c, double *v)
{
    ws(c);
    size_t n = number_span(c);
    char buf[40];
    if (c->failed || n == 0 || n >= sizeof buf)
        return bad(c, "a number");
    memcpy(buf, c->s + c->at, n);
    buf[n] = '\0';
    char *end;
    errno = 0;
    *v = strtod(buf, &end);
    if (*end || !isfinite(*v) || !strchr("-0123456789", buf[0]))
        return bad(c, "a number");
    c->at += n;
    return 0;
}

/* A number or null (an empty box's faces: fill). */
static int real_or_null(cursor *c, double *v, double fill)
{
    ws(c);
    if (!c->failed && c->len - c->at >= 4 && !memcmp(c->s + c->at, "null", 4)) {
        c->at += 4;
        *v = fill;
        return 0;
    }
    return real(c, v);
}

static int unsigned64(cursor *c, uint64_t *v)
{
    ws(c);
    size_t n = number_span(c);
    char buf[24];
    if (c->failed || n == 0 || n > 20 || c->s[c->at] < '0' || c->s[c->at] > '9')
        return bad(c, "an unsigned integer");
    memcpy(buf, c->s + c->at, n);
    buf[n] = '\0';
    char *end;
    errno = 0;
    *v = strtoull(buf, &end, 10);
    if (*end || errno)
        return bad(c, "an unsigned integer");
    c->at += n;
    return 0;
}

static int signed64(cursor *c, int64_t *v)
{
    int neg = maybe(c, '-');
    uint64_t u;
    if (unsigned64(c, &u))
        return -1;
    if (u > (uint64_t)INT64_MAX)
        return bad(c, "an integer of 64 bits");
    *v = neg ? -(int64_t)u : (int64_t)u;
    return 0;
}

/* An integer in lo..hi. */
static int integer(cursor *c, int lo, int hi, int *v)
{
    uint64_t u;
    if (unsigned64(c, &u))
        return -1;
    if (u < (uint64_t)lo || u > (uint64_t)hi)
        return bad(c, "an integer in range");
    *v = (int)u;
    return 0;
}

static int boolean(cursor *c, int *v)
{
    ws(c);
    if (!c->failed && c->len - c->at >= 4 && !memcmp(c->s + c->at, "true", 4)) {
        c->at += 4, *v = 1;
        return 0;
    }
    if (!c->failed && c->len - c->at >= 5 && !memcmp(c->s + c->at, "false", 5)) {
        c->at += 5, *v = 0;
        return 0;
    }
    return bad(c, "true or false");
}

/* A file name in the folder: no '/', not "", "." or "..". */
static int file_name(cursor *c, char **out)
{
    if (string(c, out))
        return -1;
    if (!**out || strchr(*out, '/') || !strcmp(*out, ".") || !strcmp(*out, "..") ||
        strlen(*out) > 255)
        return bad(c, "a file name (no '/')");
    return 0;
}

/* [min x, y, z, max x, y, z], null faces for an empty box. */
static int box(cursor *c, double b[6])
{
    if (punct(c, '['))
        return -1;
    for (int k = 0; k < 6; k++)
        if ((k && punct(c, ',')) || real_or_null(c, &b[k], k < 3 ? INFINITY : -INFINITY))
            return -1;
    return punct(c, ']');
}

static int options(cursor *c, wpd_coll_options *o)
{
    char *est = NULL;
    int rc = punct(c, '{') || key(c, "lambda") || real(c, &o->lambda) || punct(c, ',') ||
             key(c, "voxel_frac") || real(c, &o->voxel_frac) || punct(c, ',') ||
             key(c, "radius_estimate") || string(c, &est);
    if (rc == 0 && strcmp(est, "paper") && strcmp(est, "multiscale"))
        rc = bad(c, "\"paper\" or \"multiscale\"");
    if (rc == 0)
        o->radius_method = strcmp(est, "paper") ? WPD_RADIUS_MULTISCALE : WPD_RADIUS_PAPER;
    free(est);
    return rc || punct(c, ',') || key(c, "k") || integer(c, 3, 64, &o->k) || punct(c, ',') ||
                   key(c, "iterations") || integer(c, 0, 1000, &o->iterations) ||
                   punct(c, ',') || key(c, "even_steps") ||
                   integer(c, 0, 1000, &o->even_steps) || punct(c, ',') ||
                   key(c, "smooth") || boolean(c, &o->smooth) || punct(c, ',') ||
                   key(c, "sharp") || boolean(c, &o->sharp) || punct(c, ',') ||
                   key(c, "seed") || unsigned64(c, &o->seed) || punct(c, ',') ||
                   key(c, "drop_class") || string(c, &o->drop) || punct(c, ',') ||
                   key(c, "keep_class") || string(c, &o->keep) || punct(c, ',') ||
                   key(c, "class_field") || string(c, &o->class_field) || punct(c, '}')
               ? -1
               : 0;
}

/* "[" item ("," item)* "]" or "[]", each item read by fn into the next
 * of *items (grown as they come: no count is trusted). */
typedef int (*item_fn)(cursor *c, void *item);

static int array(cursor *c, size_t size, void **items, int *n, item_fn fn)
{
    *items = NULL;
    *n = 0;
    if (punct(c, '['))
        return -1;
    if (maybe(c, ']'))
        return 0;
    size_t cap = 0;
    do {
        if ((size_t)*n == cap) {
            cap = cap ? 2 * cap : 8;
            void *grown = cap < ((size_t)1 << 26) ? realloc(*items, cap * size) : NULL;
            if (!grown)
                return bad(c, "fewer entries (out of memory)");
            *items = grown;
        }
        memset((char *)*items + (size_t)*n * size, 0, size);
        (*n)++;
        if (fn(c, (char *)*items + (size_t)(*n - 1) * size))
            return -1;
    } while (maybe(c, ','));
    return punct(c, ']');
}

static int output_item(cursor *c, void *item)
{
    wpd_coll_output *o = item;
    return punct(c, '{') || key(c, "name") || file_name(c, &o->name) || punct(c, ',') ||
                   key(c, "size") || unsigned64(c, &o->size) || punct(c, '}')
               ? -1
               : 0;
}

static int input_item(cursor *c, void *item)
{
    wpd_coll_input *e = item;
    return punct(c, '{') || key(c, "name") || file_name(c, &e->name) || punct(c, ',') ||
                   key(c, "size") || unsigned64(c, &e->size) || punct(c, ',') ||
                   key(c, "mtime_ns") || signed64(c, &e->mtime_ns) || punct(c, ',') ||
                   key(c, "bounds") || box(c, e->bounds) || punct(c, ',') ||
                   key(c, "output") || file_name(c, &e->output) || punct(c, ',') ||
                   key(c, "first") || unsigned64(c, &e->first) || punct(c, ',') ||
                   key(c, "points") || unsigned64(c, &e->points) || punct(c, ',') ||
                   key(c, "output_bounds") || box(c, e->out_bounds) || punct(c, ',') ||
                   key(c, "night") || integer(c, 1, 1 << 30, &e->night) || punct(c, '}')
               ? -1
               : 0;
}

static int rename_item(cursor *c, void *item)
{
    wpd_coll_rename *r = item;
    return punct(c, '{') || key(c, "from") || file_name(c, &r->from) || punct(c, ',') ||
                   key(c, "to") || file_name(c, &r->to) || punct(c, '}')
               ? -1
               : 0;
}

static int header(cursor *c, wpd_collection *col)
{
    char *format = NULL, *version = NULL;
    int v = 0;
    int rc = punct(c, '{') || key(c, "format") || string(c, &format);
    if (rc == 0 && strcmp(format, "wpd-collection"))
        rc = bad(c, "\"wpd-collection\"");
    if (rc == 0 && (punct(c, ',') || key(c, "version") || integer(c, 1, 1 << 30, &v)))
        rc = -1;
    if (rc == 0 && v != WPD_COLLECTION_FORMAT) {
        wpd_fail(c->err, WPD_E_INPUT, "%s: a collection state of format version %d, this wpd "
                 "reads version %d (resample the collection with --rebuild)", c->name, v,
                 WPD_COLLECTION_FORMAT);
        c->failed = 1;
        rc = -1;
    }
    if (rc == 0 && (punct(c, ',') || key(c, "wpd") || string(c, &version)))
        rc = -1;
    if (rc == 0)
        snprintf(col->wpd_version, sizeof col->wpd_version, "%s", version);
    free(format);
    free(version);
    return rc;
}

/* The facts must hang together: every input listed once and its output
 * listed, every rename from a temporary to a listed output, the numbers in
 * range. Sorted names: a state of many inputs is checked in n log n.
 * Leaves col->by_name, the inputs' names sorted. */
static int consistent(cursor *c, wpd_collection *col)
{
    if (!(col->radius > 0) || !(col->factor > 0 && col->factor <= 1) ||
        !(col->opt.lambda > 0) || !(col->opt.voxel_frac > 0))
        return bad(c, "a positive radius, a density factor in (0, 1], positive options");
    int n = col->ninputs, m = col->noutputs;
    wpd_coll_name *outs = malloc((size_t)(m > 0 ? m : 1) * sizeof *outs);
    col->by_name = malloc((size_t)(n > 0 ? n : 1) * sizeof *col->by_name);
    if (!outs || !col->by_name) {
        free(outs);
        return bad(c, "fewer entries (out of memory)");
    }
    for (int k = 0; k < m; k++)
        outs[k] = (wpd_coll_name){col->outputs[k].name, k};
    for (int i = 0; i < n; i++)
        col->by_name[i] = (wpd_coll_name){col->inputs[i].name, i};
    wpd_coll_names_sort(outs, m);
    wpd_coll_names_sort(col->by_name, n);
    int rc = 0;
    for (int k = 1; rc == 0 && k < m; k++)
        if (!strcmp(outs[k - 1].name, outs[k].name))
            rc = bad(c, "each output listed once");
    for (int i = 1; rc == 0 && i < n; i++)
        if (!strcmp(col->by_name[i - 1].name, col->by_name[i].name))
            rc = bad(c, "each input listed once");
    for (int i = 0; rc == 0 && i < n; i++) {
        const wpd_coll_input *e = &col->inputs[i];
        if (wpd_coll_names_find(outs, m, e->output) < 0 || e->night > col->nights ||
            e->first > UINT64_MAX - e->points)
            rc = bad(c, "inputs whose outputs are listed, of nights up to \"nights\"");
    }
    for (int i = 0; rc == 0 && i < col->npending; i++)
        if (wpd_coll_names_find(outs, m, col->pending[i].to) < 0 ||
            !strstr(col->pending[i].from, ".wpd-tmp-"))
            rc = bad(c, "renames from temporary outputs to listed outputs");
    free(outs);
    return rc;
}

int wpd_collection_parse(wpd_collection *col, const char *text, size_t len, const char *name,
                         wpd_error *err)
{
    cursor c = {text, len, 0, name, err, 0};
    void *outs, *ins, *pend;
    int rc = header(&c, col) || punct(&c, ',') || key(&c, "radius") ||
             real(&c, &col->radius) || punct(&c, ',') || key(&c, "density_factor") ||
             real(&c, &col->factor) || punct(&c, ',') || key(&c, "spacing") ||
             boolean(&c, &col->spacing) || punct(&c, ',') || key(&c, "options") ||
             options(&c, &col->opt) || punct(&c, ',') || key(&c, "nights") ||
             integer(&c, 1, 1 << 30, &col->nights) || punct(&c, ',') || key(&c, "outputs");
    if (rc == 0) {
        rc = array(&c, sizeof *col->outputs, &outs, &col->noutputs, output_item);
        col->outputs = outs;
    }
    if (rc == 0 && !(rc = punct(&c, ',') || key(&c, "inputs"))) {
        rc = array(&c, sizeof *col->inputs, &ins, &col->ninputs, input_item);
        col->inputs = ins;
    }
    if (rc == 0 && !(rc = punct(&c, ',') || key(&c, "pending"))) {
        rc = array(&c, sizeof *col->pending, &pend, &col->npending, rename_item);
        col->pending = pend;
    }
    if (rc == 0 && !(rc = punct(&c, '}'))) {
        ws(&c);
        if (c.at != len)
            rc = bad(&c, "the end of the file");
    }
    if (rc == 0)
        rc = consistent(&c, col);
    if (rc == 0)
        col->exists = 1;
    return rc ? -1 : 0;
}
