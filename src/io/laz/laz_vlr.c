/* laz_vlr.c - the LASzip VLR: parsing, names, and the check against the
 * LAS header (contracts in laz.h).
 *
 * Payload (LAZ specification 1.4, "LASzip VLR"), little-endian:
 *   0 compressor u16  2 coder u16  4 version major u8  5 minor u8
 *   6 revision u16  8 options u32  12 chunk size u32  16 number of special
 *   EVLRs i64  24 offset of special EVLRs i64  32 item count u16
 *   34 items: type u16, size u16, version u16 (6 bytes each)
 */
#include "io/laz/laz.h"
#include "io/laz/laz_items.h"
#include "io/las/las_internal.h"

#include <stdio.h>
#include <string.h>

enum { LAZ_VLR_FIXED = 34, LAZ_VLR_ITEM = 6 };

const char *wpd_laz_item_name(uint16_t type)
{
    static const char *const names[] = {
        "BYTE", "SHORT", "INT", "LONG", "FLOAT", "DOUBLE", "POINT10", "GPSTIME11", "RGB12",
        "WAVEPACKET13", "POINT14", "RGB14", "RGBNIR14", "WAVEPACKET14", "BYTE14",
    };
    return type < sizeof names / sizeof *names ? names[type] : "unknown";
}

const char *wpd_laz_compressor_name(uint16_t c)
{
    switch (c) {
    case 0: return "none";
    case 1: return "point-wise";
    case 2: return "point-wise chunked";
    case 3: return "layered chunked";
    default: return "unknown";
    }
}

int wpd_laz_parse_vlr(const char *path, const uint8_t *p, uint64_t len, wpd_laz_info *info,
                      wpd_error *err)
{
    if (len < LAZ_VLR_FIXED)
        return wpd_fail(err, WPD_E_INPUT,
                        "%s: the LASzip VLR (LAZ) has %llu bytes, fewer than the %d of its "
                        "fixed part",
                        path, (unsigned long long)len, LAZ_VLR_FIXED);
    info->compressor = las_get_u16(p);
    info->coder = las_get_u16(p + 2);
    info->version_major = p[4];
    info->version_minor = p[5];
    info->version_revision = las_get_u16(p + 6);
    info->options = las_get_u32(p + 8);
    info->chunk_size = las_get_u32(p + 12);
    uint16_t n = las_get_u16(p + 32);
    if (n > WPD_LAZ_MAX_ITEMS || LAZ_VLR_FIXED + (uint64_t)n * LAZ_VLR_ITEM > len)
        return wpd_fail(err, WPD_E_INPUT,
                        "%s: the LASzip VLR (LAZ) lists %u items, which do not fit its %llu "
                        "bytes or pass the %d a point can have",
                        path, n, (unsigned long long)len, WPD_LAZ_MAX_ITEMS);
    info->nitems = n;
    for (uint16_t i = 0; i < n; i++) {
        const uint8_t *q = p + LAZ_VLR_FIXED + LAZ_VLR_ITEM * i;
        info->items[i] = (wpd_laz_item){las_get_u16(q), las_get_u16(q + 2), las_get_u16(q + 4)};
    }
    return 0;
}

/* "POINT10 20 v2, GPSTIME11 8 v2" into buf, for messages. */
static const char *item_list(const wpd_laz_info *z, char *buf, size_t size)
{
    size_t at = 0;
    buf[0] = '\0';
    for (uint16_t i = 0; i < z->nitems && at < size; i++) {
        int n = snprintf(buf + at, size - at, "%s%s %u v%u", i ? ", " : "",
                         wpd_laz_item_name(z->items[i].type), z->items[i].size,
                         z->items[i].version);
        if (n < 0)
            break;
        at += (size_t)n;
    }
    return buf;
}

/* Refusals by item: what exists in LAZ but is not decoded here, with the
 * reason a user can act on. The point-wise compressor takes the version 2
 * items of point formats 0-5, the layered one the version 3 items of
 * formats 6-10. */
