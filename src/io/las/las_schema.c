/* las_schema.c - the record schema of a LAS point data record format: the
 * PDRF's standard dimensions (named like laspy and PDAL, bit fields as
 * dimensions of their own), then the extra bytes, named and typed from the
 * Extra Bytes VLR (LASF_Spec/4) or, without a usable one, as unnamed bytes.
 */
#include "io/las/las_internal.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

typedef struct std_dim {
    const char *name;
    wpd_type type;
    uint8_t offset, bit_shift, bit_count;
} std_dim;

/* PDRF 0-5: the 20-byte core. */
static const std_dim legacy_core[] = {
    {"intensity", WPD_U16, 12, 0, 0},
    {"return_number", WPD_U8, 14, 0, 3},
    {"number_of_returns", WPD_U8, 14, 3, 3},
    {"scan_direction_flag", WPD_U8, 14, 6, 1},
    {"edge_of_flight_line", WPD_U8, 14, 7, 1},
    {"classification", WPD_U8, 15, 0, 5},
    {"synthetic", WPD_U8, 15, 5, 1},
    {"key_point", WPD_U8, 15, 6, 1},
    {"withheld", WPD_U8, 15, 7, 1},
    {"scan_angle_rank", WPD_I8, 16, 0, 0},
    {"user_data", WPD_U8, 17, 0, 0},
    {"point_source_id", WPD_U16, 18, 0, 0},
};

/* PDRF 6-10: the 30-byte core (gps_time included). */
static const std_dim extended_core[] = {
    {"intensity", WPD_U16, 12, 0, 0},
    {"return_number", WPD_U8, 14, 0, 4},
    {"number_of_returns", WPD_U8, 14, 4, 4},
    {"scan_direction_flag", WPD_U8, 15, 6, 1},
    {"edge_of_flight_line", WPD_U8, 15, 7, 1},
    {"classification", WPD_U8, 16, 0, 0},
    {"synthetic", WPD_U8, 15, 0, 1},
    {"key_point", WPD_U8, 15, 1, 1},
    {"withheld", WPD_U8, 15, 2, 1},
    {"overlap", WPD_U8, 15, 3, 1},
    {"scanner_channel", WPD_U8, 15, 4, 2},
    {"scan_angle", WPD_I16, 18, 0, 0},
    {"user_data", WPD_U8, 17, 0, 0},
    {"point_source_id", WPD_U16, 20, 0, 0},
    {"gps_time", WPD_F64, 22, 0, 0},
};

/* Optional blocks, placed at a per-PDRF offset (offsets relative). */
static const std_dim gps_block[] = {{"gps_time", WPD_F64, 0, 0, 0}};
static const std_dim rgb_block[] = {
    {"red", WPD_U16, 0, 0, 0}, {"green", WPD_U16, 2, 0, 0}, {"blue", WPD_U16, 4, 0, 0}};
static const std_dim nir_block[] = {{"nir", WPD_U16, 0, 0, 0}};
static const std_dim wave_block[] = {
    {"wavepacket_index", WPD_U8, 0, 0, 0},
    {"wavepacket_offset", WPD_U64, 1, 0, 0},
    {"wavepacket_size", WPD_U32, 9, 0, 0},
    {"return_point_wave_location", WPD_F32, 13, 0, 0},
    {"x_t", WPD_F32, 17, 0, 0},
    {"y_t", WPD_F32, 21, 0, 0},
    {"z_t", WPD_F32, 25, 0, 0},
};

/* Byte offsets of the optional blocks per PDRF; 0 = absent. */
static const uint8_t gps_at[LAS_MAX_PDRF + 1] = {0, 20, 0, 20, 20, 20, 0, 0, 0, 0, 0};
static const uint8_t rgb_at[LAS_MAX_PDRF + 1] = {0, 0, 20, 28, 0, 28, 0, 30, 30, 0, 30};
static const uint8_t nir_at[LAS_MAX_PDRF + 1] = {0, 0, 0, 0, 0, 0, 0, 0, 36, 0, 36};
static const uint8_t wave_at[LAS_MAX_PDRF + 1] = {0, 0, 0, 0, 28, 34, 0, 0, 0, 30, 38};

