/* ply_header.c - the header of a PLY file: its lines up to end_header,
 * the vertex record layout built from them, and the size checks that
 * come before any of the body is read. The header is "ply", one "format"
 * line, then "element", "property" (scalar or list), "comment" and
 * "obj_info" lines, closed by "end_header".
 *
 * Lines that bend this without changing what the data means (free text
 * that is no keyword line, blank lines, blanks after end_header, a version
 * written "1" or "1.00", the format line twice) are read with one warning
 * per kind in the header's warnings; see docs/formats.md for each case.
 */
#include "io/ply/ply_reader.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/fullio.h"
#include "common/warnings.h"
#include "io/decimal.h"

#define PLY_HEADER_MAX (1u << 20)   /* a longer header is refused */
#define PLY_HEADER_READ (64u << 10) /* header bytes read at a time */
#define PLY_LINE_MAX (16u << 10)    /* longest header line */
#define PLY_LINE_TOKENS 6           /* most tokens on a header line */

static const char *const encoding_names[] = WPD_PLY_ENCODING_NAMES;

/* Harmless oddities of the header, each kind reported by one warning once
 * the header is read: its first line, what it says, how many more. */
enum { ODD_STRAY, ODD_BLANK, ODD_END_BLANKS, ODD_VERSION, ODD_FORMAT_AGAIN, ODD_KINDS };

typedef struct header_oddity {
    unsigned first_line, more;
    char text[64];           /* the start of the first such line, or a word */
} header_oddity;

typedef struct header_parser {
    wpd_reader *r;
    ply_reader *pr;
    char *buf;
    size_t len, cap, pos;    /* bytes read, allocated, start of the next line */
    int eof;
    unsigned line_no;
    int have_format, done;
    header_oddity odd[ODD_KINDS];
} header_parser;

/* Returns the next header line (without its newline, NUL-terminated in
 * place) in *line. Returns 1, 0 when the file ends, -1 with err set. */
static int header_next_line(header_parser *hp, char **line, size_t *len, wpd_error *err)
{
    const char *path = hp->r->hdr.path;
    for (;;) {
        char *nl = hp->buf ? memchr(hp->buf + hp->pos, '\n', hp->len - hp->pos) : NULL;
        if (nl || (hp->eof && hp->pos < hp->len)) {
            char *start = hp->buf + hp->pos;
            size_t n = nl ? (size_t)(nl - start) : hp->len - hp->pos;
            if (n > PLY_LINE_MAX)
                return wpd_fail(err, WPD_E_INPUT, "%s: PLY header line %u is longer than %u bytes",
                                path, hp->line_no + 1, PLY_LINE_MAX);
            hp->pos += n + (nl != NULL);
            start[n] = '\0'; /* the '\n' or the spare byte past len */
            *line = start;
            *len = n;
            hp->line_no++;
            return 1;
        }
        if (hp->eof)
            return 0;
        if (hp->len - hp->pos > PLY_LINE_MAX)
            return wpd_fail(err, WPD_E_INPUT, "%s: PLY header line %u is longer than %u bytes",
                            path, hp->line_no + 1, PLY_LINE_MAX);
        if (hp->len >= PLY_HEADER_MAX)
            return wpd_fail(err, WPD_E_INPUT,
                            "%s: PLY header has no end_header line within the first %u bytes",
                            path, PLY_HEADER_MAX);
        size_t want = PLY_HEADER_READ;
        if (hp->len + want > PLY_HEADER_MAX)
            want = PLY_HEADER_MAX - hp->len;
        if (hp->len + want + 1 > hp->cap) {
            size_t cap = hp->cap ? hp->cap * 2 : PLY_HEADER_READ + 1;
            while (cap < hp->len + want + 1)
                cap *= 2;
            char *grown = realloc(hp->buf, cap);
            if (!grown)
                return wpd_fail(err, WPD_E_MEMORY, "%s: out of memory", path);
            hp->buf = grown;
            hp->cap = cap;
        }
        ssize_t n = wpd_pread_full(hp->r->fd, hp->buf + hp->len, want, hp->len);
        if (n < 0)
            return wpd_fail_errno(err, "%s: cannot read", path);
        if ((size_t)n < want)
            hp->eof = 1;
        hp->len += (size_t)n;
    }
}

