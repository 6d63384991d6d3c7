/* laz_items.h - the item decoders of the LAZ point-wise compressor
 * (point formats 0-5): POINT10, GPSTIME11, RGB12 and BYTE (extra bytes),
 * all version 2, chained in the order the LASzip VLR lists them.
 *
 * A chunk opens with one raw record; every later record is predicted from
 * the previous one(s) and decoded from (or encoded into) the chunk's
 * arithmetic stream.
 * Not for use outside src/io.
 */
#ifndef WPD_LAZ_ITEMS_H
#define WPD_LAZ_ITEMS_H

#include <stdint.h>

#include "io/laz/laz_coder.h"
#include "io/laz/laz_encoder.h"
#include "io/schema.h"

/* LASzip item type codes (LAZ specification, table of items). */
enum {
    LAZ_ITEM_BYTE = 0, LAZ_ITEM_POINT10 = 6, LAZ_ITEM_GPSTIME11 = 7, LAZ_ITEM_RGB12 = 8,
    LAZ_ITEM_WAVEPACKET13 = 9, LAZ_ITEM_POINT14 = 10, LAZ_ITEM_RGB14 = 11,
    LAZ_ITEM_RGBNIR14 = 12, LAZ_ITEM_WAVEPACKET14 = 13, LAZ_ITEM_BYTE14 = 14,
};

typedef struct laz_items laz_items;

/* Creates decoders for the n items of list (types and sizes already
 * checked against the record by laz_vlr.c: POINT10, GPSTIME11, RGB12,
 * BYTE, version 2). Returns NULL if out of memory. */
laz_items *laz_items_create(const wpd_laz_item *list, uint32_t n);
void laz_items_free(laz_items *it);

/* Starts a chunk whose first record is raw (already read into rec, the
 * whole record): resets every model and takes rec as the previous record. */
void laz_items_start(laz_items *it, const uint8_t *rec);

/* Decodes the next record of the chunk into rec from d. Returns 0, or -1
 * when the stream is found corrupt (a GPS time that never settles; *why
 * says so) or -2 when a model made on first use cannot be allocated. */
int laz_items_decode(laz_items *it, laz_dec *d, uint8_t *rec, const char **why);

/* Encodes rec, the next record of the chunk opened by laz_items_start,
 * into e: the exact inverse of laz_items_decode (laz_items_enc.c). The
 * items then hold rec as the previous record. Returns 0, or -1 when a
 * model made on first use cannot be allocated. */
int laz_items_encode(laz_items *it, laz_enc *e, const uint8_t *rec);

#endif