static void add_block(wpd_schema *s, const std_dim *d, size_t n, uint32_t base)
{
    for (size_t i = 0; i < n; i++) {
        int k = wpd_schema_add(s, d[i].name, d[i].type, base + d[i].offset);
        if (k >= 0) {
            s->dims[k].bit_shift = d[i].bit_shift;
            s->dims[k].bit_count = d[i].bit_count;
        }
    }
}

#define ADD_BLOCK(s, block, base) add_block(s, block, sizeof block / sizeof block[0], base)

/* Makes name usable as a dimension name in every output format (no spaces
 * or control characters, not empty, unique in s) and writes it to out. */
static void unique_dim_name(const wpd_schema *s, const char *name, uint32_t pos,
                            char out[WPD_DIM_NAME_MAX])
{
    char base[WPD_DIM_NAME_MAX - 8];
    size_t n = 0;
    for (const char *p = name; *p && n + 1 < sizeof base; p++)
        base[n++] = (*p > ' ' && *p < 0x7f) ? *p : '_';
    base[n] = '\0';
    if (!n)
        snprintf(base, sizeof base, "extra_%u", pos);
    snprintf(out, WPD_DIM_NAME_MAX, "%s", base);
    /* At most WPD_MAX_DIMS names can clash, so k stays small. */
    for (unsigned k = 2; wpd_schema_find(s, out) >= 0; k++)
        snprintf(out, WPD_DIM_NAME_MAX, "%.39s_%u", base, k % 10000u);
}

static const wpd_type extra_type[10] = {WPD_U8,  WPD_I8,  WPD_U16, WPD_I16, WPD_U32,
                                        WPD_I32, WPD_U64, WPD_I64, WPD_F32, WPD_F64};

/* Adds the dimensions of Extra Bytes descriptor number index (0-based, at d)
 * at record offset pos; end = record length. Sets *used to the bytes it
 * covers. Data types 1-10 are scalars, 11-30 the deprecated 2- and
 * 3-element arrays (dims "name[0]" ...), 0 undocumented bytes (options =
 * their number; no dimension). Options bits 3/4: scale/offset valid. */
static int add_extra_descriptor(wpd_header *h, const uint8_t *d, uint64_t index, uint32_t pos,
                                uint32_t end, uint32_t *used, wpd_error *err)
{
    wpd_schema *s = &h->schema;
    uint8_t data_type = d[2], options = d[3];
    char name[33];
    las_copy_text(name, d + 4, 32);
    if (data_type > 30)
        return wpd_fail(err, WPD_E_INPUT,
                        "%s: Extra Bytes descriptor %llu (\"%s\") has unknown data_type %u",
                        h->path, (unsigned long long)index + 1, name, data_type);
    wpd_type t = data_type ? extra_type[(data_type - 1) % 10] : WPD_U8;
    uint32_t elems = data_type ? (data_type - 1u) / 10u + 1u : 0;
    uint32_t size = data_type ? elems * (uint32_t)wpd_type_size(t) : options;
    if (size > end - pos)
        return wpd_fail(err, WPD_E_INPUT,
                        "%s: Extra Bytes descriptor %llu (\"%s\", %u bytes at record byte %u) "
                        "runs past the %u-byte point record",
                        h->path, (unsigned long long)index + 1, name, size, pos, end);
    *used = size;
    for (uint32_t e = 0; e < elems; e++) {
        char elem_name[WPD_DIM_NAME_MAX + 8], dim_name[WPD_DIM_NAME_MAX];
        if (elems > 1)
            snprintf(elem_name, sizeof elem_name, "%s[%u]", name, e);
        else
            snprintf(elem_name, sizeof elem_name, "%s", name);
        unique_dim_name(s, elem_name, pos, dim_name);
        int k = wpd_schema_add(s, dim_name, t, pos + e * (uint32_t)wpd_type_size(t));
        if (k < 0) /* schema full: the bytes stay in the record, unnamed */
            return 0;
        double scale = las_get_f64(d + 112 + 8 * e), add = las_get_f64(d + 136 + 8 * e);
        if (options & 0x18) {
            wpd_dim *dim = &s->dims[k];
            dim->scaled = 1;
            dim->scale = (options & 0x08) && isfinite(scale) && scale != 0 ? scale : 1.0;
            dim->add = (options & 0x10) && isfinite(add) ? add : 0.0;
        }
    }
    return 0;
}