/* Strips trailing whitespace (CR of CRLF lines, trailing blanks). */
static void rstrip(char *line, size_t *len)
{
    while (*len && ply_is_space((unsigned char)line[*len - 1]))
        line[--*len] = '\0';
}

/* Splits line in place into at most max tokens; returns the count, or
 * max + 1 when there are more. */
static int split_tokens(char *line, char **tok, int max)
{
    int n = 0;
    char *p = line;
    for (;;) {
        while (*p && ply_is_space((unsigned char)*p))
            p++;
        if (!*p)
            return n;
        if (n == max)
            return max + 1;
        tok[n++] = p;
        while (*p && !ply_is_space((unsigned char)*p))
            p++;
        if (*p)
            *p++ = '\0';
    }
}

static int header_fail(header_parser *hp, wpd_error *err, const char *what, const char *arg)
{
    return wpd_fail(err, WPD_E_INPUT, "%s: PLY header line %u: %s%s%s%s", hp->r->hdr.path,
                    hp->line_no, what, arg ? " '" : "", arg ? arg : "", arg ? "'" : "");
}

/* Appends a copy of text to a string array of the header (comments or
 * obj_info), keeping the count equal to the allocated entries. */
static int push_string(char ***arr, uint32_t *n, const char *text)
{
    char **grown = realloc(*arr, (*n + 1) * sizeof **arr);
    if (!grown)
        return -1;
    *arr = grown;
    if (!(grown[*n] = strdup(text)))
        return -1;
    ++*n;
    return 0;
}

/* The text of a comment / obj_info line after its keyword and one blank. */
static const char *line_text(const char *line, size_t keyword_len)
{
    const char *p = line + keyword_len;
    return *p ? p + 1 : p;
}

/* Keeps text for a warning: at most sizeof odd->text - 1 bytes, "..." at
 * the end when cut. */
static void keep_text(char *dst, size_t size, const char *text)
{
    if ((size_t)snprintf(dst, size, "%s", text) >= size)
        memcpy(dst + size - 4, "...", 4);
}

/* Notes a line of an oddity kind: the first one is kept, the others counted. */
static void note_oddity(header_parser *hp, int kind, const char *text)
{
    header_oddity *o = &hp->odd[kind];
    if (o->first_line) {
        o->more++;
        return;
    }
    o->first_line = hp->line_no;
    if (text)
        keep_text(o->text, sizeof o->text, text);
}

/* One warning per kind of oddity met, naming the file and the first line. */
static void warn_oddities(const header_parser *hp)
{
    static const char *const what[ODD_KINDS] = {
        [ODD_STRAY] = "is not a keyword line (skipped)",
        [ODD_BLANK] = "is blank (skipped)",
        [ODD_END_BLANKS] = "has blanks after end_header (the data starts after the line end)",
        [ODD_VERSION] = "writes version 1.0 in another way (read as 1.0)",
        [ODD_FORMAT_AGAIN] = "repeats the format line (ignored)",
    };
    for (int k = 0; k < ODD_KINDS; k++) {
        const header_oddity *o = &hp->odd[k];
        if (!o->first_line)
            continue;
        char more[48] = "";
        if (o->more)
            snprintf(more, sizeof more, " (and %u more such line%s)", o->more,
                     o->more == 1 ? "" : "s");
        wpd_warn(&hp->r->hdr.warnings, "%s: PLY header line %u %s%s%s%s%s", hp->r->hdr.path,
                 o->first_line, what[k], o->text[0] ? ": '" : "", o->text,
                 o->text[0] ? "'" : "", more);
    }
}

/* A second format line that agrees with the first is only noted (it says
 * nothing new); one that disagrees leaves the encoding unknown. */
