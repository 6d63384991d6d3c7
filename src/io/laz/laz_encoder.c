/* laz_encoder.c - byte sink, arithmetic encoder and integer compressor of
 * LAZ (contracts in laz_encoder.h). Each coding step is the inverse of the
 * decoder's step of the same name in laz_coder.c. */
#include "io/laz/laz_encoder.h"

#include <stdlib.h>
#include <string.h>

/* ---- byte sink ---- */

void laz_out_clear(laz_out *o)
{
    o->len = 0;
    o->oom = 0;
}

void laz_out_free(laz_out *o)
{
    free(o->buf);
    memset(o, 0, sizeof *o);
}

int laz_out_grow(laz_out *o, size_t need)
{
    if (o->cap - o->len >= need)
        return 0;
    size_t cap = o->cap ? o->cap : 64 * 1024;
    while (cap - o->len < need)
        cap *= 2;
    uint8_t *p = realloc(o->buf, cap);
    if (!p) {
        o->oom = 1;
        return -1;
    }
    o->buf = p;
    o->cap = cap;
    return 0;
}

void laz_out_bytes(laz_out *o, const uint8_t *src, size_t n)
{
    if (laz_out_grow(o, n))
        return;
    memcpy(o->buf + o->len, src, n);
    o->len += n;
}

/* ---- arithmetic encoder ---- */

void laz_enc_init(laz_enc *e, laz_out *out)
{
    e->out = out;
    e->base = 0;
    e->length = 0xFFFFFFFFu;
}

/* base wrapped past 2^32: the carry goes into the bytes already written
 * (a run of 0xFF becomes 0x00 and the byte before it grows by one). The
 * stream's value never passes the initial interval, so a byte that takes
 * the carry always exists. */
static void propagate_carry(laz_enc *e)
{
    laz_out *o = e->out;
    size_t i = o->len;
    while (i > 0 && o->buf[i - 1] == 0xFF)
        o->buf[--i] = 0;
    if (i > 0)
        o->buf[i - 1]++;
}

/* Adds x to base, carrying into the written bytes on overflow. */
static inline void add_base(laz_enc *e, uint32_t x)
{
    uint32_t before = e->base;
    e->base += x;
    if (e->base < before)
        propagate_carry(e);
}

/* Shifts out the top byte of base until the interval is at least 2^24
 * again: one byte for each byte the decoder's renorm shifts in. */
static inline void renorm(laz_enc *e)
{
    do {
        laz_out_byte(e->out, (uint8_t)(e->base >> 24));
        e->base <<= 8;
    } while ((e->length <<= 8) < LAZ_AC_MIN_LENGTH);
}

void laz_enc_done(laz_enc *e)
{
    /* A value in the final interval whose low bytes are zero: the top
     * byte (wide interval) or two bytes (narrow one) of base moved up by
     * half the minimum length; the zero bytes that follow fill the stream
     * up to the four the decoder reads beyond its renormalisations. */
    int third_zero = e->length > 2 * LAZ_AC_MIN_LENGTH;
    if (third_zero) {
        add_base(e, LAZ_AC_MIN_LENGTH);
        e->length = LAZ_AC_MIN_LENGTH >> 1;
    } else {
        add_base(e, LAZ_AC_MIN_LENGTH >> 1);
        e->length = LAZ_AC_MIN_LENGTH >> 9;
    }
    renorm(e);
    laz_out_byte(e->out, 0);
    laz_out_byte(e->out, 0);
    if (third_zero)
        laz_out_byte(e->out, 0);
}

void laz_enc_bit(laz_enc *e, laz_bit *m, uint32_t bit)
{
    uint32_t x = m->bit_0_prob * (e->length >> LAZ_BM_LENGTH_SHIFT);
    if (!bit) {
        e->length = x;
        ++m->bit_0_count;
    } else {
        add_base(e, x);
        e->length -= x;
    }
    if (e->length < LAZ_AC_MIN_LENGTH)
        renorm(e);
    if (--m->bits_until_update == 0)
        laz_bit_update(m);
}

void laz_enc_symbol(laz_enc *e, laz_sym *m, uint32_t sym)
{
    /* The last symbol takes the interval up to its end, as in the decoder. */
    uint32_t whole = e->length;
    e->length >>= LAZ_DM_LENGTH_SHIFT;
    uint32_t x = m->distribution[sym] * e->length;
    add_base(e, x);
    e->length = sym == m->last ? whole - x : m->distribution[sym + 1] * e->length - x;
    if (e->length < LAZ_AC_MIN_LENGTH)
        renorm(e);
    ++m->count[sym];
    if (--m->until_update == 0)
        laz_sym_update(m);
}

/* Up to 16 raw bits in one step. */
static void enc_raw(laz_enc *e, uint32_t v, unsigned n)
{
    e->length >>= n;
    add_base(e, v * e->length);
    if (e->length < LAZ_AC_MIN_LENGTH)
        renorm(e);
}

void laz_enc_bits(laz_enc *e, uint32_t v, unsigned n)
{
    if (n > 19) { /* as the decoder splits them: low 16 bits first */
        enc_raw(e, v & 0xFFFFu, 16);
        laz_enc_bits(e, v >> 16, n - 16);
        return;
    }
    enc_raw(e, n < 32 ? v & ((1u << n) - 1u) : v, n);
}

void laz_enc_u32(laz_enc *e, uint32_t v)
{
    enc_raw(e, v & 0xFFFFu, 16);
    enc_raw(e, v >> 16, 16);
}

/* ---- integer compressor ---- */

/* Bit length of v (0 for 0). */
static inline uint32_t bit_length(uint32_t v) { return v ? 32u - (uint32_t)__builtin_clz(v) : 0; }

/* The corrector c: its class k (bit length of |c| for c <= 0, of c - 1
 * for c > 0), then its place among the 2^k values of that class (the
 * high bits_high bits modelled, the rest raw); class 0 holds 0 and 1. */
static void write_corrector(laz_ic *ic, laz_enc *e, int32_t c, uint32_t ctx)
{
    uint32_t u = (uint32_t)c;
    uint32_t k = ic->k = bit_length(c <= 0 ? 0u - u : u - 1u);
    laz_enc_symbol(e, laz_ic_model(ic, &ic->m_bits[ctx], ctx), k);
    if (!k) {
        laz_enc_bit(e, &ic->m_corr0, u);
        return;
    }
    if (k >= 32) /* only the most negative corrector has 32 bits */
        return;
    uint32_t place = c < 0 ? u + ((1u << k) - 1u) : u - 1u;
    laz_sym *m = laz_ic_model(ic, &ic->m_corr[k], ic->contexts + k);
    if (k <= ic->bits_high) {
        laz_enc_symbol(e, m, place);
        return;
    }
    unsigned low = k - ic->bits_high;
    laz_enc_symbol(e, m, place >> low);
    laz_enc_bits(e, place, low);
}

void laz_ic_encode(laz_ic *ic, laz_enc *e, int32_t pred, int32_t real, uint32_t ctx)
{
    int32_t c = (int32_t)((uint32_t)real - (uint32_t)pred);
    if (ic->corr_range) { /* fold into [corr_min, corr_min + corr_range) */
        int32_t corr_max = ic->corr_min + (int32_t)ic->corr_range - 1;
        if (c < ic->corr_min)
            c += (int32_t)ic->corr_range;
        else if (c > corr_max)
            c -= (int32_t)ic->corr_range;
    }
    write_corrector(ic, e, c, ctx);
}
