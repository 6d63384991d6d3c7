/* las_extra.c - writing Extra Bytes descriptors (LAS 1.4 R15, section
 * 2.6, table 24) and appending a described field to the records of a LAS
 * header (see las.h). The reading side is in las_schema.c.
 *
 * Descriptor layout (192 bytes): 0 reserved[2], 2 data_type, 3 options,
 * 4 name[32], 36 unused[4], 40 no_data, 48 deprecated, 64 min, 72
 * deprecated, 88 max, 96 deprecated, 112 scale, 120 deprecated, 136 offset,
 * 144 deprecated, 160 description[32]. Descriptors describe the extra
 * bytes in order from the end of the standard record; data_type 0 stands
 * for `options` undocumented bytes.
 */
#include "io/las/las_internal.h"

#include <stdio.h>
#include <stdlib.h>

enum { MAX_DESCRIPTORS = 65535 / LAS_EXTRA_BYTES_DESCRIPTOR_SIZE }; /* a VLR's payload */

uint8_t wpd_las_extra_type_code(wpd_type t)
{
    static const uint8_t code[] = {
        [WPD_U8] = 1, [WPD_I8] = 2, [WPD_U16] = 3, [WPD_I16] = 4, [WPD_U32] = 5,
        [WPD_I32] = 6, [WPD_U64] = 7, [WPD_I64] = 8, [WPD_F32] = 9, [WPD_F64] = 10,
    };
    return code[t];
}

void wpd_las_put_descriptor(uint8_t *desc, wpd_type type, const char *name,
                            const char *description)
{
    memset(desc, 0, LAS_EXTRA_BYTES_DESCRIPTOR_SIZE);
    desc[2] = wpd_las_extra_type_code(type);
    /* strncpy semantics: a 32-byte name fills the field without a NUL. */
    for (int i = 0; i < 32 && name[i]; i++)
        desc[4 + i] = (uint8_t)name[i];
    for (int i = 0; i < 32 && description[i]; i++)
        desc[160 + i] = (uint8_t)description[i];
}

/* The Extra Bytes VLR of las, or -1. */
static int extra_bytes_vlr(const wpd_las_info *las)
{
    for (uint32_t i = 0; i < las->nvlr; i++)
        if (!strcmp(las->vlrs[i].user_id, "LASF_Spec") && las->vlrs[i].record_id == 4)
            return (int)i;
    return -1;
}

/* Whole descriptors of v that las_schema.c would use for `extra` extra
 * bytes (every data_type known, none running past them), with the bytes
 * they cover in *covered; 0 when the reader ignores the VLR. */
static uint64_t usable_descriptors(const wpd_vlr *v, uint32_t extra, uint32_t *covered)
{
    uint64_t n = v->length / LAS_EXTRA_BYTES_DESCRIPTOR_SIZE;
    uint32_t pos = 0;
    for (uint64_t i = 0; i < n; i++) {
        const uint8_t *d = v->data + i * LAS_EXTRA_BYTES_DESCRIPTOR_SIZE;
        static const uint8_t size_of[10] = {1, 1, 2, 2, 4, 4, 8, 8, 4, 8};
        if (d[2] > 30)
            return *covered = 0;
        uint32_t size = d[2] ? ((d[2] - 1u) / 10u + 1u) * size_of[(d[2] - 1) % 10] : d[3];
        if (size > extra - pos)
            return *covered = 0;
        pos += size;
    }
    *covered = pos;
    return n;
}

/* The payload of the new Extra Bytes VLR, malloc'd into *out (*len
 * bytes): the usable old descriptors, data_type 0 descriptors for the
 * bytes they leave undescribed, then one for the new field. Returns 0, -1
 * when out of memory or -2 when the descriptors would not fit in a VLR. */
static int new_payload(const wpd_las_info *las, int old, uint32_t extra, wpd_type type,
                       const char *name, const char *description, uint8_t **out, size_t *len)
{
    uint32_t covered = 0;
    uint64_t keep = old >= 0 ? usable_descriptors(&las->vlrs[old], extra, &covered) : 0;
    uint32_t gap = extra - covered, fillers = (gap + 254) / 255;
    uint64_t n = keep + fillers + 1;
    if (n > MAX_DESCRIPTORS)
        return -2;
    uint8_t *p = calloc((size_t)n, LAS_EXTRA_BYTES_DESCRIPTOR_SIZE);
    if (!(*out = p))
        return -1;
    if (keep)
        memcpy(p, las->vlrs[old].data, keep * LAS_EXTRA_BYTES_DESCRIPTOR_SIZE);
    for (uint32_t i = 0; i < fillers; i++, gap -= 255) {
        uint8_t *d = p + (keep + i) * LAS_EXTRA_BYTES_DESCRIPTOR_SIZE;
        d[3] = (uint8_t)(gap < 255 ? gap : 255); /* data_type 0: options = byte count */
    }
    wpd_las_put_descriptor(p + (n - 1) * LAS_EXTRA_BYTES_DESCRIPTOR_SIZE, type, name,
                           description);
    *len = (size_t)n * LAS_EXTRA_BYTES_DESCRIPTOR_SIZE;
    return 0;
}

/* Puts payload (owned from now on) into the Extra Bytes VLR of las, which
 * is vlrs[old] or, with old < 0, a new last VLR. Returns 0 or -1. */
static int store_vlr(wpd_las_info *las, int old, uint8_t *payload, size_t len)
{
    if (old < 0) {
        wpd_vlr *grown = realloc(las->vlrs, (las->nvlr + 1) * sizeof *grown);
        if (!grown)
            return -1;
        las->vlrs = grown;
        old = (int)las->nvlr++;
        memset(&grown[old], 0, sizeof *grown);
        snprintf(grown[old].user_id, sizeof grown[old].user_id, "LASF_Spec");
        grown[old].record_id = 4;
        snprintf(grown[old].description, sizeof grown[old].description, "Extra Bytes");
    }
    free(las->vlrs[old].data);
    las->vlrs[old].data = payload;
    las->vlrs[old].length = len;
    return 0;
}

int wpd_las_append_extra(wpd_header *h, const char *name, wpd_type type,
                         const char *description, wpd_error *err)
{
    wpd_las_info *las = &h->las;
    uint32_t size = (uint32_t)wpd_type_size(type);
    if (las->pdrf > LAS_MAX_PDRF || las->record_length < las_pdrf_size[las->pdrf] ||
        las->record_length + size > UINT16_MAX)
        return wpd_fail(err, WPD_E_INPUT, "%s: no room for the field %s in a %u-byte LAS "
                        "record", h->path, name, las->record_length);
    int old = extra_bytes_vlr(las);
    uint32_t extra = las->record_length - las_pdrf_size[las->pdrf];
    uint8_t *payload = NULL;
    size_t len = 0;
    int rc = new_payload(las, old, extra, type, name, description, &payload, &len);
    if (rc == -1)
        return wpd_fail(err, WPD_E_MEMORY, "%s: out of memory", h->path);
    if (rc)
        return wpd_fail(err, WPD_E_INPUT, "%s: the Extra Bytes VLR has no room to describe "
                        "the field %s", h->path, name);
    if (store_vlr(las, old, payload, len)) {
        free(payload);
        return wpd_fail(err, WPD_E_MEMORY, "%s: out of memory", h->path);
    }
    las->record_length = (uint16_t)(las->record_length + size);
    las->extra_bytes = (uint16_t)(extra + size);
    return wpd_las_schema_from_info(h, err);
}
