/* append.c - a point file made longer (append.h). */
#include "io/append.h"

#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "common/fullio.h"
#include "io/las/las.h"
#include "io/las/las_internal.h"
#include "io/reader.h"

enum { STEP = 1 << 20 };           /* bytes copied at once */
enum { PLY_HEADER_MAX = 1 << 20 }; /* a PLY header longer than this is refused */

typedef struct source {
    wpd_reader *r;
    const wpd_header *h;
    int fd;
    uint64_t body, end;      /* the records: bytes body .. end - 1 */
} source;

static void source_close(source *s)
{
    wpd_reader_close(s->r);
    if (s->fd >= 0)
        close(s->fd);
}

static int source_open(const char *path, source *s, wpd_error *err)
{
    memset(s, 0, sizeof *s);
    s->fd = -1;
    if (!(s->r = wpd_reader_open(path, err)))
        return -1;
    s->h = wpd_reader_header(s->r);
    if ((s->fd = open(path, O_RDONLY | O_CLOEXEC)) < 0)
        return wpd_fail_errno(err, "%s: cannot open", path);
    return 0;
}

/* Copies bytes [from, to) of s into dest. */
static int copy_bytes(const source *s, uint64_t from, uint64_t to, wpd_outfile *dest,
                      wpd_error *err)
{
    uint8_t *buf = malloc(STEP);
    int rc = buf ? 0 : wpd_fail(err, WPD_E_MEMORY, "out of memory");
    for (uint64_t at = from; rc == 0 && at < to; at += STEP) {
        size_t n = to - at < STEP ? (size_t)(to - at) : STEP;
        if (wpd_pread_full(s->fd, buf, n, at) != (ssize_t)n)
            rc = wpd_fail(err, WPD_E_IO, "%s: cut short or unreadable", s->h->path);
        else
            rc = wpd_outfile_write(dest, buf, n, err);
    }
    free(buf);
    return rc;
}

/* ------------------------------------------------------------ LAS */

static int las_appendable(const wpd_header *h, wpd_error *err)
{
    if (h->las.laz.compressed)
        return wpd_fail(err, WPD_E_USAGE, "%s: --append to LAZ would encode every old record "
                        "again: write LAS or PLY", h->path);
    if (h->las.nevlr)
        return wpd_fail(err, WPD_E_USAGE, "%s: has extended VLRs after its points: --append "
                        "cannot add points before them", h->path);
    return 0;
}

/* The same fields at the same places (coordinates' scale and offset
 * aside). */
static int same_layout(const wpd_header *a, const wpd_header *b)
{
    const wpd_schema *x = &a->schema, *y = &b->schema;
    if (x->record_size != y->record_size || x->ndims != y->ndims)
        return 0;
    for (uint32_t i = 0; i < x->ndims; i++) {
        const wpd_dim *p = &x->dims[i], *q = &y->dims[i];
        int coord = (int)i == x->dim_x || (int)i == x->dim_y || (int)i == x->dim_z;
        if (strcmp(p->name, q->name) || p->type != q->type || p->offset != q->offset ||
            p->bit_shift != q->bit_shift || p->bit_count != q->bit_count ||
            p->scaled != q->scaled ||
            (!coord && p->scaled && (p->scale != q->scale || p->add != q->add)))
            return 0;
    }
    return 1;
}

/* What the new records add to the header. */
typedef struct las_totals {
    uint64_t by_return[16];
    int32_t qmin[3], qmax[3];
} las_totals;

/* Part's records (n of them at rec) in OUT's coordinates, tallied. */
static int las_recode(const wpd_header *out, const wpd_header *part, uint8_t *rec, size_t n,
                      las_totals *t, wpd_error *err)
{
    uint32_t len = out->las.record_length;
    int same = 1;
    for (int a = 0; a < 3; a++)
        same &= out->las.scale[a] == part->las.scale[a] &&
                out->las.offset[a] == part->las.offset[a];
    for (size_t i = 0; i < n; i++) {
        uint8_t *p = rec + i * len;
        for (int a = 0; a < 3; a++) {
            int32_t q = (int32_t)las_get_u32(p + 4 * a);
            if (!same) {
                double v = q * part->las.scale[a] + part->las.offset[a];
                double u = nearbyint((v - out->las.offset[a]) / out->las.scale[a]);
                if (!(u >= -2147483648.0 && u <= 2147483647.0))
                    return wpd_fail(err, WPD_E_USAGE, "%s: a point at %.17g lies outside what "
                                    "the scale and offset of %s can hold", part->path, v,
                                    out->path);
                q = (int32_t)u;
                las_put_u32(p + 4 * a, (uint32_t)q);
            }
            t->qmin[a] = q < t->qmin[a] ? q : t->qmin[a];
            t->qmax[a] = q > t->qmax[a] ? q : t->qmax[a];
        }
    }
    wpd_las_tally_returns(out, rec, n, t->by_return);
    return 0;
}

