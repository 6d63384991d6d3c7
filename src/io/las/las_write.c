/* las_write.c - LAS 1.0-1.4 writer.
 *
 * Layout written: header (the version's standard size + the caller's header
 * tail), VLRs (their headers byte for byte), the bytes the input had between
 * its VLRs and points [none in a LAS 1.0 input: the 0xCCDD point data start
 * signature], point records, EVLRs. The header is written first with zero counts and patched
 * by finish() with the counts, return histogram, bounds and EVLR position
 * of the points actually written. Header facts that identify the data
 * (creation date, system id, GUID, file source id, global encoding) are
 * carried over unchanged so that output is deterministic; only the
 * generating software becomes wpd's, with its version (common/version.h).
 */
#include "io/format.h"
#include "io/las/las_internal.h"
#include "io/laz/laz.h"
#include "common/version.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Points are staged in a buffer of this size and written in one call. */
#define WRITE_BUFFER_BYTES (4u * 1024u * 1024u)
/* Records are copied and quantised in steps of about this many bytes, so a
 * step is still in the CPU cache when the quantise loop walks over it. */
#define STAGE_STEP_BYTES (64u * 1024u)

typedef struct las_writer {
    uint8_t *buf;
    size_t buf_len, buf_cap;
    uint32_t record_length;
    uint16_t header_size;
    uint32_t offset_to_points;
    uint64_t max_points;          /* what the version's count fields can hold */
    uint8_t return_mask;          /* bits of the return number in byte 14 */
    double scale[3], offset[3];
    int32_t qmin[3], qmax[3];     /* bounds of the quantised coordinates */
    uint64_t by_return[16];       /* index = return number (0 not counted) */
    wpd_laz_writer *laz;          /* LAZ output: compresses the records; else NULL */
} las_writer;

static const char axis_name[3] = {'x', 'y', 'z'};

/* ---- header ---- */

/* Values that are only known once all points are written. */
typedef struct header_totals {
    uint64_t count;
    const uint64_t *by_return;    /* 16 entries, index = return number */
    double min[3], max[3];
    uint64_t waveform_start, evlr_start;
    uint32_t nevlr;
} header_totals;

static void put_text(uint8_t *dst, const char *src, size_t width)
{
    size_t n = strnlen(src, width);
    memset(dst, 0, width);
    memcpy(dst, src, n);
}

/* Encodes the full header (standard part + tail) into h, which must hold
 * L->header_size bytes. */
static void encode_header(const wpd_writer *w, const las_writer *L, const header_totals *t,
                          uint8_t *h)
{
    const wpd_las_info *las = &w->hdr.las;
    uint16_t standard = las_standard_header_size(las->version_minor);
    memset(h, 0, L->header_size);
    memcpy(h, "LASF", 4);
    las_put_u16(h + LAS_OFF_SOURCE_ID, las->file_source_id);
    las_put_u16(h + LAS_OFF_GLOBAL_ENCODING, las->global_encoding);
    memcpy(h + LAS_OFF_GUID, las->guid, 16);
    h[LAS_OFF_VERSION_MAJOR] = las->version_major;
    h[LAS_OFF_VERSION_MINOR] = las->version_minor;
    memcpy(h + LAS_OFF_SYSTEM_ID, las->system_id, 32); /* all 32 bytes, as read */
    put_text(h + LAS_OFF_SOFTWARE, WPD_SOFTWARE, 32);
    las_put_u16(h + LAS_OFF_DAY, las->creation_day);
    las_put_u16(h + LAS_OFF_YEAR, las->creation_year);
    las_put_u16(h + LAS_OFF_HEADER_SIZE, L->header_size);
    las_put_u32(h + LAS_OFF_POINT_OFFSET, L->offset_to_points);
    /* LAZ: the LASzip VLR is one more, and bit 7 of the point format marks
     * the records as compressed. */
    las_put_u32(h + LAS_OFF_NVLR, las->nvlr + (L->laz ? 1 : 0));
    h[LAS_OFF_PDRF] = (uint8_t)(las->pdrf | (L->laz ? 0x80 : 0));
    las_put_u16(h + LAS_OFF_RECORD_LENGTH, (uint16_t)L->record_length);
    /* LAS 1.4: the legacy counts are 0 for PDRF 6-10 and for counts that do
     * not fit in 32 bits; earlier versions have only the legacy fields. */
    int legacy = las->version_minor < 4 || (las->pdrf < 6 && t->count <= UINT32_MAX);
    if (legacy) {
        las_put_u32(h + LAS_OFF_LEGACY_COUNT, (uint32_t)t->count);
        for (int i = 0; i < 5; i++)
            las_put_u32(h + LAS_OFF_LEGACY_BY_RETURN + 4 * i, (uint32_t)t->by_return[i + 1]);
    }
    for (int i = 0; i < 3; i++) {
        las_put_f64(h + LAS_OFF_SCALE + 8 * i, L->scale[i]);
        las_put_f64(h + LAS_OFF_OFFSET + 8 * i, L->offset[i]);
        las_put_f64(h + LAS_OFF_BOUNDS + 16 * i, t->max[i]);
        las_put_f64(h + LAS_OFF_BOUNDS + 16 * i + 8, t->min[i]);
    }
    if (las->version_minor >= 3)
        las_put_u64(h + LAS_OFF_WAVEFORM_START, t->waveform_start);
    if (las->version_minor >= 4) {
        las_put_u64(h + LAS_OFF_EVLR_START, t->evlr_start);
        las_put_u32(h + LAS_OFF_NEVLR, t->nevlr);
        las_put_u64(h + LAS_OFF_COUNT, t->count);
        for (int i = 0; i < 15; i++)
            las_put_u64(h + LAS_OFF_BY_RETURN + 8 * i, t->by_return[i + 1]);
    }
    if (las->header_tail_len)
        memcpy(h + standard, las->header_tail, las->header_tail_len);
}

