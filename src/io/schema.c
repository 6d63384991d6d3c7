#include "io/schema.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static const struct {
    const char *name;
    const char *alias;
    size_t size;
} type_table[] = {
    [WPD_I8] = {"char", "int8", 1},       [WPD_U8] = {"uchar", "uint8", 1},
    [WPD_I16] = {"short", "int16", 2},    [WPD_U16] = {"ushort", "uint16", 2},
    [WPD_I32] = {"int", "int32", 4},      [WPD_U32] = {"uint", "uint32", 4},
    [WPD_I64] = {"int64", "long", 8},     [WPD_U64] = {"uint64", "ulong", 8},
    [WPD_F32] = {"float", "float32", 4},  [WPD_F64] = {"double", "float64", 8},
};

size_t wpd_type_size(wpd_type t) { return type_table[t].size; }

const char *wpd_type_name(wpd_type t) { return type_table[t].name; }

int wpd_type_parse(const char *name, wpd_type *t)
{
    for (int i = 0; i <= WPD_F64; i++) {
        if (!strcmp(name, type_table[i].name) || !strcmp(name, type_table[i].alias)) {
            *t = (wpd_type)i;
            return 0;
        }
    }
    return -1;
}

int wpd_schema_add(wpd_schema *s, const char *name, wpd_type type, uint32_t offset)
{
    if (s->ndims >= WPD_MAX_DIMS || strlen(name) >= WPD_DIM_NAME_MAX)
        return -1;
    wpd_dim *d = &s->dims[s->ndims];
    memset(d, 0, sizeof *d);
    strcpy(d->name, name);
    d->type = type;
    d->offset = offset;
    d->scale = 1.0;
    return (int)s->ndims++;
}

int wpd_schema_find(const wpd_schema *s, const char *name)
{
    for (uint32_t i = 0; i < s->ndims; i++)
        if (!strcmp(s->dims[i].name, name))
            return (int)i;
    return -1;
}

double wpd_dim_get(const wpd_dim *d, const uint8_t *record)
{
    const uint8_t *p = record + d->offset;
    double v;
    if (d->bit_count) {
        uint64_t raw = (uint64_t)wpd_value_get_int(d->type, p);
        v = (double)((raw >> d->bit_shift) & ((1ull << d->bit_count) - 1));
    } else {
        v = wpd_value_get(d->type, p);
    }
    return d->scaled ? v * d->scale + d->add : v;
}

static const double type_min[] = {
    [WPD_I8] = -128.0, [WPD_U8] = 0, [WPD_I16] = -32768.0, [WPD_U16] = 0,
    [WPD_I32] = -2147483648.0, [WPD_U32] = 0, [WPD_I64] = -9223372036854775808.0,
    [WPD_U64] = 0,
};
static const double type_max[] = {
    [WPD_I8] = 127.0, [WPD_U8] = 255.0, [WPD_I16] = 32767.0, [WPD_U16] = 65535.0,
    [WPD_I32] = 2147483647.0, [WPD_U32] = 4294967295.0,
    [WPD_I64] = 9223372036854774784.0, [WPD_U64] = 18446744073709549568.0,
};

static void field_set_int(wpd_type t, uint8_t *p, int64_t v)
{
    switch (t) {
    case WPD_I8: case WPD_U8: { uint8_t x = (uint8_t)v; memcpy(p, &x, 1); break; }
    case WPD_I16: case WPD_U16: { uint16_t x = (uint16_t)v; memcpy(p, &x, 2); break; }
    case WPD_I32: case WPD_U32: { uint32_t x = (uint32_t)v; memcpy(p, &x, 4); break; }
    default: { uint64_t x = (uint64_t)v; memcpy(p, &x, 8); break; }
    }
}

