/* laz_layered.h - chunks of the layered compressor of LAZ 1.4 (point
 * formats 6-10): a chunk's raw first record, point count and layer byte
 * counts, its layers (those a caller needs loaded, the others skipped
 * without being read into memory or decoded), and the chain of item
 * decoders over them. Not for use outside src/io.
 */
#ifndef WPD_LAZ_LAYERED_H
#define WPD_LAZ_LAYERED_H

#include <stdint.h>

#include "io/laz/laz_coder.h"
#include "io/laz/laz_encoder.h"
#include "io/schema.h"

typedef struct laz_layered laz_layered;

/* Decoders for the n items of list (checked by laz_vlr.c: POINT14 first,
 * then RGB14 or RGBNIR14 and BYTE14, version 3). NULL if out of memory. */
laz_layered *laz_layered_create(const wpd_laz_item *list, uint32_t n);
void laz_layered_free(laz_layered *L);

/* From the next chunk on, decode only the layers of X, Y and Z (xyz_only
 * 1) or every layer (0). With xyz_only the other fields of the records
 * are those of each chunk's first point: for passes that need positions
 * only. */
void laz_layered_xyz_only(laz_layered *L, int xyz_only);

/* The scanner channels the open chunk's points have had so far, as bits
 * (bit c: channel c): more than one bit means a point changed channel. */
unsigned laz_layered_channels(const laz_layered *L);

/* Opens the chunk at in's position, whose bytes end at limit: reads the
 * raw first record (record_length bytes) into rec, the chunk's point
 * count into *count and the layers, and leaves in after the chunk.
 * Returns 0, -1 with *why set (truncated, or byte counts that pass the
 * chunk's end), or -2 if out of memory. */
int laz_layered_open(laz_layered *L, laz_in *in, uint64_t limit, uint32_t record_length,
                     uint8_t *rec, uint32_t *count, const char **why);

/* Decodes the chunk's next record into rec. Returns 0, -1 with *why set
 * (corrupt stream) or -2 if out of memory. */
int laz_layered_decode(laz_layered *L, uint8_t *rec, const char **why);

/* After a chunk's last record: NULL if every decoded layer ended exactly
 * at its byte count, else why not (corrupt or truncated). */
const char *laz_layered_close(const laz_layered *L);

/* ---- encoding (the LAZ writer) ---- */

/* Starts a chunk whose raw first record is rec: every item's context from
 * it, every layer's stream empty. Returns 0, or -1 if out of memory. */
int laz_layered_start_encode(laz_layered *L, const uint8_t *rec);

/* Encodes the chunk's next record. Returns 0, or -1 if out of memory. */
int laz_layered_encode(laz_layered *L, const uint8_t *rec);

/* Ends the chunk of count points opened with first (record_length bytes)
 * and appends it to out: the raw record, the count, the layer byte counts
 * (0 for a layer whose field never changed in the chunk: decoders then
 * keep the first point's value) and the layers. Returns 0, or -1 if out
 * of memory. */
int laz_layered_finish(laz_layered *L, laz_out *out, const uint8_t *first,
                       uint32_t record_length, uint32_t count);

#endif
