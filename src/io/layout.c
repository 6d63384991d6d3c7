#include "io/layout.h"

#include "io/las/las.h"

#include <stdarg.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#define PROVENANCE "wpd_las"   /* comment keyword remembering LAS facts in a PLY */

static int is_coordinate(const wpd_schema *s, int i)
{
    return i == s->dim_x || i == s->dim_y || i == s->dim_z;
}

/* A plain field (no bit field, no scale) of one type on both sides with no
 * multiplier is copied as bytes: a value round trip through double would
 * quieten signalling NaNs (real files hold such GPS times) and round 64-bit
 * integers. */
static int raw_copy(const wpd_dim *a, const wpd_dim *b, double mul)
{
    return mul == 1.0 && a->type == b->type && !a->bit_count && !b->bit_count &&
           !a->scaled && !b->scaled;
}

static void map_add(wpd_layout_map *m, const wpd_schema *in, int src, const wpd_schema *out,
                    int dst, double mul)
{
    wpd_field_map *f = &m->fields[m->nfields++];
    f->src = (int16_t)src;
    f->dst = (int16_t)dst;
    f->mul = mul;
    f->raw_bytes = raw_copy(&in->dims[src], &out->dims[dst], mul)
                       ? (uint8_t)wpd_type_size(in->dims[src].type)
                       : 0;
}

/* ------------------------------------------------------------------ LAS -> PLY */

/* PLY property type for a LAS dimension. 64-bit integers become double:
 * PLY 1.0 has no 64-bit integer type and common readers (rply, MeshLab)
 * refuse the int64/uint64 extension; values stay exact below 2^53. */
static wpd_type ply_type_for(const wpd_dim *d)
{
    if (d->bit_count)
        return WPD_U8;
    if (d->scaled || d->type == WPD_I64 || d->type == WPD_U64)
        return WPD_F64;
    return d->type;
}

static int add_comment(wpd_header *out, const char *fmt, ...)
    __attribute__((format(printf, 2, 3)));

static int add_comment(wpd_header *out, const char *fmt, ...)
{
    char line[256];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(line, sizeof line, fmt, ap);
    va_end(ap);
    char **grown = realloc(out->ply.comments, (out->ply.ncomments + 1) * sizeof *grown);
    if (!grown)
        return -1;
    out->ply.comments = grown;
    if (!(grown[out->ply.ncomments] = strdup(line)))
        return -1;
    out->ply.ncomments++;
    return 0;
}

static int remember_las(wpd_header *out, const wpd_las_info *las)
{
    return add_comment(out, PROVENANCE " version %u.%u pdrf %u", las->version_major,
                       las->version_minor, las->pdrf) ||
           add_comment(out, PROVENANCE " scale %.17g %.17g %.17g", las->scale[0],
                       las->scale[1], las->scale[2]) ||
           add_comment(out, PROVENANCE " offset %.17g %.17g %.17g", las->offset[0],
                       las->offset[1], las->offset[2]);
}

static int plan_las_to_ply(const wpd_header *in, wpd_header *out, wpd_layout_map *m,
                           wpd_error *err)
{
    wpd_schema *s = &out->schema;
    const wpd_schema *is = &in->schema;
    static const char *axis[3] = {"x", "y", "z"};
    uint32_t off = 0;
    /* Coordinates need no mapping: writers take them from the batch's xyz. */
    for (int k = 0; k < 3; k++, off += 8)
        wpd_schema_add(s, axis[k], WPD_F64, off);
    s->dim_x = 0, s->dim_y = 1, s->dim_z = 2;
    for (uint32_t i = 0; i < is->ndims; i++) {
        if (is_coordinate(is, (int)i))
            continue;
        wpd_type t = ply_type_for(&is->dims[i]);
        int d = wpd_schema_add(s, is->dims[i].name, t, off);
        if (d < 0)
            return wpd_fail(err, WPD_E_INPUT, "%s: too many dimensions for PLY", in->path);
        off += (uint32_t)wpd_type_size(t);
        map_add(m, is, (int)i, s, d, 1.0);
    }
    s->record_size = off;
    out->ply.encoding = WPD_PLY_BINARY_LE;
    if (remember_las(out, &in->las))
        return wpd_fail(err, WPD_E_MEMORY, "out of memory");
    return 0;
}

/* ------------------------------------------------------------------ PLY -> LAS */

/* LAS facts a PLY written by wpd remembers in its comments. */
typedef struct remembered_las {
    int have_format, have_scale, have_offset;
    unsigned major, minor, pdrf;
    double scale[3], offset[3];
} remembered_las;