static int parse_format(header_parser *hp, char **tok, int n, wpd_error *err)
{
    if (n != 3)
        return header_fail(hp, err, "expected 'format <encoding> 1.0'", NULL);
    int enc = -1;
    for (int i = 0; i < 3; i++)
        if (!strcmp(tok[1], encoding_names[i]))
            enc = i;
    if (enc < 0)
        return header_fail(hp, err, "unknown format", tok[1]);
    double version;
    if (!wpd_decimal_exact(tok[2], strlen(tok[2]), &version) || version != 1.0)
        return header_fail(hp, err, "unsupported PLY version", tok[2]);
    if (hp->have_format) {
        if ((wpd_ply_encoding)enc != hp->pr->enc)
            return header_fail(hp, err, "second format line with another encoding", tok[1]);
        note_oddity(hp, ODD_FORMAT_AGAIN, NULL);
        return 0;
    }
    if (strcmp(tok[2], "1.0"))
        note_oddity(hp, ODD_VERSION, tok[2]);
    hp->pr->enc = (wpd_ply_encoding)enc;
    hp->have_format = 1;
    return 0;
}

static int parse_element(header_parser *hp, char **tok, int n, wpd_error *err)
{
    ply_reader *pr = hp->pr;
    if (n != 3)
        return header_fail(hp, err, "expected 'element <name> <count>'", NULL);
    int neg;
    uint64_t count;
    if (wpd_decimal_integer(tok[2], strlen(tok[2]), &neg, &count) != 1 || neg || tok[2][0] == '+')
        return header_fail(hp, err, "bad element count", tok[2]);
    ply_elem *grown = realloc(pr->elems, (pr->nelems + 1) * sizeof *grown);
    if (!grown)
        return wpd_fail(err, WPD_E_MEMORY, "%s: out of memory", hp->r->hdr.path);
    pr->elems = grown;
    ply_elem *e = &pr->elems[pr->nelems++];
    memset(e, 0, sizeof *e);
    snprintf(e->name, sizeof e->name, "%s", tok[1]);
    e->count = count;
    e->first_prop = pr->nprops;
    return 0;
}

static int parse_property(header_parser *hp, char **tok, int n, wpd_error *err)
{
    ply_reader *pr = hp->pr;
    if (!pr->nelems)
        return header_fail(hp, err, "property before any element", NULL);
    ply_prop p;
    memset(&p, 0, sizeof p);
    const char *name;
    if (n >= 2 && !strcmp(tok[1], "list")) {
        if (n != 5)
            return header_fail(hp, err,
                               "expected 'property list <count type> <item type> <name>'", NULL);
        if (wpd_type_parse(tok[2], &p.count_type))
            return header_fail(hp, err, "unknown list count type", tok[2]);
        if (!wpd_type_is_int(p.count_type))
            return header_fail(hp, err, "list count type is not an integer type", tok[2]);
        if (wpd_type_parse(tok[3], &p.type))
            return header_fail(hp, err, "unknown list item type", tok[3]);
        p.is_list = 1;
        name = tok[4];
    } else {
        if (n != 3)
            return header_fail(hp, err, "expected 'property <type> <name>'", NULL);
        if (wpd_type_parse(tok[1], &p.type))
            return header_fail(hp, err, "unknown property type", tok[1]);
        name = tok[2];
    }
    snprintf(p.name, sizeof p.name, "%s", name);
    if (pr->nprops == pr->props_cap) {
        uint32_t cap = pr->props_cap ? pr->props_cap * 2 : 32;
        ply_prop *grown = realloc(pr->props, cap * sizeof *grown);
        if (!grown)
            return wpd_fail(err, WPD_E_MEMORY, "%s: out of memory", hp->r->hdr.path);
        pr->props = grown;
        pr->props_cap = cap;
    }
    pr->props[pr->nprops++] = p;
    ply_elem *e = &pr->elems[pr->nelems - 1];
    e->nprops++;
    e->has_lists |= p.is_list;
    e->item_bytes += wpd_type_size(p.is_list ? p.count_type : p.type);
    /* A vertex property whose name does not fit a schema dimension. */
    if (!strcmp(e->name, "vertex") && strlen(name) >= WPD_DIM_NAME_MAX && !p.is_list)
        return header_fail(hp, err, "vertex property name too long", name);
    return 0;
}

