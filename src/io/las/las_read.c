/* las_read.c - LAS 1.0-1.4 reader (PDRF 0-10, VLRs, EVLRs, extra bytes).
 *
 * Nothing in the header is trusted: every size, count and offset is checked
 * against the file size before anything is allocated or looped over. Points
 * are fixed-size records, so the reader streams them with pread(2) straight
 * into the batch and can start at any record index. LAZ (compressed LAS)
 * headers and VLRs are read here, the points by laz_read.c. The COPC info
 * VLR and hierarchy EVLR are dropped (las.copc says so): they index the
 * input's chunks and mean nothing in any file written from its points.
 */
#include "io/format.h"
#include "io/las/las_internal.h"
#include "io/laz/laz.h"
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
    las_copy_text(las->system_id, h + LAS_OFF_SYSTEM_ID, 32);
    las_copy_text(las->software, h + LAS_OFF_SOFTWARE, 32);
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
    if (las->version_minor >= 4)
        las->nevlr = las_get_u32(h + LAS_OFF_NEVLR);
}

/* LAS 1.4 has a 64-bit point count next to the legacy 32-bit one, which is
 * 0 for PDRF 6-10, for more than 2^32 points, and whenever the writer does
 * not keep legacy compatibility: 0 there is no oddity. The 64-bit count is
 * the authority, as in PDAL and laspy; a legacy count that disagrees is
 * reported. A 64-bit count of 0 next to a legacy one is a known writer bug:
 * the legacy count is used, with a warning. */
static void choose_point_count(wpd_reader *r, const uint8_t *h)
{
    wpd_las_info *las = &r->hdr.las;
    if (las->version_minor < 4)
        return;
    uint64_t legacy = las->point_count, count = las_get_u64(h + LAS_OFF_COUNT);
    if (!count && legacy) {
        wpd_warn(&r->hdr.warnings,
                 "%s: number_of_point_records is 0 but legacy_number_of_point_records is "
                 "%llu; the legacy count is used",
                 r->hdr.path, (unsigned long long)legacy);
        return;
    }
    if (legacy && legacy != count)
        wpd_warn(&r->hdr.warnings,
                 "%s: legacy_number_of_point_records %llu disagrees with "
                 "number_of_point_records %llu; the 64-bit count is used",
                 r->hdr.path, (unsigned long long)legacy, (unsigned long long)count);
    las->point_count = count;
    for (int i = 0; i < 15; i++)
        las->points_by_return[i] = las_get_u64(h + LAS_OFF_BY_RETURN + 8 * i);
}

/* Start of the first EVLR as stored in a 1.4 header (0 otherwise). */
static uint64_t evlr_start_field(const wpd_las_info *las, const uint8_t *h)
{
    return las->version_minor >= 4 ? las_get_u64(h + LAS_OFF_EVLR_START) : 0;
}

/* Takes record i out of list (n records), freeing its payload. */
static void drop_record(wpd_vlr *list, uint32_t *n, uint32_t i)
{
    free(list[i].data);
    memmove(list + i, list + i + 1, (*n - i - 1) * sizeof *list);
    --*n;
}

/* The COPC info VLR ("copc", 1) and hierarchy EVLR ("copc", 1000). */
static int is_copc(const wpd_vlr *v, uint16_t record)
{
    return !strcmp(v->user_id, "copc") && v->record_id == record;
}

/* Checks header size (at least standard bytes), point offset, PDRF, record
 * length, scale and offset (which must give finite coordinates for every
 * int32 value). */