/* Writes the header at the current position (open) or over the first bytes
 * of the file without moving the position (patch, at finish). */
static int write_header(wpd_writer *w, const las_writer *L, const header_totals *t, int patch,
                        wpd_error *err)
{
    uint8_t *h = malloc(L->header_size);
    if (!h)
        return wpd_fail(err, WPD_E_MEMORY, "%s: out of memory", w->out.final_path);
    encode_header(w, L, t, h);
    int rc = patch ? wpd_outfile_pwrite(&w->out, h, L->header_size, 0, err)
                   : wpd_outfile_write(&w->out, h, L->header_size, err);
    free(h);
    return rc;
}

/* ---- VLRs and EVLRs ---- */

/* Writes a VLR or EVLR: its header as read, byte for byte (all 16 bytes of
 * the user id and 32 of the description, also those after a terminating
 * NUL: see wpd_vlr), then the payload. */
static int write_vlr(wpd_writer *w, const wpd_vlr *v, int extended, wpd_error *err)
{
    uint8_t vh[LAS_EVLR_HEADER_SIZE] = {0};
    las_put_u16(vh, v->reserved);
    memcpy(vh + 2, v->user_id, 16);
    las_put_u16(vh + 18, v->record_id);
    if (extended)
        las_put_u64(vh + 20, v->length);
    else
        las_put_u16(vh + 20, (uint16_t)v->length);
    memcpy(vh + (extended ? 28 : 22), v->description, 32);
    size_t hsize = extended ? LAS_EVLR_HEADER_SIZE : LAS_VLR_HEADER_SIZE;
    if (wpd_outfile_write(&w->out, vh, hsize, err))
        return -1;
    return v->length ? wpd_outfile_write(&w->out, v->data, v->length, err) : 0;
}

/* Writes the EVLRs after the points and records where they went.
 * LAS 1.4: all of them; the waveform start points at the first waveform data
 * packet record (record id 65535), if any. LAS 1.3 can locate only one EVLR,
 * through start_of_waveform_data_packet_record: the first EVLR is written
 * there and any others are dropped. LAS 1.0-1.2 have no EVLRs: all are
 * dropped. */
static int write_evlrs(wpd_writer *w, uint64_t pos, header_totals *t, wpd_error *err)
{
    const wpd_las_info *las = &w->hdr.las;
    uint32_t n = las->version_minor >= 4 ? las->nevlr
               : las->version_minor == 3 ? (las->nevlr ? 1 : 0) : 0;
    t->nevlr = n;
    t->evlr_start = n ? pos : 0;
    t->waveform_start = 0;
    for (uint32_t i = 0; i < n; i++) {
        const wpd_vlr *v = &las->evlrs[i];
        int waveform = las->version_minor == 3 || v->record_id == LAS_WAVEFORM_RECORD_ID;
        if (waveform && !t->waveform_start)
            t->waveform_start = pos;
        if (write_vlr(w, v, 1, err))
            return -1;
        pos += LAS_EVLR_HEADER_SIZE + v->length;
    }
    return 0;
}