/* 1 if word reads as the start of a number (data, not a keyword). */
static int starts_number(const char *word)
{
    const char *p = word + (*word == '-' || *word == '+');
    return (*p >= '0' && *p <= '9') || (*p == '.' && p[1] >= '0' && p[1] <= '9');
}

/* A line whose first word is no keyword: free text some writers put in the
 * header (Blender 2.4x's "Created by Blender3D 247 - www.blender.org, ...")
 * is skipped with a warning, as PCL does. Refused when skipping it could
 * change what the data means: a number (data before a missing end_header),
 * or the shape of a declaration whose keyword is misspelled ("<word> <type>
 * <name>", "<word> list ...", "<word> <name> <count>"), which would
 * misplace every property after it. */
static int stray_line(header_parser *hp, char **tok, int n, const char *text, wpd_error *err)
{
    if (starts_number(tok[0]))
        return header_fail(hp, err, "a number where a keyword belongs (no end_header line?)",
                           tok[0]);
    wpd_type type;
    int neg;
    uint64_t count;
    int declaration = (n == 3 && !wpd_type_parse(tok[1], &type)) ||
                      (n == 5 && !strcmp(tok[1], "list")) ||
                      (n == 3 && wpd_decimal_integer(tok[2], strlen(tok[2]), &neg, &count) == 1);
    if (declaration)
        return header_fail(hp, err, "unknown keyword on a line shaped like a declaration",
                           tok[0]);
    note_oddity(hp, ODD_STRAY, text);
    return 0;
}

static int end_header(header_parser *hp, int n, int trailing_blanks, wpd_error *err)
{
    if (n != 1)
        return header_fail(hp, err, "text after end_header", NULL);
    if (trailing_blanks)
        note_oddity(hp, ODD_END_BLANKS, NULL);
    hp->done = 1;
    return 0;
}

/* Handles one header line. */
static int header_line(header_parser *hp, char *line, size_t len, wpd_error *err)
{
    wpd_ply_info *info = &hp->r->hdr.ply;
    if (memchr(line, '\0', len))
        return header_fail(hp, err, "binary data before end_header", NULL);
    if (len && line[len - 1] == '\r') /* CRLF line ends: no oddity */
        line[--len] = '\0';
    int trailing_blanks = len && ply_is_space((unsigned char)line[len - 1]);
    rstrip(line, &len);
    if (hp->line_no == 1) {
        if (strcmp(line, "ply"))
            return wpd_fail(err, WPD_E_INPUT, "%s: not a PLY file (no 'ply' magic line)",
                            hp->r->hdr.path);
        return 0;
    }
    size_t kw = strcspn(line, " \t");
    if ((kw == 7 && !strncmp(line, "comment", 7)) || (kw == 8 && !strncmp(line, "obj_info", 8))) {
        int is_comment = kw == 7;
        if (push_string(is_comment ? &info->comments : &info->obj_info,
                        is_comment ? &info->ncomments : &info->nobj_info, line_text(line, kw)))
            return wpd_fail(err, WPD_E_MEMORY, "%s: out of memory", hp->r->hdr.path);
        return 0;
    }
    char text[sizeof hp->odd[0].text];
    keep_text(text, sizeof text, line); /* split_tokens cuts the line up */
    char *tok[PLY_LINE_TOKENS];
    int n = split_tokens(line, tok, PLY_LINE_TOKENS);
    if (n == 0) {
        note_oddity(hp, ODD_BLANK, NULL);
        return 0;
    }
    if (!strcmp(tok[0], "format"))
        return parse_format(hp, tok, n, err);
    if (!strcmp(tok[0], "element"))
        return parse_element(hp, tok, n, err);
    if (!strcmp(tok[0], "property"))
        return parse_property(hp, tok, n, err);
    if (!strcmp(tok[0], "end_header"))
        return end_header(hp, n, trailing_blanks, err);
    return stray_line(hp, tok, n, text, err);
}