static int check_items_known(const char *path, const wpd_laz_info *z, wpd_error *err)
{
    int layered = z->compressor == 3;
    for (uint16_t i = 0; i < z->nitems; i++) {
        const wpd_laz_item *it = &z->items[i];
        int ok = 0;
        switch (it->type) {
        case LAZ_ITEM_POINT10: case LAZ_ITEM_GPSTIME11: case LAZ_ITEM_RGB12: case LAZ_ITEM_BYTE:
            ok = !layered;
            break;
        case LAZ_ITEM_POINT14: case LAZ_ITEM_RGB14: case LAZ_ITEM_RGBNIR14: case LAZ_ITEM_BYTE14:
            ok = layered;
            break;
        case LAZ_ITEM_WAVEPACKET13: case LAZ_ITEM_WAVEPACKET14:
            return wpd_fail(err, WPD_E_INPUT,
                            "%s: waveform packets in LAZ are not supported (item %s); "
                            "decompress it first (e.g. with laszip)",
                            path, wpd_laz_item_name(it->type));
        default: break;
        }
        if (!ok)
            return wpd_fail(err, WPD_E_INPUT,
                            "%s: LAZ item type %u (%s) is not supported with the %s compressor",
                            path, it->type, wpd_laz_item_name(it->type),
                            wpd_laz_compressor_name(z->compressor));
        if (it->version == 1)
            return wpd_fail(err, WPD_E_INPUT,
                            "%s: LAZ written by LASzip 1.x (item %s version 1) is not "
                            "supported; recompress it with a current laszip",
                            path, wpd_laz_item_name(it->type));
        if (it->version != (layered ? 3 : 2))
            return wpd_fail(err, WPD_E_INPUT, "%s: unknown LAZ item version %u of %s", path,
                            it->version, wpd_laz_item_name(it->type));
    }
    return 0;
}

/* The items must be the record's fields in record order: the point item,
 * then GPS time, colour, waveform as the point format has them, then the
 * extra bytes, sizes adding up to the record length. */
static int check_items_layout(const wpd_header *h, wpd_error *err)
{
    const wpd_las_info *l = &h->las;
    const wpd_laz_info *z = &l->laz;
    wpd_laz_item want[5];
    int n = 0, f = l->pdrf;
    if (f >= 6) {
        want[n++] = (wpd_laz_item){LAZ_ITEM_POINT14, 30, 0};
        if (f == 7)
            want[n++] = (wpd_laz_item){LAZ_ITEM_RGB14, 6, 0};
        if (f == 8 || f == 10)
            want[n++] = (wpd_laz_item){LAZ_ITEM_RGBNIR14, 8, 0};
        if (f == 9 || f == 10)
            want[n++] = (wpd_laz_item){LAZ_ITEM_WAVEPACKET14, 29, 0};
        if (l->extra_bytes)
            want[n++] = (wpd_laz_item){LAZ_ITEM_BYTE14, l->extra_bytes, 0};
    } else {
        want[n++] = (wpd_laz_item){LAZ_ITEM_POINT10, 20, 0};
        if (f == 1 || f == 3 || f == 4 || f == 5)
            want[n++] = (wpd_laz_item){LAZ_ITEM_GPSTIME11, 8, 0};
        if (f == 2 || f == 3 || f == 5)
            want[n++] = (wpd_laz_item){LAZ_ITEM_RGB12, 6, 0};
        if (f == 4 || f == 5)
            want[n++] = (wpd_laz_item){LAZ_ITEM_WAVEPACKET13, 29, 0};
        if (l->extra_bytes)
            want[n++] = (wpd_laz_item){LAZ_ITEM_BYTE, l->extra_bytes, 0};
    }
    int same = z->nitems == n;
    for (int i = 0; same && i < n; i++)
        same = z->items[i].type == want[i].type && z->items[i].size == want[i].size;
    if (same)
        return 0;
    char buf[256];
    return wpd_fail(err, WPD_E_INPUT,
                    "%s: the LASzip VLR's items (%s) do not match point format %u with "
                    "%u-byte records",
                    h->path, item_list(z, buf, sizeof buf), l->pdrf, l->record_length);
}

int wpd_laz_check(const wpd_header *h, wpd_error *err)
{
    const wpd_las_info *l = &h->las;
    const wpd_laz_info *z = &l->laz;
    if (z->compressor < 1 || z->compressor > 3)
        return wpd_fail(err, WPD_E_INPUT, "%s: unknown LAZ compressor %u", h->path,
                        z->compressor);
    if ((l->pdrf >= 6) != (z->compressor == 3))
        return wpd_fail(err, WPD_E_INPUT,
                        "%s: LAZ point format %u with the %s compressor: point formats 6-10 "
                        "use the layered compressor and only they do",
                        h->path, l->pdrf, wpd_laz_compressor_name(z->compressor));
    if (z->coder != 0)
        return wpd_fail(err, WPD_E_INPUT, "%s: unknown LAZ coder %u (0, arithmetic, is defined)",
                        h->path, z->coder);
    if (check_items_known(h->path, z, err))
        return -1;
    return check_items_layout(h, err);
}