void wpd_dim_set(const wpd_dim *d, uint8_t *record, double v)
{
    uint8_t *p = record + d->offset;
    if (d->scaled)
        v = (v - d->add) / d->scale;
    if (d->type == WPD_F32) { float x = (float)v; memcpy(p, &x, 4); return; }
    if (d->type == WPD_F64) { memcpy(p, &v, 8); return; }
    v = isnan(v) ? 0 : nearbyint(v);
    if (v < type_min[d->type]) v = type_min[d->type];
    if (v > type_max[d->type]) v = type_max[d->type];
    if (d->type == WPD_U64) {
        uint64_t x = (uint64_t)v;
        memcpy(p, &x, 8);
        return;
    }
    int64_t iv = (int64_t)v;
    if (d->bit_count) {
        uint64_t mask = ((1ull << d->bit_count) - 1);
        uint64_t raw = (uint64_t)wpd_value_get_int(d->type, p);
        uint64_t bits = (uint64_t)iv > mask ? mask : (uint64_t)iv;
        raw = (raw & ~(mask << d->bit_shift)) | (bits << d->bit_shift);
        iv = (int64_t)raw;
    }
    field_set_int(d->type, p, iv);
}

static void free_vlrs(wpd_vlr *v, uint32_t n)
{
    for (uint32_t i = 0; v && i < n; i++)
        free(v[i].data);
    free(v);
}

static void free_strings(char **s, uint32_t n)
{
    for (uint32_t i = 0; s && i < n; i++)
        free(s[i]);
    free(s);
}

void wpd_header_free(wpd_header *h)
{
    free_vlrs(h->las.vlrs, h->las.nvlr);
    free_vlrs(h->las.evlrs, h->las.nevlr);
    free(h->las.header_tail);
    free(h->las.vlr_tail);
    free_strings(h->ply.comments, h->ply.ncomments);
    free_strings(h->ply.obj_info, h->ply.nobj_info);
    free(h->ply.elements);
    memset(h, 0, sizeof *h);
}

static int copy_vlrs(wpd_vlr **dst, const wpd_vlr *src, uint32_t n)
{
    *dst = NULL;
    if (!n)
        return 0;
    *dst = calloc(n, sizeof **dst);
    if (!*dst)
        return -1;
    for (uint32_t i = 0; i < n; i++) {
        (*dst)[i] = src[i];
        (*dst)[i].data = NULL;
        if (src[i].length) {
            (*dst)[i].data = malloc(src[i].length);
            if (!(*dst)[i].data)
                return -1;
            memcpy((*dst)[i].data, src[i].data, src[i].length);
        }
    }
    return 0;
}

static int copy_strings(char ***dst, char *const *src, uint32_t n)
{
    *dst = NULL;
    if (!n)
        return 0;
    *dst = calloc(n, sizeof **dst);
    if (!*dst)
        return -1;
    for (uint32_t i = 0; i < n; i++)
        if (!((*dst)[i] = strdup(src[i])))
            return -1;
    return 0;
}

static void *copy_bytes(const void *src, size_t len)
{
    void *p = len ? malloc(len) : NULL;
    if (p)
        memcpy(p, src, len);
    return p;
}

int wpd_header_copy(wpd_header *dst, const wpd_header *src)
{
    *dst = *src;
    /* Null every owned pointer first so a partial failure frees cleanly. */
    dst->las.vlrs = dst->las.evlrs = NULL;
    dst->las.header_tail = dst->las.vlr_tail = NULL;
    dst->ply.comments = dst->ply.obj_info = NULL;
    dst->ply.elements = NULL;
    int bad = copy_vlrs(&dst->las.vlrs, src->las.vlrs, src->las.nvlr) ||
              copy_vlrs(&dst->las.evlrs, src->las.evlrs, src->las.nevlr) ||
              copy_strings(&dst->ply.comments, src->ply.comments, src->ply.ncomments) ||
              copy_strings(&dst->ply.obj_info, src->ply.obj_info, src->ply.nobj_info);
    if (!bad && src->las.header_tail_len &&
        !(dst->las.header_tail = copy_bytes(src->las.header_tail, src->las.header_tail_len)))
        bad = 1;
    if (!bad && src->las.vlr_tail_len &&
        !(dst->las.vlr_tail = copy_bytes(src->las.vlr_tail, src->las.vlr_tail_len)))
        bad = 1;
    if (!bad && src->ply.nelements &&
        !(dst->ply.elements = copy_bytes(src->ply.elements,
                                         src->ply.nelements * sizeof *src->ply.elements)))
        bad = 1;
    if (bad) {
        wpd_header_free(dst);
        return -1;
    }
    return 0;
}