static void read_remembered(const wpd_ply_info *ply, remembered_las *r)
{
    memset(r, 0, sizeof *r);
    for (uint32_t i = 0; i < ply->ncomments; i++) {
        const char *c = ply->comments[i];
        if (strncmp(c, PROVENANCE " ", sizeof PROVENANCE))
            continue;
        c += sizeof PROVENANCE;
        if (sscanf(c, "version %u.%u pdrf %u", &r->major, &r->minor, &r->pdrf) == 3)
            r->have_format = r->major == 1 && r->minor <= 4 && r->pdrf <= 10;
        else if (sscanf(c, "scale %lf %lf %lf", &r->scale[0], &r->scale[1], &r->scale[2]) == 3)
            r->have_scale = r->scale[0] > 0 && r->scale[1] > 0 && r->scale[2] > 0;
        else if (sscanf(c, "offset %lf %lf %lf", &r->offset[0], &r->offset[1],
                        &r->offset[2]) == 3)
            r->have_offset = 1;
    }
}

/* Name comparison for properties that mean a LAS dimension: case-insensitive,
 * ignoring CloudCompare's "scalar_" prefix. */
static const char *bare_name(const char *name)
{
    return strncasecmp(name, "scalar_", 7) ? name : name + 7;
}

static int find_ply_source(const wpd_schema *in, const char *las_name, const int *used)
{
    for (uint32_t i = 0; i < in->ndims; i++)
        if (!used[i] && !strcasecmp(bare_name(in->dims[i].name), las_name))
            return (int)i;
    return -1;
}

/* Picks a power-of-ten LAS scale for one axis: fine enough to keep the
 * precision the input type has (the float32 spacing at the largest magnitude,
 * 1 for integers), coarse enough that the span fits in a 32-bit integer. */
static double pick_scale(wpd_type t, double lo, double hi)
{
    double want = 1.0;                     /* integer coordinates */
    if (t == WPD_F64) {
        want = 1e-9;
    } else if (t == WPD_F32) {
        double mag = fmax(fabs(lo), fabs(hi));
        int e;
        frexp(mag > 0 ? mag : 1.0, &e);
        want = ldexp(1.0, e - 24);         /* float32 spacing near mag */
    }
    double scale = pow(10.0, floor(log10(want)));
    double fit = (hi - lo) / 4.0e9;        /* offset at the centre: +-2e9 units */
    if (scale < fit)
        scale = pow(10.0, ceil(log10(fit)));
    return scale;
}

static double pick_offset(double lo, double hi, double scale)
{
    if (!isfinite(lo) || !isfinite(hi))
        return 0;
    double centre = 0.5 * (lo + hi);
    double rounded = nearbyint(centre);
    /* A whole-number offset reads better; keep it if the span still fits. */
    if (fmax(hi - rounded, rounded - lo) / scale < 2.0e9)
        return rounded;
    return nearbyint(centre / scale) * scale;
}

static int pick_pdrf(const wpd_schema *in)
{
    int has_rgb = wpd_schema_find(in, "red") >= 0 && wpd_schema_find(in, "green") >= 0 &&
                  wpd_schema_find(in, "blue") >= 0;
    if (has_rgb && wpd_schema_find(in, "nir") >= 0)
        return 8;
    return has_rgb ? 7 : 6;
}

/* Colour depth change: 8-bit and 0..1 float colours become 16-bit. */
static double colour_multiplier(const char *las_name, wpd_type src)
{
    int colour = !strcmp(las_name, "red") || !strcmp(las_name, "green") ||
                 !strcmp(las_name, "blue") || !strcmp(las_name, "nir");
    if (!colour)
        return 1.0;
    if (src == WPD_U8 || src == WPD_I8)
        return 257.0;
    return src == WPD_F32 || src == WPD_F64 ? 65535.0 : 1.0;
}

/* One 192-byte Extra Bytes descriptor for dimension d. */
static void put_descriptor(uint8_t *desc, const wpd_dim *d)
{
    char description[64];
    snprintf(description, sizeof description, "%s (from PLY)", d->name);
    wpd_las_put_descriptor(desc, d->type, d->name, description);
}

static int add_extra_bytes_vlr(wpd_las_info *las, const wpd_schema *in, const int *extra,
                               int nextra)
{
    wpd_vlr *v = calloc(1, sizeof *v);
    if (!v || !(v->data = calloc((size_t)nextra, 192))) {
        free(v);
        return -1;
    }
    strcpy(v->user_id, "LASF_Spec");
    v->record_id = 4;
    v->length = (uint64_t)nextra * 192;
    strcpy(v->description, "Extra Bytes");
    for (int i = 0; i < nextra; i++)
        put_descriptor(v->data + 192 * i, &in->dims[extra[i]]);
    las->vlrs = v;
    las->nvlr = 1;
    return 0;
}