/* Returns the Extra Bytes VLR, or NULL. */
static const wpd_vlr *find_extra_bytes_vlr(const wpd_las_info *las)
{
    for (uint32_t i = 0; i < las->nvlr; i++)
        if (!strcmp(las->vlrs[i].user_id, "LASF_Spec") && las->vlrs[i].record_id == 4)
            return &las->vlrs[i];
    return NULL;
}

/* Adds the dimensions the Extra Bytes VLR describes, from record byte start
 * on; returns the first byte no descriptor covers. A VLR that cannot
 * describe these records (an unknown data type, descriptors that run past
 * the record: PDAL refuses such files, see docs/formats.md) only names
 * bytes, and every byte is still read and written: it is ignored with a
 * warning and the bytes stay undescribed. */
static uint32_t add_described_extra_dims(wpd_header *h, const wpd_vlr *ebv, uint32_t start,
                                         uint32_t end)
{
    uint64_t ndesc = ebv->length / LAS_EXTRA_BYTES_DESCRIPTOR_SIZE;
    uint64_t rest = ebv->length % LAS_EXTRA_BYTES_DESCRIPTOR_SIZE;
    if (rest)
        wpd_warn(&h->warnings,
                 "%s: Extra Bytes VLR length %llu is not a multiple of %d; its last %llu "
                 "bytes are ignored",
                 h->path, (unsigned long long)ebv->length, LAS_EXTRA_BYTES_DESCRIPTOR_SIZE,
                 (unsigned long long)rest);
    uint32_t first = h->schema.ndims, pos = start;
    for (uint64_t i = 0; i < ndesc; i++) {
        uint32_t used = 0;
        wpd_error why;
        if (add_extra_descriptor(h, ebv->data + i * LAS_EXTRA_BYTES_DESCRIPTOR_SIZE, i, pos,
                                 end, &used, &why)) {
            wpd_warn(&h->warnings,
                     "%s; the Extra Bytes VLR is ignored and the extra bytes are read "
                     "unnamed (extra_byte_N)",
                     why.msg);
            memset(h->schema.dims + first, 0, (h->schema.ndims - first) * sizeof *h->schema.dims);
            h->schema.ndims = first;
            return start;
        }
        pos += used;
    }
    return pos;
}

/* Dimensions of the record bytes from start to end (the extra bytes): the
 * described ones, then one u8 per undescribed byte ("extra_byte_<k>", k
 * counted from the first extra byte). */
static void add_extra_dims(wpd_header *h, uint32_t start, uint32_t end)
{
    const wpd_vlr *ebv = find_extra_bytes_vlr(&h->las);
    uint32_t first_described = h->schema.ndims;
    uint32_t pos = ebv ? add_described_extra_dims(h, ebv, start, end) : start;
    /* The generated names can clash only with a descriptor's name of the
     * same form (found by fuzzing); only then is each one checked. */
    int clash = 0;
    for (uint32_t i = first_described; i < h->schema.ndims; i++)
        clash |= !strncmp(h->schema.dims[i].name, "extra_byte_", 11);
    for (; pos < end; pos++) {
        char name[WPD_DIM_NAME_MAX], unique[WPD_DIM_NAME_MAX];
        snprintf(name, sizeof name, "extra_byte_%u", pos - start);
        if (clash)
            unique_dim_name(&h->schema, name, pos, unique);
        if (wpd_schema_add(&h->schema, clash ? unique : name, WPD_U8, pos) < 0)
            break; /* schema full: the bytes stay in the record, unnamed */
    }
}

