/* las_read.c - LAS 1.0-1.4 reader (PDRF 0-10, VLRs, EVLRs, extra bytes).
 *
 * Nothing in the header is trusted: every size, count and offset is checked
 * against the file size before anything is allocated or looped over. Points
 * are fixed-size records, so the reader streams them with pread(2) straight
 * into the batch and can start at any record index. LAZ and COPC (compressed
 * LAS) are refused with a message that says how to decompress them.
 */
#include "io/format.h"
#include "io/las_internal.h"
#include "common/fullio.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* Reader state: where the records are and how to decode x, y, z. */
typedef struct las_reader {
    uint64_t data_start;    /* byte offset of record 0 */
    uint64_t next;          /* index of the next record to read */
    uint32_t record_length;
    double scale[3], offset[3];
} las_reader;

/* Points are read and decoded in blocks of about this many bytes, so that a
 * block is still in the CPU cache when the decode loop walks over it. */
#define READ_BLOCK_BYTES (512u * 1024u)

/* ---- file access ---- */

/* Reads exactly len bytes at off. A short read means the file is shorter
 * than its header promises (or shrank since it was opened). */
static int read_at(wpd_reader *r, void *buf, size_t len, uint64_t off, const char *what,
                   wpd_error *err)
{
    ssize_t n = wpd_pread_full(r->fd, buf, len, off);
    if (n < 0)
        return wpd_fail_errno(err, "%s: cannot read %s at byte %llu", r->hdr.path, what,
                              (unsigned long long)off);
    if ((size_t)n < len)
        return wpd_fail(err, WPD_E_INPUT, "%s: file ends at byte %llu inside the %s",
                        r->hdr.path, (unsigned long long)(off + (uint64_t)n), what);
    return 0;
}

/* Copies a fixed-width, possibly unterminated text field into a C string. */
static void copy_text(char *dst, const uint8_t *src, size_t width)
{
    memcpy(dst, src, width);
    dst[width] = '\0';
}

/* ---- header ---- */

/* Fills the fixed header fields of las from the header bytes h (at least the
 * version's standard size). Validates nothing beyond what parsing needs. */
static void parse_header_fields(wpd_las_info *las, const uint8_t *h)
{
    las->file_source_id = las_get_u16(h + LAS_OFF_SOURCE_ID);
    las->global_encoding = las_get_u16(h + LAS_OFF_GLOBAL_ENCODING);
    memcpy(las->guid, h + LAS_OFF_GUID, 16);
    las->version_major = h[LAS_OFF_VERSION_MAJOR];
    las->version_minor = h[LAS_OFF_VERSION_MINOR];
    copy_text(las->system_id, h + LAS_OFF_SYSTEM_ID, 32);
    copy_text(las->software, h + LAS_OFF_SOFTWARE, 32);
    las->creation_day = las_get_u16(h + LAS_OFF_DAY);
    las->creation_year = las_get_u16(h + LAS_OFF_YEAR);
    las->header_size = las_get_u16(h + LAS_OFF_HEADER_SIZE);
    las->offset_to_points = las_get_u32(h + LAS_OFF_POINT_OFFSET);
    las->nvlr = las_get_u32(h + LAS_OFF_NVLR);
    las->pdrf = h[LAS_OFF_PDRF];
    las->record_length = las_get_u16(h + LAS_OFF_RECORD_LENGTH);
    for (int i = 0; i < 3; i++) {
        las->scale[i] = las_get_f64(h + LAS_OFF_SCALE + 8 * i);
        las->offset[i] = las_get_f64(h + LAS_OFF_OFFSET + 8 * i);
        las->max[i] = las_get_f64(h + LAS_OFF_BOUNDS + 16 * i);
        las->min[i] = las_get_f64(h + LAS_OFF_BOUNDS + 16 * i + 8);
    }
    las->point_count = las_get_u32(h + LAS_OFF_LEGACY_COUNT);
    for (int i = 0; i < 5; i++)
        las->points_by_return[i] = las_get_u32(h + LAS_OFF_LEGACY_BY_RETURN + 4 * i);
    if (las->version_minor >= 3)
        las->waveform_start = las_get_u64(h + LAS_OFF_WAVEFORM_START);
    if (las->version_minor >= 4) {
        las->nevlr = las_get_u32(h + LAS_OFF_NEVLR);
        /* The 64-bit counts are authoritative in 1.4 (the legacy ones are 0
         * for PDRF 6-10 or more than 2^32 points). A 64-bit count of 0 next
         * to a non-zero legacy count is a known writer bug: keep the legacy. */
        uint64_t count = las_get_u64(h + LAS_OFF_COUNT);
        if (count || !las->point_count) {
            las->point_count = count;
            for (int i = 0; i < 15; i++)
                las->points_by_return[i] = las_get_u64(h + LAS_OFF_BY_RETURN + 8 * i);
        }
    }
}