static void plan_las_frame(const wpd_header *in, const wpd_bounds *bounds,
                           const remembered_las *mem, wpd_las_info *las)
{
    const wpd_schema *is = &in->schema;
    int axes[3] = {is->dim_x, is->dim_y, is->dim_z};
    for (int k = 0; k < 3; k++) {
        wpd_type t = axes[k] >= 0 ? is->dims[axes[k]].type : WPD_I32;
        double lo = bounds && bounds->count ? bounds->min[k] : 0;
        double hi = bounds && bounds->count ? bounds->max[k] : 0;
        las->scale[k] = mem->have_scale ? mem->scale[k] : pick_scale(t, lo, hi);
        las->offset[k] = mem->have_offset ? mem->offset[k] : pick_offset(lo, hi, las->scale[k]);
    }
}

static int plan_ply_to_las(const wpd_header *in, const wpd_bounds *bounds, wpd_header *out,
                           wpd_layout_map *m, wpd_error *err)
{
    const wpd_schema *is = &in->schema;
    remembered_las mem;
    read_remembered(&in->ply, &mem);
    wpd_las_info *las = &out->las;
    las->version_major = 1;
    las->version_minor = mem.have_format ? (uint8_t)mem.minor : 4;
    las->pdrf = (uint8_t)(mem.have_format ? (int)mem.pdrf : pick_pdrf(is));
    if (las->pdrf > 5 && las->version_minor < 4)
        las->version_minor = 4;
    snprintf(las->system_id, sizeof las->system_id, "wpd convert");
    snprintf(las->software, sizeof las->software, "wpd");
    plan_las_frame(in, bounds, &mem, las);

    /* Standard dimensions first, from the PDRF alone, to learn their names. */
    uint16_t std_size = wpd_las_pdrf_size(las->pdrf);
    las->record_length = std_size;
    if (wpd_las_schema_from_info(out, err))
        return -1;
    int used[WPD_MAX_DIMS] = {0}, extra[WPD_MAX_DIMS], nextra = 0;
    used[is->dim_x] = used[is->dim_y] = 1;
    if (is->dim_z >= 0)
        used[is->dim_z] = 1;
    for (uint32_t j = 0; j < out->schema.ndims; j++) {
        int src = is_coordinate(&out->schema, (int)j)
                      ? -1
                      : find_ply_source(is, out->schema.dims[j].name, used);
        if (src >= 0)
            used[src] = 1;
    }
    uint32_t extra_size = 0;
    for (uint32_t i = 0; i < is->ndims; i++)
        if (!used[i]) {
            extra[nextra++] = (int)i;
            extra_size += (uint32_t)wpd_type_size(is->dims[i].type);
        }
    if (std_size + extra_size > 65535)
        return wpd_fail(err, WPD_E_INPUT, "%s: too many properties for a LAS record", in->path);
    las->record_length = (uint16_t)(std_size + extra_size);
    las->extra_bytes = (uint16_t)extra_size;
    if (nextra && add_extra_bytes_vlr(las, is, extra, nextra))
        return wpd_fail(err, WPD_E_MEMORY, "out of memory");
    memset(&out->schema, 0, sizeof out->schema);
    if (wpd_las_schema_from_info(out, err))
        return -1;

    /* Map every output dimension from the input property it came from. */
    int taken[WPD_MAX_DIMS] = {0};
    for (uint32_t j = 0; j < out->schema.ndims; j++) {
        const char *name = out->schema.dims[j].name;
        int src;
        if (is_coordinate(&out->schema, (int)j) ||
            (src = find_ply_source(is, name, taken)) < 0)
            continue;
        taken[src] = 1;
        map_add(m, is, src, &out->schema, (int)j,
                colour_multiplier(name, is->dims[src].type));
    }
    return 0;
}

/* ------------------------------------------------------------------ widening */

int wpd_layout_widen_coordinates(const wpd_header *in, wpd_header *out, wpd_layout_map *map,
                                 wpd_error *err)
{
    if (out->format != WPD_FMT_PLY)
        return wpd_fail(err, WPD_E_USAGE, "%s: only PLY coordinates can be widened", out->path);
    const wpd_schema *src = &out->schema;
    wpd_schema wide;
    memset(&wide, 0, sizeof wide);
    wide.dim_x = src->dim_x, wide.dim_y = src->dim_y, wide.dim_z = src->dim_z;
    wpd_layout_map m;
    memset(&m, 0, sizeof m);
    uint32_t off = 0;
    for (uint32_t i = 0; i < src->ndims; i++) {
        int coord = is_coordinate(src, (int)i);
        wpd_type t = coord ? WPD_F64 : src->dims[i].type;
        int d = wpd_schema_add(&wide, src->dims[i].name, t, off);
        off += (uint32_t)wpd_type_size(t);
        if (coord)
            continue;
        /* The source of each property: the input's field of that name. */
        int from = map->identity ? (int)i : -1;
        double mul = 1.0;
        for (uint32_t f = 0; !map->identity && f < map->nfields; f++)
            if (map->fields[f].dst == (int)i) {
                from = map->fields[f].src;
                mul = map->fields[f].mul;
            }
        if (from >= 0)
            map_add(&m, &in->schema, from, &wide, d, mul);
    }
    wide.record_size = off;
    out->schema = wide;
    *map = m;
    return 0;
}