/* ---- points ---- */

static int flush_buffer(wpd_writer *w, las_writer *L, wpd_error *err)
{
    if (!L->buf_len)
        return 0;
    int rc = L->laz ? wpd_laz_writer_put(L->laz, &w->out, L->buf, L->buf_len / L->record_length,
                                         err)
                    : wpd_outfile_write(&w->out, L->buf, L->buf_len, err);
    L->buf_len = 0;
    return rc;
}

static int fail_coordinate(wpd_writer *w, const las_writer *L, uint64_t index, int axis,
                           double v, wpd_error *err)
{
    return wpd_fail(err, WPD_E_INPUT,
                    "%s: point %llu: %c = %.17g does not fit a LAS 32-bit coordinate with "
                    "scale %g and offset %.17g",
                    w->out.final_path, (unsigned long long)index, axis_name[axis], v,
                    L->scale[axis], L->offset[axis]);
}

/* Rounds to the nearest integer, ties to even, without a libm call (which
 * x86-64 without SSE4.1 needs for nearbyint). Exact for |x| < 2^51. */
static inline double round_nearest(double x)
{
    const double magic = 6755399441055744.0; /* 1.5 * 2^52 */
    return (x + magic) - magic;
}

/* Stores the quantised xyz into the n staged records at rec and updates
 * bounds and the return histogram. first = index of the first point. */
static int quantise_records(wpd_writer *w, las_writer *L, uint8_t *rec, const double *xyz,
                            size_t n, uint64_t first, wpd_error *err)
{
    const uint32_t len = L->record_length;
    for (size_t i = 0; i < n; i++) {
        uint8_t *p = rec + i * len;
        for (int a = 0; a < 3; a++) {
            double v = xyz[3 * i + a];
            double u = (v - L->offset[a]) / L->scale[a];
            /* Also rejects NaN; within these limits u rounds into int32. */
            if (!(u > -2147483648.5 && u < 2147483647.5))
                return fail_coordinate(w, L, first + i, a, v, err);
            int32_t iq = (int32_t)round_nearest(u);
            memcpy(p + 4 * a, &iq, 4);
            if (iq < L->qmin[a])
                L->qmin[a] = iq;
            if (iq > L->qmax[a])
                L->qmax[a] = iq;
        }
        L->by_return[p[14] & L->return_mask]++;
    }
    return 0;
}

/* Appends the points of b. After an error the output lacks part of the
 * batch: the caller must abort the writer. */
static int las_write(wpd_writer *w, const wpd_batch *b, wpd_error *err)
{
    las_writer *L = w->impl;
    const uint32_t len = L->record_length;
    if (b->n > L->max_points - w->count)
        return wpd_fail(err, WPD_E_INPUT,
                        "%s: more than %llu points do not fit in a LAS %u.%u file (use LAS 1.4)",
                        w->out.final_path, (unsigned long long)L->max_points,
                        w->hdr.las.version_major, w->hdr.las.version_minor);
    /* The caller's records are copied into the buffer and quantised there:
     * the batch itself is never modified. */
    const size_t step = STAGE_STEP_BYTES / len ? STAGE_STEP_BYTES / len : 1;
    for (size_t done = 0; done < b->n;) {
        size_t room = (L->buf_cap - L->buf_len) / len;
        if (room > step)
            room = step;
        if (!room) {
            if (flush_buffer(w, L, err))
                return -1;
            continue;
        }
        size_t n = b->n - done < room ? b->n - done : room;
        uint8_t *dst = L->buf + L->buf_len;
        memcpy(dst, b->records + done * len, n * len);
        if (quantise_records(w, L, dst, b->xyz + 3 * done, n, w->count + done, err))
            return -1;
        L->buf_len += n * len;
        done += n;
    }
    w->count += b->n;
    return 0;
}

/* A part (writer.h) ends with its last records: no table, no header. */
static int las_end_part(wpd_writer *w, wpd_write_part *part, wpd_error *err)
{
    las_writer *L = w->impl;
    if (flush_buffer(w, L, err) ||
        (L->laz && wpd_laz_writer_end_part(L->laz, &w->out, &part->nchunks,
                                           &part->chunk_sizes, err)))
        return -1;
    memcpy(part->by_return, L->by_return, sizeof part->by_return);
    memcpy(part->qmin, L->qmin, sizeof part->qmin);
    memcpy(part->qmax, L->qmax, sizeof part->qmax);
    return 0;
}