/* Start of the first EVLR as stored in a 1.4 header (0 otherwise). */
static uint64_t evlr_start_field(const wpd_las_info *las, const uint8_t *h)
{
    return las->version_minor >= 4 ? las_get_u64(h + LAS_OFF_EVLR_START) : 0;
}

/* 1 if the first VLR (where the COPC spec puts it) has user id "copc". */
static int first_vlr_is_copc(wpd_reader *r)
{
    const wpd_las_info *las = &r->hdr.las;
    uint8_t vh[LAS_VLR_HEADER_SIZE];
    if (!las->nvlr || (uint64_t)las->header_size + sizeof vh > r->hdr.file_size)
        return 0;
    if (read_at(r, vh, sizeof vh, las->header_size, "VLR", NULL))
        return 0;
    return !memcmp(vh + 2, "copc\0", 5);
}

static int fail_compressed(wpd_reader *r, int copc, wpd_error *err)
{
    if (copc)
        return wpd_fail(err, WPD_E_INPUT,
                        "%s: COPC (cloud-optimized compressed LAS) is not supported; "
                        "decompress it first (e.g. with laszip or pdal translate)",
                        r->hdr.path);
    return wpd_fail(err, WPD_E_INPUT,
                    "%s: compressed LAS (LAZ) is not supported; decompress it first "
                    "(e.g. with laszip or pdal translate)",
                    r->hdr.path);
}

/* Checks version, header size, point offset, PDRF, record length, scale and
 * offset (which must give finite coordinates for every int32 value). */
static int check_header_fields(wpd_reader *r, wpd_error *err)
{
    const wpd_las_info *las = &r->hdr.las;
    const char *path = r->hdr.path;
    uint16_t standard = las_standard_header_size(las->version_minor);
    if (las->header_size < standard)
        return wpd_fail(err, WPD_E_INPUT,
                        "%s: header_size %u is smaller than the %u bytes of a LAS %u.%u header",
                        path, las->header_size, standard, las->version_major,
                        las->version_minor);
    if (las->header_size > r->hdr.file_size)
        return wpd_fail(err, WPD_E_INPUT,
                        "%s: header_size %u is larger than the file (%llu bytes)", path,
                        las->header_size, (unsigned long long)r->hdr.file_size);
    if (las->offset_to_points < las->header_size)
        return wpd_fail(err, WPD_E_INPUT,
                        "%s: offset_to_point_data %u lies inside the %u-byte header", path,
                        las->offset_to_points, las->header_size);
    if (las->offset_to_points > r->hdr.file_size)
        return wpd_fail(err, WPD_E_INPUT,
                        "%s: offset_to_point_data %u is past the end of the file (%llu bytes)",
                        path, las->offset_to_points, (unsigned long long)r->hdr.file_size);
    if (las->pdrf > LAS_MAX_PDRF)
        return wpd_fail(err, WPD_E_INPUT,
                        "%s: unsupported point data record format %u (0 to %d are defined)",
                        path, las->pdrf, LAS_MAX_PDRF);
    if (las->record_length < las_pdrf_size[las->pdrf])
        return wpd_fail(err, WPD_E_INPUT,
                        "%s: point record_length %u is smaller than the %u bytes of "
                        "point data record format %u",
                        path, las->record_length, las_pdrf_size[las->pdrf], las->pdrf);
    static const char axis[3] = {'x', 'y', 'z'};
    for (int i = 0; i < 3; i++) {
        double extreme = fabs(las->scale[i]) * 2147483648.0 + fabs(las->offset[i]);
        if (las->scale[i] == 0 || !isfinite(extreme))
            return wpd_fail(err, WPD_E_INPUT,
                            "%s: %c scale factor %g / offset %g cannot give usable coordinates",
                            path, axis[i], las->scale[i], las->offset[i]);
    }
    return 0;
}

/* Reads and validates the fixed header, the header tail and the compression
 * markers. Sets *evlr_start to the 1.4 EVLR start field. */