/* ------------------------------------------------------------------ entry points */

wpd_format wpd_format_from_name(const char *path)
{
    const char *dot = strrchr(path, '.');
    if (dot && (!strcasecmp(dot, ".las") || !strcasecmp(dot, ".laz")))
        return WPD_FMT_LAS;
    if (dot && !strcasecmp(dot, ".ply"))
        return WPD_FMT_PLY;
    return WPD_FMT_NONE;
}

int wpd_format_is_laz_name(const char *path)
{
    const char *dot = strrchr(path, '.');
    return dot && !strcasecmp(dot, ".laz");
}

int wpd_layout_plan(const wpd_header *in, const wpd_bounds *bounds, wpd_format fmt,
                    wpd_header *out, wpd_layout_map *map, wpd_error *err)
{
    memset(map, 0, sizeof *map);
    memset(out, 0, sizeof *out);
    if (in->format == fmt) {
        if (wpd_header_copy(out, in))
            return wpd_fail(err, WPD_E_MEMORY, "out of memory");
        map->identity = 1;
        return 0;
    }
    out->format = fmt;
    snprintf(out->path, sizeof out->path, "%s", in->path);
    int rc = fmt == WPD_FMT_PLY ? plan_las_to_ply(in, out, map, err)
                                : plan_ply_to_las(in, bounds, out, map, err);
    if (rc)
        wpd_header_free(out);
    return rc;
}

void wpd_layout_apply(const wpd_layout_map *map, const wpd_schema *in,
                      const wpd_schema *out, const wpd_batch *src, wpd_batch *dst)
{
    dst->n = src->n;
    memcpy(dst->xyz, src->xyz, src->n * 3 * sizeof *src->xyz);
    if (map->identity && dst->record_size == src->record_size) {
        memcpy(dst->records, src->records, src->n * (size_t)src->record_size);
        return;
    }
    if (map->identity) { /* a longer output record: fields were appended */
        size_t in_size = src->record_size, out_size = dst->record_size;
        for (size_t i = 0; i < src->n; i++) {
            memcpy(dst->records + i * out_size, src->records + i * in_size, in_size);
            memset(dst->records + i * out_size + in_size, 0, out_size - in_size);
        }
        return;
    }
    memset(dst->records, 0, src->n * (size_t)dst->record_size);
    for (size_t i = 0; i < src->n; i++) {
        const uint8_t *r = src->records + i * src->record_size;
        uint8_t *w = dst->records + i * dst->record_size;
        for (uint32_t f = 0; f < map->nfields; f++) {
            const wpd_field_map *fm = &map->fields[f];
            if (fm->raw_bytes) {
                memcpy(w + out->dims[fm->dst].offset, r + in->dims[fm->src].offset,
                       fm->raw_bytes);
                continue;
            }
            double v = wpd_dim_get(&in->dims[fm->src], r) * fm->mul;
            wpd_dim_set(&out->dims[fm->dst], w, v);
        }
    }
}

/* ------------------------------------------------------------------ labels */

int wpd_layout_add_label(wpd_header *out, const char *name, const char *description,
                         int *replaced, wpd_error *err)
{
    wpd_schema *s = &out->schema;
    int d = wpd_schema_find(s, name);
    *replaced = d >= 0;
    if (d >= 0)
        return d;
    if (out->format == WPD_FMT_LAS) {
        if (wpd_las_append_extra(out, name, WPD_U8, description, err))
            return -1;
    } else if (s->record_size < UINT32_MAX && wpd_schema_add(s, name, WPD_U8, s->record_size) >= 0) {
        s->record_size++;
    }
    d = wpd_schema_find(s, name);
    if (d < 0)
        return wpd_fail(err, WPD_E_INPUT, "%s: no room for the field %s (%u dimensions)",
                        out->path, name, s->ndims);
    return d;
}

void wpd_layout_set_labels(const wpd_dim *d, wpd_batch *b, const uint8_t *value)
{
    if (!d->bit_count && !d->scaled && d->type == WPD_U8) {
        for (size_t i = 0; i < b->n; i++)
            b->records[i * b->record_size + d->offset] = value[i];
        return;
    }
    for (size_t i = 0; i < b->n; i++)
        wpd_dim_set(d, b->records + i * b->record_size, value[i]);
}