static int las_add_part(wpd_writer *w, const wpd_write_part *part, wpd_error *err)
{
    las_writer *L = w->impl;
    if (part->count > L->max_points - w->count)
        return wpd_fail(err, WPD_E_INPUT,
                        "%s: more than %llu points do not fit in a LAS %u.%u file (use LAS 1.4)",
                        w->out.final_path, (unsigned long long)L->max_points,
                        w->hdr.las.version_major, w->hdr.las.version_minor);
    if (L->laz && wpd_laz_writer_add_chunks(L->laz, part->chunk_sizes, part->nchunks,
                                            part->bytes, err))
        return -1;
    for (int i = 0; i < 16; i++)
        L->by_return[i] += part->by_return[i];
    for (int a = 0; a < 3; a++) {
        L->qmin[a] = part->qmin[a] < L->qmin[a] ? part->qmin[a] : L->qmin[a];
        L->qmax[a] = part->qmax[a] > L->qmax[a] ? part->qmax[a] : L->qmax[a];
    }
    return 0;
}

static int las_finish(wpd_writer *w, wpd_error *err)
{
    las_writer *L = w->impl;
    if (w->part) {
        wpd_write_part ignored;
        return las_end_part(w, &ignored, err);
    }
    header_totals t = {.count = w->count, .by_return = L->by_return};
    if (flush_buffer(w, L, err))
        return -1;
    uint64_t points_end = L->offset_to_points + w->count * L->record_length;
    if (L->laz && wpd_laz_writer_finish(L->laz, &w->out, L->offset_to_points, &points_end, err))
        return -1;
    if (write_evlrs(w, points_end, &t, err))
        return -1;
    for (int a = 0; a < 3 && w->count; a++) {
        t.min[a] = L->qmin[a] * L->scale[a] + L->offset[a];
        t.max[a] = L->qmax[a] * L->scale[a] + L->offset[a];
    }
    return write_header(w, L, &t, 1, err);
}

static void las_close_writer(wpd_writer *w)
{
    las_writer *L = w->impl;
    if (L) {
        free(L->buf);
        wpd_laz_writer_free(L->laz);
    }
    free(L);
    w->impl = NULL;
}

static const wpd_writer_ops las_writer_ops = {las_write, las_finish, las_close_writer,
                                              las_end_part, las_add_part};

/* ---- open ---- */

/* Checks that w->hdr describes a LAS file this writer can produce. */
static int check_writer_header(const wpd_writer *w, uint32_t record_length, wpd_error *err)
{
    const wpd_las_info *las = &w->hdr.las;
    const char *path = w->out.final_path;
    if (las->version_major != 1 || las->version_minor > 4)
        return wpd_fail(err, WPD_E_USAGE, "%s: cannot write LAS version %u.%u (1.0 to 1.4)",
                        path, las->version_major, las->version_minor);
    if (las->pdrf > LAS_MAX_PDRF)
        return wpd_fail(err, WPD_E_USAGE, "%s: cannot write point data record format %u",
                        path, las->pdrf);
    if (record_length != w->hdr.schema.record_size || record_length > UINT16_MAX ||
        record_length < las_pdrf_size[las->pdrf])
        return wpd_fail(err, WPD_E_USAGE,
                        "%s: record length %u (schema record size %u) does not suit point "
                        "data record format %u (at least %u bytes, at most 65535)",
                        path, record_length, w->hdr.schema.record_size, las->pdrf,
                        las_pdrf_size[las->pdrf]);
    for (int i = 0; i < 3; i++)
        if (!(las->scale[i] != 0 && isfinite(las->scale[i]) && isfinite(las->offset[i])))
            return wpd_fail(err, WPD_E_USAGE, "%s: unusable %c scale %g / offset %g", path,
                            axis_name[i], las->scale[i], las->offset[i]);
    if (las_standard_header_size(las->version_minor) + (uint64_t)las->header_tail_len >
        UINT16_MAX)
        return wpd_fail(err, WPD_E_USAGE, "%s: header tail of %u bytes is too long", path,
                        las->header_tail_len);
    for (uint32_t i = 0; i < las->nvlr; i++)
        if (las->vlrs[i].length > UINT16_MAX)
            return wpd_fail(err, WPD_E_USAGE,
                            "%s: VLR %u (\"%s\" record %u) has %llu bytes, more than a VLR "
                            "can hold (65535)",
                            path, i + 1, las->vlrs[i].user_id, las->vlrs[i].record_id,
                            (unsigned long long)las->vlrs[i].length);
    return 0;
}