/* OUT's header bytes with the totals of both files. */
static void las_patch(uint8_t *head, const wpd_header *out, uint64_t added, const las_totals *t)
{
    const wpd_las_info *L = &out->las;
    uint64_t total = L->point_count + added;
    uint64_t by[16] = {0};
    for (int k = 1; k < 16; k++)
        by[k] = (k <= 15 ? L->points_by_return[k - 1] : 0) + t->by_return[k];
    int legacy = L->version_minor < 4 || (L->pdrf < 6 && total <= UINT32_MAX);
    las_put_u32(head + LAS_OFF_LEGACY_COUNT, legacy ? (uint32_t)total : 0);
    for (int i = 0; i < 5; i++)
        las_put_u32(head + LAS_OFF_LEGACY_BY_RETURN + 4 * i, legacy ? (uint32_t)by[i + 1] : 0);
    for (int a = 0; added && a < 3; a++) {
        double lo = t->qmin[a] * L->scale[a] + L->offset[a];
        double hi = t->qmax[a] * L->scale[a] + L->offset[a];
        if (L->point_count)
            lo = fmin(lo, L->min[a]), hi = fmax(hi, L->max[a]);
        las_put_f64(head + LAS_OFF_BOUNDS + 16 * a, hi);
        las_put_f64(head + LAS_OFF_BOUNDS + 16 * a + 8, lo);
    }
    if (L->version_minor >= 4 && L->header_size >= LAS_HEADER_SIZE_14) {
        las_put_u64(head + LAS_OFF_COUNT, total);
        for (int i = 0; i < 15; i++)
            las_put_u64(head + LAS_OFF_BY_RETURN + 8 * i, by[i + 1]);
    }
}

static int las_append(source *o, source *p, wpd_outfile *dest, wpd_error *err)
{
    const wpd_las_info *L = &o->h->las;
    if (las_appendable(o->h, err) || las_appendable(p->h, err))
        return -1;
    if (L->pdrf != p->h->las.pdrf || !same_layout(o->h, p->h))
        return wpd_fail(err, WPD_E_USAGE, "%s: its points (format %d, %u bytes) are not laid "
                        "out as those of %s (format %d, %u bytes): --append needs one layout",
                        p->h->path, p->h->las.pdrf, p->h->las.record_length, o->h->path, L->pdrf,
                        L->record_length);
    uint32_t len = L->record_length;
    las_totals t = {{0}, {INT32_MAX, INT32_MAX, INT32_MAX}, {INT32_MIN, INT32_MIN, INT32_MIN}};
    uint8_t *head = malloc(L->offset_to_points ? L->offset_to_points : 1);
    uint8_t *buf = malloc((size_t)STEP / len * len + len);
    int rc = head && buf ? 0 : wpd_fail(err, WPD_E_MEMORY, "out of memory");
    if (rc == 0 && wpd_pread_full(o->fd, head, L->offset_to_points, 0) !=
                       (ssize_t)L->offset_to_points)
        rc = wpd_fail(err, WPD_E_IO, "%s: cut short or unreadable", o->h->path);
    /* the header's place now, its totals at the end */
    if (rc == 0)
        rc = wpd_outfile_write(dest, head, L->offset_to_points, err);
    if (rc == 0)
        rc = copy_bytes(o, L->offset_to_points, L->offset_to_points + L->point_count * len,
                        dest, err);
    uint64_t n = p->h->las.point_count, per = STEP / len;
    for (uint64_t at = 0; rc == 0 && at < n; at += per) {
        size_t m = (size_t)(n - at < per ? n - at : per);
        uint64_t off = p->h->las.offset_to_points + at * len;
        if (wpd_pread_full(p->fd, buf, m * len, off) != (ssize_t)(m * len))
            rc = wpd_fail(err, WPD_E_IO, "%s: cut short or unreadable", p->h->path);
        else if ((rc = las_recode(o->h, p->h, buf, m, &t, err)) == 0)
            rc = wpd_outfile_write(dest, buf, m * len, err);
    }
    if (rc == 0) {
        las_patch(head, o->h, n, &t);
        rc = wpd_outfile_pwrite(dest, head, L->offset_to_points, 0, err);
    }
    free(head);
    free(buf);
    return rc;
}

/* ------------------------------------------------------------ PLY */