/* Reads and parses the header up to end_header; sets pr->body_offset. */
static int parse_header(wpd_reader *r, ply_reader *pr, wpd_error *err)
{
    header_parser hp = {.r = r, .pr = pr};
    int rc = 0;
    while (!hp.done) {
        char *line = NULL;
        size_t len = 0;
        rc = header_next_line(&hp, &line, &len, err);
        if (rc < 0)
            break;
        if (rc == 0) {
            rc = hp.line_no == 0 || hp.len == 0
                     ? wpd_fail(err, WPD_E_INPUT, "%s: not a PLY file (no 'ply' magic line)",
                                r->hdr.path)
                     : wpd_fail(err, WPD_E_INPUT, "%s: PLY header has no end_header line",
                                r->hdr.path);
            break;
        }
        if ((rc = header_line(&hp, line, len, err)) < 0)
            break;
    }
    free(hp.buf);
    if (rc < 0)
        return -1;
    if (!hp.have_format)
        return wpd_fail(err, WPD_E_INPUT, "%s: PLY header has no format line", r->hdr.path);
    pr->body_offset = hp.pos;
    pr->header_lines = hp.line_no;
    warn_oddities(&hp);
    return 0;
}

/* ------------------------------------------------------------------ layout */

/* Builds the record schema from the vertex element's scalar properties. */
static int build_schema(wpd_reader *r, ply_reader *pr, wpd_error *err)
{
    const char *path = r->hdr.path;
    const ply_elem *v = &pr->elems[pr->vertex];
    wpd_schema *s = &r->hdr.schema;
    memset(s, 0, sizeof *s);
    uint32_t offset = 0;
    for (uint32_t i = 0; i < v->nprops; i++) {
        ply_prop *p = &pr->props[v->first_prop + i];
        if (p->is_list) {
            if (!strcmp(p->name, "x") || !strcmp(p->name, "y") || !strcmp(p->name, "z"))
                return wpd_fail(err, WPD_E_INPUT, "%s: PLY vertex property '%s' is a list",
                                path, p->name);
            continue;
        }
        if (wpd_schema_find(s, p->name) >= 0)
            return wpd_fail(err, WPD_E_INPUT, "%s: PLY vertex property '%s' appears twice",
                            path, p->name);
        if (wpd_schema_add(s, p->name, p->type, offset) < 0)
            return wpd_fail(err, WPD_E_INPUT, "%s: PLY vertex element has more than %d properties",
                            path, WPD_MAX_DIMS);
        p->offset = offset;
        offset += (uint32_t)wpd_type_size(p->type);
    }
    s->record_size = offset;
    s->dim_x = wpd_schema_find(s, "x");
    s->dim_y = wpd_schema_find(s, "y");
    s->dim_z = wpd_schema_find(s, "z");
    if (s->dim_x < 0 || s->dim_y < 0)
        return wpd_fail(err, WPD_E_INPUT, "%s: PLY vertex element has no '%s' property", path,
                        s->dim_x < 0 ? "x" : "y");
    pr->record_size = offset;
    const int idx[3] = {s->dim_x, s->dim_y, s->dim_z};
    for (int c = 0; c < 3; c++) {
        pr->coord[c].present = idx[c] >= 0;
        if (idx[c] >= 0) {
            pr->coord[c].type = s->dims[idx[c]].type;
            pr->coord[c].offset = s->dims[idx[c]].offset;
        }
    }
    for (uint32_t i = 0; i < s->ndims; i++) {
        size_t size = wpd_type_size(s->dims[i].type);
        if (size > 1) {
            pr->swap_offset[pr->nswap] = (uint16_t)s->dims[i].offset;
            pr->swap_size[pr->nswap++] = (uint8_t)size;
        }
    }
    return 0;
}