static int read_header(wpd_reader *r, uint64_t *evlr_start, wpd_error *err)
{
    wpd_las_info *las = &r->hdr.las;
    const char *path = r->hdr.path;
    uint8_t h[LAS_HEADER_SIZE_14] = {0};
    if (r->hdr.file_size < LAS_HEADER_SIZE_10)
        return wpd_fail(err, WPD_E_INPUT,
                        "%s: truncated header: the file has %llu bytes, a LAS header needs "
                        "at least %d",
                        path, (unsigned long long)r->hdr.file_size, LAS_HEADER_SIZE_10);
    size_t have = r->hdr.file_size < sizeof h ? (size_t)r->hdr.file_size : sizeof h;
    if (read_at(r, h, have, 0, "header", err))
        return -1;
    las->version_major = h[LAS_OFF_VERSION_MAJOR];
    las->version_minor = h[LAS_OFF_VERSION_MINOR];
    if (las->version_major != 1 || las->version_minor > 4)
        return wpd_fail(err, WPD_E_INPUT,
                        "%s: unsupported LAS version %u.%u (1.0 to 1.4 are supported)", path,
                        las->version_major, las->version_minor);
    uint16_t standard = las_standard_header_size(las->version_minor);
    if (have < standard)
        return wpd_fail(err, WPD_E_INPUT,
                        "%s: truncated header: the file has %llu bytes, a LAS %u.%u header "
                        "needs %u",
                        path, (unsigned long long)r->hdr.file_size, las->version_major,
                        las->version_minor, standard);
    parse_header_fields(las, h);
    *evlr_start = evlr_start_field(las, h);
    /* LAZ marks compression in the top bits of the PDRF byte. */
    if (las->pdrf & 0xC0) {
        las->nvlr = las_get_u32(h + LAS_OFF_NVLR);
        return fail_compressed(r, first_vlr_is_copc(r), err);
    }
    if (check_header_fields(r, err))
        return -1;
    las->extra_bytes = (uint16_t)(las->record_length - las_pdrf_size[las->pdrf]);
    las->header_tail_len = (uint32_t)(las->header_size - standard);
    if (las->header_tail_len) {
        if (!(las->header_tail = malloc(las->header_tail_len)))
            return wpd_fail(err, WPD_E_MEMORY, "%s: out of memory", path);
        if (read_at(r, las->header_tail, las->header_tail_len, standard, "header", err))
            return -1;
    }
    return 0;
}

/* ---- VLRs and EVLRs ---- */

/* Decodes a VLR (54-byte) or EVLR (60-byte) header. */
static void parse_vlr_header(wpd_vlr *v, const uint8_t *vh, int extended)
{
    v->reserved = las_get_u16(vh);
    copy_text(v->user_id, vh + 2, 16);
    v->record_id = las_get_u16(vh + 18);
    v->length = extended ? las_get_u64(vh + 20) : las_get_u16(vh + 20);
    copy_text(v->description, vh + (extended ? 28 : 22), 32);
    v->data = NULL;
}

/* Where a list of (E)VLRs may lie: [start, end) of the file. */
typedef struct vlr_area {
    const char *kind;       /* "VLR" or "EVLR" */
    int extended;           /* 60-byte headers with 64-bit lengths */
    uint64_t start, end;
    const char *end_name;   /* what lies at end, for messages */
} vlr_area;

/* Walks count (E)VLR headers through area, checking that each header and
 * payload lies inside it. With out == NULL only validates; otherwise also
 * fills out[0..count) and loads the payloads (already validated). */
static int walk_vlrs(wpd_reader *r, const vlr_area *a, uint32_t count, wpd_vlr *out,
                     wpd_error *err)
{
    const char *path = r->hdr.path;
    size_t hsize = a->extended ? LAS_EVLR_HEADER_SIZE : LAS_VLR_HEADER_SIZE;
    uint64_t pos = a->start;
    for (uint32_t i = 0; i < count; i++) {
        if (pos > a->end || a->end - pos < hsize)
            return wpd_fail(err, WPD_E_INPUT,
                            "%s: %s %u of %u (header at byte %llu) runs past %s at byte %llu; "
                            "the header's %s count is wrong",
                            path, a->kind, i + 1, count, (unsigned long long)pos, a->end_name,
                            (unsigned long long)a->end, a->kind);
        uint8_t vh[LAS_EVLR_HEADER_SIZE];
        wpd_vlr v;
        if (read_at(r, vh, hsize, pos, a->kind, err))
            return -1;
        parse_vlr_header(&v, vh, a->extended);
        pos += hsize;
        if (v.length > a->end - pos)
            return wpd_fail(err, WPD_E_INPUT,
                            "%s: %s %u of %u (\"%s\" record %u, %llu bytes at byte %llu) runs "
                            "past %s at byte %llu",
                            path, a->kind, i + 1, count, v.user_id, v.record_id,
                            (unsigned long long)v.length, (unsigned long long)pos, a->end_name,
                            (unsigned long long)a->end);
        if (out) {
            if (v.length && !(v.data = malloc(v.length)))
                return wpd_fail(err, WPD_E_MEMORY, "%s: out of memory for %s %u (%llu bytes)",
                                path, a->kind, i + 1, (unsigned long long)v.length);
            out[i] = v;
            if (v.length && read_at(r, v.data, v.length, pos, a->kind, err))
                return -1;
        }
        pos += v.length;
    }
    return 0;
}