static int check_header_fields(wpd_reader *r, uint16_t standard, wpd_error *err)
{
    const wpd_las_info *las = &r->hdr.las;
    const char *path = r->hdr.path;
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

/* The header size a LAS 1.<minor> file must have. A 1.3 header of the 227
 * bytes of 1.0-1.2 lacks only start_of_waveform_data_packet_record, which
 * no point needs: LAStools reads such files with a warning, and so does
 * wpd, taking the field as 0. The bytes past header_size are then VLRs, so
 * they are zeroed in h, the header as read. */
static uint16_t required_header_size(wpd_reader *r, uint8_t *h)
{
    uint8_t minor = h[LAS_OFF_VERSION_MINOR];
    uint16_t standard = las_standard_header_size(minor);
    uint16_t size = las_get_u16(h + LAS_OFF_HEADER_SIZE);
    if (minor != 3 || size < LAS_HEADER_SIZE_10 || size >= standard)
        return standard;
    wpd_warn(&r->hdr.warnings,
             "%s: header_size %u is smaller than the %u bytes of a LAS 1.3 header; read as "
             "a header without start_of_waveform_data_packet_record",
             r->hdr.path, size, standard);
    memset(h + size, 0, standard - size);
    return size;
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
    uint16_t standard = required_header_size(r, h);
    if (have < standard)
        return wpd_fail(err, WPD_E_INPUT,
                        "%s: truncated header: the file has %llu bytes, a LAS %u.%u header "
                        "needs %u",
                        path, (unsigned long long)r->hdr.file_size, las->version_major,
                        las->version_minor, standard);
    parse_header_fields(las, h);
    choose_point_count(r, h);
    *evlr_start = evlr_start_field(las, h);
    /* LAZ marks compression in the top bits of the PDRF byte; the records
     * it decompresses to are those of the format in the low bits. */
    if (las->pdrf & 0xC0) {
        las->laz.compressed = 1;
        las->pdrf &= 0x3F;
    }
    if (check_header_fields(r, standard, err))
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
    las_copy_text(v->user_id, vh + 2, 16);
    v->record_id = las_get_u16(vh + 18);
    v->length = extended ? las_get_u64(vh + 20) : las_get_u16(vh + 20);
    las_copy_text(v->description, vh + (extended ? 28 : 22), 32);
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
 * fills out[0..count) and loads the payloads (already validated). Sets
 * *stop (if not NULL) to the first byte after the last record. */
static int walk_vlrs(wpd_reader *r, const vlr_area *a, uint32_t count, wpd_vlr *out,
                     uint64_t *stop, wpd_error *err)
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
    if (stop)
        *stop = pos;
    return 0;
}

/* Validates count (E)VLRs in area, then loads them into *list; *stop as in
 * walk_vlrs. */
static int load_vlrs(wpd_reader *r, const vlr_area *a, uint32_t count, wpd_vlr **list,
                     uint64_t *stop, wpd_error *err)
{
    *list = NULL;
    *stop = a->start;
    if (!count)
        return 0;
    /* The first walk bounds count by the file contents before allocating. */
    if (walk_vlrs(r, a, count, NULL, NULL, err))
        return -1;
    if (!(*list = calloc(count, sizeof **list)))
        return wpd_fail(err, WPD_E_MEMORY, "%s: out of memory", r->hdr.path);
    return walk_vlrs(r, a, count, *list, stop, err);
}

/* Bytes between the last VLR and the point data: the LAS 1.0 start
 * signature, or bytes that later versions do not forbid (ASPRS LAS issue
 * #91: TerraScan writes 2, GeoCue up to thousands). Kept, so that LAS -> LAS
 * writes them back, as laspy (extra_vlr_bytes) and LAStools
 * (user_data_after_header) do; beyond this size only with a warning. */
#define LAS_VLR_TAIL_MAX (16u << 20)

static int keep_vlr_tail(wpd_reader *r, uint64_t vlr_end, wpd_error *err)
{
    wpd_las_info *las = &r->hdr.las;
    uint64_t len = las->offset_to_points - vlr_end;
    if (!len)
        return 0;
    if (len > LAS_VLR_TAIL_MAX) {
        wpd_warn(&r->hdr.warnings,
                 "%s: the %llu bytes between the VLRs and the point data are not carried "
                 "over (more than %u)",
                 r->hdr.path, (unsigned long long)len, LAS_VLR_TAIL_MAX);
        return 0;
    }
    if (!(las->vlr_tail = malloc(len)))
        return wpd_fail(err, WPD_E_MEMORY, "%s: out of memory", r->hdr.path);
    las->vlr_tail_len = (uint32_t)len;
    return read_at(r, las->vlr_tail, len, vlr_end, "bytes before the point data", err);
}

/* Parses the LASzip VLR (index i) into las.laz and takes it out of the VLR
 * list: the records read are decompressed, so what is written from them
 * must not claim compression. A LASzip VLR without the compression bits
 * leaves unclear whether the records are compressed: refused. */
static int take_laszip_vlr(wpd_reader *r, uint32_t i, wpd_error *err)
{
    wpd_las_info *las = &r->hdr.las;
    wpd_vlr *v = &las->vlrs[i];
    if (!las->laz.compressed)
        return wpd_fail(err, WPD_E_INPUT,
                        "%s: a LASzip VLR (LAZ) is present but the point format byte does not "
                        "mark compressed records",
                        r->hdr.path);
    if (wpd_laz_parse_vlr(r->hdr.path, v->data, v->length, &las->laz, err))
        return -1;
    las->laz.wpd_vlr = !strncmp(v->description, WPD_LAZ_VLR_DESCRIPTION,
                                strlen(WPD_LAZ_VLR_DESCRIPTION));
    drop_record(las->vlrs, &las->nvlr, i);
    return 0;
}

/* VLRs: strict, since a VLR count or length that runs into the point data
 * (PDAL's bad_vlr_count.las) leaves it unclear where anything is. */
static int read_vlrs(wpd_reader *r, wpd_error *err)
{
    wpd_las_info *las = &r->hdr.las;
    vlr_area a = {"VLR", 0, las->header_size, las->offset_to_points,
                  "the start of the point data"};
    uint32_t n = las->nvlr;
    uint64_t vlr_end;
    las->nvlr = 0; /* owns nothing until loaded */
    if (load_vlrs(r, &a, n, &las->vlrs, &vlr_end, err)) {
        las->nvlr = las->vlrs ? n : 0; /* lets wpd_header_free release a partial list */
        return -1;
    }
    las->nvlr = n;
    int laszip = 0;
    for (uint32_t i = 0; i < las->nvlr; i++) {
        const wpd_vlr *v = &las->vlrs[i];
        if (is_copc(v, 1)) {
            las->copc = 1;
            drop_record(las->vlrs, &las->nvlr, i--);
            continue;
        }
        if (!strcmp(v->user_id, WPD_LAZ_VLR_USER) && v->record_id == WPD_LAZ_VLR_RECORD) {
            if (laszip++)
                return wpd_fail(err, WPD_E_INPUT, "%s: two LASzip VLRs (LAZ)", r->hdr.path);
            if (take_laszip_vlr(r, i--, err)) /* i--: the list moved down by one */
                return -1;
        }
    }
    if (las->laz.compressed && !laszip)
        return wpd_fail(err, WPD_E_INPUT,
                        "%s: the point format byte marks compressed LAS (LAZ) but there is no "
                        "LASzip VLR (\"%s\", record %d)",
                        r->hdr.path, WPD_LAZ_VLR_USER, WPD_LAZ_VLR_RECORD);
    return keep_vlr_tail(r, vlr_end, err);
}

/* Where the EVLRs are said to start: in 1.4 start_of_first_evlr with the
 * EVLR count; in 1.3 the only EVLR is the waveform data packet record at
 * start_of_waveform_data_packet_record. */
typedef struct evlr_place {
    uint64_t start;
    uint32_t count;
    const char *field;      /* the header field that gives start */
    const char *what;       /* what is lost when they cannot be read */
} evlr_place;

static evlr_place evlr_place_of(const wpd_las_info *las, uint64_t evlr_start)
{
    if (las->version_minor == 3)
        return (evlr_place){las->waveform_start, las->waveform_start ? 1 : 0,
                            "start_of_waveform_data_packet_record", "the waveform data are"};
    return (evlr_place){evlr_start, las->nevlr, "start_of_first_evlr", "the EVLRs are"};
}

/* No point needs an EVLR (wpd reads Extra Bytes descriptions from the VLRs
 * only), so EVLRs that are not where the header says (a waveform pointer
 * past the end because the waveforms were kept in another file, an EVLR
 * start of 0 as PDAL before 2.1 wrote it, EVLRs that run past the end) are
 * ignored with a warning. A start inside the point data stays an error:
 * either it or the point count is wrong, and with a wrong count the points
 * read would include EVLR bytes. Sets *claimed to the bytes after the
 * points that the EVLRs take, or that the warning about them covers. */
static int read_evlrs(wpd_reader *r, uint64_t evlr_start, uint64_t points_end,
                      uint64_t *claimed, wpd_error *err)
{
    wpd_las_info *las = &r->hdr.las;
    evlr_place e = evlr_place_of(las, evlr_start);
    const char *path = r->hdr.path;
    uint64_t size = r->hdr.file_size;
    las->nevlr = 0;
    *claimed = 0;
    if (!e.count)
        return 0;
    *claimed = size - points_end; /* each way out below warns, or loads them */
    if (e.start >= las->offset_to_points && e.start < points_end)
        return wpd_fail(err, WPD_E_INPUT,
                        "%s: %s %llu lies inside the point data (bytes %u to %llu): either it "
                        "or the point count is wrong",
                        path, e.field, (unsigned long long)e.start, las->offset_to_points,
                        (unsigned long long)points_end);
    if (e.start < points_end || e.start > size) {
        wpd_warn(&r->hdr.warnings,
                 "%s: %s %llu is not in the file after the point data (bytes %llu to %llu); "
                 "%s ignored (not carried over)",
                 path, e.field, (unsigned long long)e.start, (unsigned long long)points_end,
                 (unsigned long long)size, e.what);
        return 0;
    }
    vlr_area a = {"EVLR", 1, e.start, size, "the end of the file"};
    wpd_error why = {0};
    if (walk_vlrs(r, &a, e.count, NULL, NULL, &why)) {
        if (why.code != WPD_E_INPUT) { /* an I/O error is not the file's oddity */
            if (err)
                *err = why;
            return -1;
        }
        wpd_warn(&r->hdr.warnings, "%s; %s ignored (not carried over)", why.msg, e.what);
        return 0;
    }
    uint64_t stop;
    if (load_vlrs(r, &a, e.count, &las->evlrs, &stop, err)) {
        las->nevlr = las->evlrs ? e.count : 0;
        return -1;
    }
    las->nevlr = e.count;
    *claimed = stop - e.start;
    for (uint32_t i = 0; i < las->nevlr; i++)
        if (is_copc(&las->evlrs[i], 1000))
            drop_record(las->evlrs, &las->nevlr, i--);
    return 0;
}

/* LAS 1.4 keeps start_of_waveform_data_packet_record next to the EVLR
 * fields; wpd does not need it (LAS -> LAS writes its own), so a value that
 * cannot be right is only reported. */
static void check_waveform_pointer(wpd_reader *r, uint64_t points_end)
{
    const wpd_las_info *las = &r->hdr.las;
    uint64_t at = las->waveform_start;
    if (las->version_minor < 4 || !at || (at >= points_end && at < r->hdr.file_size))
        return;
    wpd_warn(&r->hdr.warnings,
             "%s: start_of_waveform_data_packet_record %llu is not in the file after the "
             "point data (bytes %llu to %llu); ignored",
             r->hdr.path, (unsigned long long)at, (unsigned long long)points_end,
             (unsigned long long)r->hdr.file_size);
}

/* Bytes after the point records that no EVLR claims: garbage some writers
 * leave, or records the point count does not cover. Never read as points. */
static void check_unclaimed_bytes(wpd_reader *r, uint64_t points_end, uint64_t claimed)
{
    uint64_t after = r->hdr.file_size - points_end;
    if (after <= claimed)
        return;
    wpd_warn(&r->hdr.warnings,
             "%s: %llu bytes after the %llu point records belong to no record; ignored",
             r->hdr.path, (unsigned long long)(after - claimed),
             (unsigned long long)r->hdr.las.point_count);
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

/* ---- streaming ---- */

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
            size_t k = las_decode_xyz(L->scale, L->offset, len, dst, n, b->xyz + 3 * kept);
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

static const wpd_reader_ops las_reader_ops = {las_read, las_seek, las_close, NULL, NULL, NULL};

int wpd_las_open_reader(wpd_reader *r, wpd_error *err)
{
    wpd_las_info *las = &r->hdr.las;
    uint64_t evlr_start = 0, points_end = 0, claimed = 0;
    r->hdr.format = WPD_FMT_LAS;
    if (read_header(r, &evlr_start, err) || read_vlrs(r, err))
        return -1;
    r->hdr.point_count = las->point_count;
    int laz = las->laz.compressed;
    /* LAZ: the reader is laz_read.c's, which knows where the compressed
     * points end (the chunk table) and checks them as it decodes. */
    if (laz ? wpd_laz_open_reader(r, &points_end, err) : check_point_data(r, &points_end, err))
        return -1;
    if (read_evlrs(r, evlr_start, points_end, &claimed, err))
        return -1;
    check_waveform_pointer(r, points_end);
    if (!laz)
        check_unclaimed_bytes(r, points_end, claimed);
    if (wpd_las_schema_from_info(&r->hdr, err))
        return -1;
    if (laz)
        return 0;
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