/* Copies the element list into hdr.ply (owned by the header). */
static int fill_ply_info(wpd_reader *r, ply_reader *pr, wpd_error *err)
{
    wpd_ply_info *info = &r->hdr.ply;
    info->encoding = pr->enc;
    info->vertex_element = pr->vertex;
    info->elements = calloc(pr->nelems, sizeof *info->elements);
    if (!info->elements)
        return wpd_fail(err, WPD_E_MEMORY, "%s: out of memory", r->hdr.path);
    info->nelements = pr->nelems;
    for (uint32_t i = 0; i < pr->nelems; i++) {
        wpd_ply_element_info *e = &info->elements[i];
        snprintf(e->name, sizeof e->name, "%s", pr->elems[i].name);
        e->count = pr->elems[i].count;
        e->nprops = pr->elems[i].nprops;
        e->has_lists = pr->elems[i].has_lists;
    }
    return 0;
}

/* Binary vertex data that does not fit: reported as where the file ends. */
int ply_fail_vertex_space(const wpd_reader *r, const ply_elem *v, uint64_t need,
                          uint64_t avail, uint64_t offset, wpd_error *err)
{
    return wpd_fail(err, WPD_E_INPUT,
                    "%s: file ends after %llu of %llu vertices (PLY element 'vertex' count "
                    "%llu needs %s%llu bytes but only %llu bytes follow offset %llu)",
                    r->hdr.path, (unsigned long long)(avail / v->item_bytes),
                    (unsigned long long)v->count, (unsigned long long)v->count,
                    v->has_lists ? "at least " : "", (unsigned long long)need,
                    (unsigned long long)avail, (unsigned long long)offset);
}

/* Checks, before anything is looped over, that the elements up to and
 * including the vertex element can fit in the bytes after the header:
 * binary items need at least their scalar and list-count bytes, ascii items
 * at least one character and one separator per property (the last
 * separator may be missing). */
static int check_sizes(wpd_reader *r, ply_reader *pr, wpd_error *err)
{
    uint64_t avail = r->hdr.file_size > pr->body_offset ? r->hdr.file_size - pr->body_offset : 0;
    uint64_t slack = pr->enc == WPD_PLY_ASCII ? 1 : 0;
    uint64_t need = 0;
    for (uint32_t i = 0; i <= pr->vertex; i++) {
        const ply_elem *e = &pr->elems[i];
        uint64_t per_item = pr->enc == WPD_PLY_ASCII ? 2 * (uint64_t)e->nprops : e->item_bytes;
        uint64_t total;
        int overflow = ply_muladd_u64(e->count, per_item, need, &total);
        if (!overflow && total <= avail + slack) {
            need = total;
            continue;
        }
        if (!overflow && i == pr->vertex && !slack)
            return ply_fail_vertex_space(r, e, total - need, avail - need,
                                     pr->body_offset + need, err);
        char needed[32] = "more than 2^64";
        if (!overflow)
            snprintf(needed, sizeof needed, "%llu", (unsigned long long)(total - slack));
        return wpd_fail(err, WPD_E_INPUT,
                        "%s: PLY element '%s' count %llu cannot fit in the file: the data up "
                        "to it needs at least %s bytes but only %llu bytes follow the header",
                        r->hdr.path, e->name, (unsigned long long)e->count, needed,
                        (unsigned long long)avail);
    }
    return 0;
}

int ply_read_header(wpd_reader *r, ply_reader *pr, wpd_error *err)
{
    const char *path = r->hdr.path;
    if (parse_header(r, pr, err))
        return -1;
    uint32_t v = 0;
    while (v < pr->nelems && strcmp(pr->elems[v].name, "vertex"))
        v++;
    if (v == pr->nelems)
        return wpd_fail(err, WPD_E_INPUT, "%s: PLY header has no 'vertex' element", path);
    pr->vertex = v;
    pr->count = pr->elems[v].count;
    if (build_schema(r, pr, err) || fill_ply_info(r, pr, err) || check_sizes(r, pr, err))
        return -1;
    r->hdr.format = WPD_FMT_PLY;
    r->hdr.point_count = pr->count;
    return 0;
}