uint16_t wpd_las_pdrf_size(int pdrf)
{
    return pdrf >= 0 && pdrf <= LAS_MAX_PDRF ? las_pdrf_size[pdrf] : 0;
}

int wpd_las_schema_from_info(wpd_header *h, wpd_error *err)
{
    const wpd_las_info *las = &h->las;
    wpd_schema *s = &h->schema;
    uint8_t pdrf = las->pdrf;
    if (pdrf > LAS_MAX_PDRF)
        return wpd_fail(err, WPD_E_INPUT,
                        "%s: unsupported point data record format %u (0 to %d are defined)",
                        h->path, pdrf, LAS_MAX_PDRF);
    if (las->record_length < las_pdrf_size[pdrf])
        return wpd_fail(err, WPD_E_INPUT,
                        "%s: point record_length %u is smaller than the %u bytes of "
                        "point data record format %u",
                        h->path, las->record_length, las_pdrf_size[pdrf], pdrf);
    memset(s, 0, sizeof *s);
    s->record_size = las->record_length;
    static const char *const xyz[3] = {"x", "y", "z"};
    for (int i = 0; i < 3; i++) {
        int k = wpd_schema_add(s, xyz[i], WPD_I32, 4u * (unsigned)i);
        s->dims[k].scaled = 1;
        s->dims[k].scale = las->scale[i];
        s->dims[k].add = las->offset[i];
    }
    s->dim_x = 0, s->dim_y = 1, s->dim_z = 2;
    if (pdrf >= 6)
        ADD_BLOCK(s, extended_core, 0);
    else
        ADD_BLOCK(s, legacy_core, 0);
    if (gps_at[pdrf])
        ADD_BLOCK(s, gps_block, gps_at[pdrf]);
    if (rgb_at[pdrf])
        ADD_BLOCK(s, rgb_block, rgb_at[pdrf]);
    if (nir_at[pdrf])
        ADD_BLOCK(s, nir_block, nir_at[pdrf]);
    if (wave_at[pdrf])
        ADD_BLOCK(s, wave_block, wave_at[pdrf]);
    add_extra_dims(h, las_pdrf_size[pdrf], las->record_length);
    return 0;
}

/* The coordinates of LAS records, shared by the LAS reader and the LAZ
 * decoder (las_internal.h). */
size_t las_decode_xyz(const double scale[3], const double offset[3], uint32_t len,
                      uint8_t *rec, size_t n, double *xyz)
{
    const double sx = scale[0], sy = scale[1], sz = scale[2];
    const double ox = offset[0], oy = offset[1], oz = offset[2];
    int bad = 0;
    for (size_t i = 0; i < n; i++) {
        const uint8_t *p = rec + i * len;
        int32_t X, Y, Z;
        memcpy(&X, p, 4);
        memcpy(&Y, p + 4, 4);
        memcpy(&Z, p + 8, 4);
        double x = X * sx + ox, y = Y * sy + oy, z = Z * sz + oz;
        xyz[3 * i] = x;
        xyz[3 * i + 1] = y;
        xyz[3 * i + 2] = z;
        bad |= !isfinite(x + y + z);
    }
    if (!bad)
        return n;
    size_t kept = 0;
    for (size_t i = 0; i < n; i++) {
        const double *v = xyz + 3 * i;
        if (!isfinite(v[0]) || !isfinite(v[1]) || !isfinite(v[2]))
            continue;
        if (kept != i) {
            memmove(rec + kept * len, rec + i * len, len);
            memmove(xyz + 3 * kept, v, 3 * sizeof *v);
        }
        kept++;
    }
    return kept;
}
