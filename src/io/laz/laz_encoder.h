/* laz_encoder.h - the entropy encoding layer of LAZ (LASzip), the mirror of
 * laz_coder.h: a growable byte sink in memory, the arithmetic (range)
 * encoder and the integer compressor, over the same adaptive models
 * (laz_bit, laz_sym, laz_ic) so that the decoder reproduces every step.
 *
 * Written from the LAZ Specification 1.4 (rapidlasso) and the LASzip paper
 * and by inverting our decoder (laz_coder.c): the encoder keeps the low end
 * (base) of the interval the decoder keeps the offset into (value), and
 * shifts out one byte for every byte the decoder shifts in. A chunk is
 * encoded in memory, so a carry out of base is added into the bytes
 * already written, however far back. Not for use outside src/io.
 */
#ifndef WPD_LAZ_ENCODER_H
#define WPD_LAZ_ENCODER_H

#include <stddef.h>
#include <stdint.h>

#include "io/laz/laz_coder.h"

/* ---- byte sink ---- */

/* Bytes of one chunk (or the chunk table). A failed growth sets oom and
 * keeps overwriting the buffer's start: the bytes are then garbage, which
 * the caller learns from oom before using them. */
typedef struct laz_out {
    uint8_t *buf;
    size_t len, cap;
    int oom;
} laz_out;

/* Empties the sink (keeps its buffer); clears oom. */
void laz_out_clear(laz_out *o);
void laz_out_free(laz_out *o);
/* Grows the buffer (slow path of laz_out_byte). Returns 0, or -1 with oom set. */
int laz_out_grow(laz_out *o, size_t need);
static inline void laz_out_byte(laz_out *o, uint8_t b)
{
    if (o->len == o->cap && laz_out_grow(o, 1))
        o->len = 0;
    o->buf[o->len++] = b;
}
/* Appends n bytes (a chunk's raw first record). */
void laz_out_bytes(laz_out *o, const uint8_t *src, size_t n);

/* ---- arithmetic encoder ---- */

typedef struct laz_enc {
    laz_out *out;
    uint32_t base, length;
} laz_enc;

/* Starts an arithmetic stream appended to out. */
void laz_enc_init(laz_enc *e, laz_out *out);
/* Ends the stream: writes the bytes that pin a value inside the final
 * interval, padded so that the stream has exactly as many bytes as the
 * decoder reads (its 4 opening bytes and one per renormalisation). */
void laz_enc_done(laz_enc *e);

void laz_enc_bit(laz_enc *e, laz_bit *m, uint32_t bit);
/* sym < m->n. */
void laz_enc_symbol(laz_enc *e, laz_sym *m, uint32_t sym);
/* Raw (unmodelled) bits: the low n bits of v, n in 1..32. */
void laz_enc_bits(laz_enc *e, uint32_t v, unsigned n);
void laz_enc_u32(laz_enc *e, uint32_t v);

/* ---- integer compressor ---- */

/* Encodes real as pred plus a corrector in context ctx (< ic->contexts),
 * ic made by laz_ic_create; sets ic->k as the decoder will. */
void laz_ic_encode(laz_ic *ic, laz_enc *e, int32_t pred, int32_t real, uint32_t ctx);

#endif