/* The header text of a PLY file (up to and with "end_header\n"). */
static int ply_header_text(const source *s, char **text, size_t *len, wpd_error *err)
{
    size_t cap = s->h->file_size < PLY_HEADER_MAX ? (size_t)s->h->file_size : PLY_HEADER_MAX;
    char *buf = malloc(cap + 1);
    if (!buf)
        return wpd_fail(err, WPD_E_MEMORY, "out of memory");
    ssize_t got = wpd_pread_full(s->fd, buf, cap, 0);
    buf[got > 0 ? got : 0] = '\0';
    char *end = got > 0 ? strstr(buf, "\nend_header\n") : NULL;
    if (!end) {
        free(buf);
        return wpd_fail(err, WPD_E_USAGE, "%s: its header does not end in \"end_header\" and "
                        "a newline within %d bytes: --append cannot place its points",
                        s->h->path, PLY_HEADER_MAX);
    }
    *len = (size_t)(end - buf) + strlen("\nend_header\n");
    buf[*len] = '\0';
    *text = buf;
    return 0;
}

/* The header's lines that say how the records are laid out: every line
 * but comments, obj_info and the vertex count, joined. */
static void ply_layout_lines(const char *header, char *out, size_t size)
{
    size_t n = 0;
    for (const char *line = header; *line;) {
        const char *eol = strchr(line, '\n');
        size_t len = eol ? (size_t)(eol - line) + 1 : strlen(line);
        int skip = !strncmp(line, "comment", 7) || !strncmp(line, "obj_info", 8) ||
                   !strncmp(line, "element vertex ", 15);
        if (!skip && n + len < size) {
            memcpy(out + n, line, len);
            n += len;
        }
        line += len;
    }
    out[n] = '\0';
}

static int ply_append(source *o, source *p, wpd_outfile *dest, wpd_error *err)
{
    const wpd_ply_info *a = &o->h->ply;
    if (a->nelements != 1 || p->h->ply.nelements != 1)
        return wpd_fail(err, WPD_E_USAGE, "%s: --append adds vertices to files with no other "
                        "element", a->nelements != 1 ? o->h->path : p->h->path);
    char *ho = NULL, *hp = NULL, *lo = NULL, *lp = NULL;
    size_t no = 0, np = 0;
    int rc = ply_header_text(o, &ho, &no, err) || ply_header_text(p, &hp, &np, err) ? -1 : 0;
    if (rc == 0 && (!(lo = malloc(no + 1)) || !(lp = malloc(np + 1))))
        rc = wpd_fail(err, WPD_E_MEMORY, "out of memory");
    if (rc == 0) {
        ply_layout_lines(ho, lo, no + 1);
        ply_layout_lines(hp, lp, np + 1);
        if (strcmp(lo, lp))
            rc = wpd_fail(err, WPD_E_USAGE, "%s: its vertices are not laid out as those of %s: "
                          "--append needs one layout", p->h->path, o->h->path);
    }
    uint64_t total = a->elements[0].count + p->h->ply.elements[0].count;
    for (const char *line = ho; rc == 0 && *line;) { /* the header, with the new count */
        const char *eol = strchr(line, '\n');
        size_t len = (size_t)(eol - line) + 1;
        char count[64];
        if (!strncmp(line, "element vertex ", 15)) {
            int n = snprintf(count, sizeof count, "element vertex %llu\n",
                             (unsigned long long)total);
            rc = wpd_outfile_write(dest, count, (size_t)n, err);
        } else {
            rc = wpd_outfile_write(dest, line, len, err);
        }
        line += len;
    }
    if (rc == 0)
        rc = copy_bytes(o, no, o->h->file_size, dest, err);
    if (rc == 0)
        rc = copy_bytes(p, np, p->h->file_size, dest, err);
    free(ho), free(hp), free(lo), free(lp);
    return rc;
}

/* ------------------------------------------------------------ both */

int wpd_append_check(const char *out, wpd_error *err)
{
    source o;
    int rc = source_open(out, &o, err);
    if (rc == 0 && o.h->format == WPD_FMT_LAS)
        rc = las_appendable(o.h, err);
    else if (rc == 0 && o.h->ply.nelements != 1)
        rc = wpd_fail(err, WPD_E_USAGE, "%s: --append adds vertices to files with no other "
                      "element", out);
    source_close(&o);
    return rc;
}

int wpd_append_files(const char *out, const char *part, wpd_outfile *dest, uint64_t *old,
                     uint64_t *added, wpd_error *err)
{
    source o, p;
    int opened = source_open(out, &o, err) == 0;
    int rc = opened && source_open(part, &p, err) == 0 ? 0 : -1;
    if (rc == 0 && o.h->format != p.h->format)
        rc = wpd_fail(err, WPD_E_USAGE, "%s and %s: not one format", out, part);
    else if (rc == 0)
        rc = o.h->format == WPD_FMT_LAS ? las_append(&o, &p, dest, err)
                                        : ply_append(&o, &p, dest, err);
    if (rc == 0) {
        *old = o.h->point_count;
        *added = p.h->point_count;
    }
    if (opened)
        source_close(&p); /* opened or zeroed (fd -1) by source_open */
    source_close(&o);
    return rc;
}