/* Validates count (E)VLRs in area, then loads them into *list. */
static int load_vlrs(wpd_reader *r, const vlr_area *a, uint32_t count, wpd_vlr **list,
                     wpd_error *err)
{
    *list = NULL;
    if (!count)
        return 0;
    /* The first walk bounds count by the file contents before allocating. */
    if (walk_vlrs(r, a, count, NULL, err))
        return -1;
    if (!(*list = calloc(count, sizeof **list)))
        return wpd_fail(err, WPD_E_MEMORY, "%s: out of memory", r->hdr.path);
    return walk_vlrs(r, a, count, *list, err);
}

static int read_vlrs(wpd_reader *r, wpd_error *err)
{
    wpd_las_info *las = &r->hdr.las;
    vlr_area a = {"VLR", 0, las->header_size, las->offset_to_points,
                  "the start of the point data"};
    uint32_t n = las->nvlr;
    las->nvlr = 0; /* owns nothing until loaded */
    if (load_vlrs(r, &a, n, &las->vlrs, err)) {
        las->nvlr = las->vlrs ? n : 0; /* lets wpd_header_free release a partial list */
        return -1;
    }
    las->nvlr = n;
    for (uint32_t i = 0; i < n; i++) {
        const wpd_vlr *v = &las->vlrs[i];
        if (!strcmp(v->user_id, "copc"))
            return fail_compressed(r, 1, err);
        if (!strcmp(v->user_id, "laszip encoded")) /* record 22204 */
            return fail_compressed(r, 0, err);
    }
    return 0;
}

/* EVLRs: in 1.4 from start_of_first_evlr and the EVLR count; in 1.3 the only
 * EVLR is the waveform data packet record at start_of_waveform_data. They
 * must follow the point data. */
static int read_evlrs(wpd_reader *r, uint64_t evlr_start, uint64_t points_end, wpd_error *err)
{
    wpd_las_info *las = &r->hdr.las;
    uint32_t n = las->nevlr;
    uint64_t start = evlr_start;
    const char *field = "start_of_first_evlr";
    if (las->version_minor == 3) {
        n = las->waveform_start ? 1 : 0;
        start = las->waveform_start;
        field = "start_of_waveform_data_packet_record";
    }
    las->nevlr = 0;
    if (!n)
        return 0;
    if (start < points_end || start > r->hdr.file_size)
        return wpd_fail(err, WPD_E_INPUT,
                        "%s: %s %llu is outside the file after the point data (bytes %llu to "
                        "%llu)",
                        r->hdr.path, field, (unsigned long long)start,
                        (unsigned long long)points_end, (unsigned long long)r->hdr.file_size);
    vlr_area a = {"EVLR", 1, start, r->hdr.file_size, "the end of the file"};
    if (load_vlrs(r, &a, n, &las->evlrs, err)) {
        las->nevlr = las->evlrs ? n : 0;
        return -1;
    }
    las->nevlr = n;
    return 0;
}

/* The point records must fit between offset_to_point_data and the end. */
static int check_point_data(wpd_reader *r, uint64_t *points_end, wpd_error *err)
{
    const wpd_las_info *las = &r->hdr.las;
    uint64_t avail = r->hdr.file_size - las->offset_to_points;
    uint64_t count = las->point_count, len = las->record_length;
    if (count > avail / len) {
        if (count > UINT64_MAX / len)
            return wpd_fail(err, WPD_E_INPUT,
                            "%s: header point count %llu is impossibly large", r->hdr.path,
                            (unsigned long long)count);
        return wpd_fail(err, WPD_E_INPUT,
                        "%s: header point count %llu needs %llu bytes of point data "
                        "(%llu-byte records from byte %u) but the file has only %llu",
                        r->hdr.path, (unsigned long long)count,
                        (unsigned long long)(count * len), (unsigned long long)len,
                        las->offset_to_points, (unsigned long long)avail);
    }
    *points_end = las->offset_to_points + count * len;
    return 0;
}