/* The point data start signature LAS 1.0 requires after the VLRs. */
static const uint8_t las10_signature[2] = {0xCC, 0xDD}; /* as liblas writes it */

/* Bytes written between the VLRs and the point data: those of the input
 * (see wpd_las_info.vlr_tail), else LAS 1.0's start signature. */
static const uint8_t *vlr_tail(const wpd_las_info *las, uint32_t *len)
{
    *len = las->vlr_tail_len;
    if (*len)
        return las->vlr_tail;
    if (las->version_minor == 0)
        *len = sizeof las10_signature;
    return las10_signature;
}

/* Bytes before the first point record (LAZ: before the chunk table
 * offset); -1 if beyond the 32-bit offset field. */
static int64_t prelude_size(const wpd_las_info *las, const las_writer *L)
{
    uint64_t size = L->header_size;
    for (uint32_t i = 0; i < las->nvlr; i++)
        size += LAS_VLR_HEADER_SIZE + las->vlrs[i].length;
    if (L->laz) {
        wpd_vlr laszip;
        wpd_laz_writer_vlr(L->laz, &laszip);
        size += LAS_VLR_HEADER_SIZE + laszip.length;
    }
    uint32_t tail;
    vlr_tail(las, &tail);
    size += tail;
    return size > UINT32_MAX ? -1 : (int64_t)size;
}

static las_writer *new_las_writer(const wpd_writer *w, uint32_t record_length)
{
    const wpd_las_info *las = &w->hdr.las;
    las_writer *L = calloc(1, sizeof *L);
    if (!L)
        return NULL;
    L->record_length = record_length;
    L->buf_cap = WRITE_BUFFER_BYTES < record_length ? record_length : WRITE_BUFFER_BYTES;
    L->buf = malloc(L->buf_cap);
    if (!L->buf) {
        free(L);
        return NULL;
    }
    L->header_size = (uint16_t)(las_standard_header_size(las->version_minor) +
                                las->header_tail_len);
    L->max_points = las->version_minor >= 4 ? UINT64_MAX : UINT32_MAX;
    L->return_mask = (uint8_t)((1u << las_return_bits(las->pdrf)) - 1);
    memcpy(L->scale, las->scale, sizeof L->scale);
    memcpy(L->offset, las->offset, sizeof L->offset);
    for (int a = 0; a < 3; a++) {
        L->qmin[a] = INT32_MAX;
        L->qmax[a] = INT32_MIN;
    }
    return L;
}

int wpd_las_open_writer(wpd_writer *w, wpd_error *err)
{
    const wpd_las_info *las = &w->hdr.las;
    uint32_t record_length = las->record_length ? las->record_length
                                                : w->hdr.schema.record_size;
    if (check_writer_header(w, record_length, err))
        return -1;
    las_writer *L = new_las_writer(w, record_length);
    if (!L)
        return wpd_fail(err, WPD_E_MEMORY, "%s: out of memory", w->out.final_path);
    w->impl = L;
    w->ops = &las_writer_ops;
    if (las->laz.compressed &&
        !(L->laz = wpd_laz_writer_create(w->out.final_path, las->pdrf,
                                         (uint16_t)record_length, err)))
        return -1;
    int64_t prelude = prelude_size(las, L);
    if (prelude < 0)
        return wpd_fail(err, WPD_E_USAGE, "%s: the VLRs do not fit before the point data "
                        "(more than 4 GiB)", w->out.final_path);
    L->offset_to_points = (uint32_t)prelude;
    if (w->part) /* records only (writer.h) */
        return 0;
    /* Placeholder header (patched by finish), then the VLRs in order. */
    uint64_t zero_returns[16] = {0};
    header_totals t = {.by_return = zero_returns};
    if (write_header(w, L, &t, 0, err))
        return -1;
    for (uint32_t i = 0; i < las->nvlr; i++)
        if (write_vlr(w, &las->vlrs[i], 0, err))
            return -1;
    if (L->laz) {
        wpd_vlr laszip;
        wpd_laz_writer_vlr(L->laz, &laszip);
        if (write_vlr(w, &laszip, 0, err))
            return -1;
    }
    uint32_t tail_len;
    const uint8_t *tail = vlr_tail(las, &tail_len);
    if (tail_len && wpd_outfile_write(&w->out, tail, tail_len, err))
        return -1;
    return L->laz ? wpd_laz_writer_begin(L->laz, &w->out, err) : 0;
}