/* ---- schema ---- */

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
    copy_text(name, d + 4, 32);
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

/* Dimensions of the record bytes from start to end (the extra bytes): the
 * described ones, then one u8 per undescribed byte ("extra_byte_<k>", k
 * counted from the first extra byte). */
static int add_extra_dims(wpd_header *h, uint32_t start, uint32_t end, wpd_error *err)
{
    const wpd_vlr *ebv = find_extra_bytes_vlr(&h->las);
    uint32_t pos = start;
    uint64_t ndesc = ebv ? ebv->length / LAS_EXTRA_BYTES_DESCRIPTOR_SIZE : 0;
    uint32_t first_described = h->schema.ndims;
    for (uint64_t i = 0; i < ndesc; i++) {
        uint32_t used = 0;
        if (add_extra_descriptor(h, ebv->data + i * LAS_EXTRA_BYTES_DESCRIPTOR_SIZE, i, pos,
                                 end, &used, err))
            return -1;
        pos += used;
    }
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
    return 0;
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
    return add_extra_dims(h, las_pdrf_size[pdrf], las->record_length, err);
}

/* ---- streaming ---- */

/* Decodes x, y, z of n records at rec into xyz. Records whose coordinates
 * are not finite are removed (the rest moved down, in order). Returns the
 * number kept. With a validated scale/offset nothing is ever removed, but
 * the check keeps the reader contract independent of that validation. */
static size_t decode_xyz(const las_reader *L, uint8_t *rec, size_t n, double *xyz)
{
    const uint32_t len = L->record_length;
    const double sx = L->scale[0], sy = L->scale[1], sz = L->scale[2];
    const double ox = L->offset[0], oy = L->offset[1], oz = L->offset[2];
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

static long las_read(wpd_reader *r, wpd_batch *b, wpd_error *err)
{
    las_reader *L = r->impl;
    const uint32_t len = L->record_length;
    const size_t block = READ_BLOCK_BYTES / len ? READ_BLOCK_BYTES / len : 1;
    size_t kept = 0;
    b->n = 0;
    if (!b->cap)
        return wpd_fail(err, WPD_E_USAGE, "%s: read into a batch without room", r->hdr.path);
    /* Loop until something is kept, so that 0 means only "end of points". */
    while (kept == 0 && L->next < r->end) {
        uint64_t left = r->end - L->next;
        size_t want = b->cap < left ? b->cap : (size_t)left;
        for (size_t done = 0; done < want;) {
            size_t n = want - done < block ? want - done : block;
            uint8_t *dst = b->records + kept * len;
            if (read_at(r, dst, n * len, L->data_start + (L->next + done) * len,
                        "point data", err))
                return -1;
            size_t k = decode_xyz(L, dst, n, b->xyz + 3 * kept);
            r->dropped += n - k;
            kept += k;
            done += n;
        }
        L->next += want;
    }
    b->n = kept;
    return (long)kept;
}

static int las_seek(wpd_reader *r, uint64_t index, wpd_error *err)
{
    (void)err;
    ((las_reader *)r->impl)->next = index;
    return 0;
}

static void las_close(wpd_reader *r)
{
    free(r->impl);
    r->impl = NULL;
}

static const wpd_reader_ops las_reader_ops = {las_read, las_seek, las_close};

int wpd_las_open_reader(wpd_reader *r, wpd_error *err)
{
    wpd_las_info *las = &r->hdr.las;
    uint64_t evlr_start = 0, points_end = 0;
    r->hdr.format = WPD_FMT_LAS;
    if (read_header(r, &evlr_start, err) || read_vlrs(r, err) ||
        check_point_data(r, &points_end, err) || read_evlrs(r, evlr_start, points_end, err))
        return -1;
    r->hdr.point_count = las->point_count;
    if (wpd_las_schema_from_info(&r->hdr, err))
        return -1;
    las_reader *L = calloc(1, sizeof *L);
    if (!L)
        return wpd_fail(err, WPD_E_MEMORY, "%s: out of memory", r->hdr.path);
    L->data_start = las->offset_to_points;
    L->record_length = las->record_length;
    memcpy(L->scale, las->scale, sizeof L->scale);
    memcpy(L->offset, las->offset, sizeof L->offset);
    r->impl = L;
    r->ops = &las_reader_ops;
    return 0;
}
