/* laz_items14.c - the RGB14, RGBNIR14 and BYTE14 items of the layered
 * compressor, version 3: contexts and decoders (contracts in
 * laz_layered_state.h).
 *
 * Colour is coded as RGB12 v2 (laz_items.c), in its own layer; NIR in a
 * second layer, its two bytes flagged as changed by a 2-bit symbol and
 * coded as differences modulo 256. Each extra byte is its own layer, the
 * difference to the same byte of the previous point. All of them keep a
 * context per scanner channel, which POINT14 decides; which context's
 * previous values predict a point is LASzip's rule in
 * laz_layered_state.h.
 */
#include "io/laz/laz_layered_state.h"

#include <stdlib.h>
#include <string.h>

/* ---- colour ---- */

static void color_context_free(color14_context *x)
{
    if (!x)
        return;
    laz_rgb12_free(x->rgb);
    laz_sym_free(&x->m_nir_used);
    laz_sym_free(&x->m_nir_diff[0]);
    laz_sym_free(&x->m_nir_diff[1]);
    free(x);
}

static color14_context *color_context_create(void)
{
    color14_context *x = calloc(1, sizeof *x);
    if (x && (!(x->rgb = laz_rgb12_create()) || laz_sym_create(&x->m_nir_used, 4) ||
              laz_sym_create(&x->m_nir_diff[0], 256) || laz_sym_create(&x->m_nir_diff[1], 256))) {
        color_context_free(x);
        return NULL;
    }
    return x;
}

color14 *laz_color14_create(int nir)
{
    color14 *c = calloc(1, sizeof *c);
    if (c)
        c->nir = nir;
    return c;
}

void laz_color14_free(color14 *c)
{
    if (!c)
        return;
    for (int i = 0; i < 4; i++)
        color_context_free(c->ctx[i]);
    free(c);
}

/* Starts context ch: fresh models, the previous values rgb and nir. */
static int color_context(color14 *c, unsigned ch, const uint16_t *rgb, uint16_t nir)
{
    if (!c->ctx[ch] && !(c->ctx[ch] = color_context_create()))
        return -1;
    color14_context *x = c->ctx[ch];
    uint8_t raw[6];
    for (int i = 0; i < 3; i++)
        put_u16(raw + 2 * i, rgb[i]);
    laz_rgb12_start(x->rgb, raw);
    memmove(x->last, rgb, sizeof x->last);
    x->last_nir = nir;
    laz_sym_reset(&x->m_nir_used);
    laz_sym_reset(&x->m_nir_diff[0]);
    laz_sym_reset(&x->m_nir_diff[1]);
    c->used |= 1u << ch;
    return 0;
}

int laz_color14_start(color14 *c, unsigned ch, const uint8_t *rec)
{
    uint16_t rgb[3] = {get_u16(rec), get_u16(rec + 2), get_u16(rec + 4)};
    c->used = 0;
    c->current = ch;
    return color_context(c, ch, rgb, c->nir ? get_u16(rec + 6) : 0);
}

/* Moves to channel ch; *last gets the context whose previous values
 * predict this point (see laz_layered_state.h). */
static int color_switch(color14 *c, unsigned ch, color14_context **last)
{
    color14_context *prev = c->ctx[c->current];
    *last = prev;
    if (ch == c->current)
        return 0;
    c->current = ch;
    if (c->used & (1u << ch))
        return 0;
    if (color_context(c, ch, prev->last, prev->last_nir))
        return -1;
    *last = c->ctx[ch];
    return 0;
}

/* NIR: which of its two bytes changed, then each as a difference. */
static void nir_decode(color14_context *x, color14_context *l, laz_dec *d)
{
    uint32_t used = laz_dec_symbol(d, &x->m_nir_used);
    unsigned lo = l->last_nir & 0xFF, hi = l->last_nir >> 8;
    if (used & 1)
        lo = fold8((int)laz_dec_symbol(d, &x->m_nir_diff[0]) + (int)lo);
    if (used & 2)
        hi = fold8((int)laz_dec_symbol(d, &x->m_nir_diff[1]) + (int)hi);
    l->last_nir = (uint16_t)(lo | hi << 8);
}

int laz_color14_decode(color14 *c, laz_layer *layer, unsigned ch, uint8_t *out)
{
    color14_context *l;
    if (color_switch(c, ch, &l))
        return -2;
    color14_context *x = c->ctx[c->current];
    if (layer[0].active) { /* x's models, l's previous colour */
        memcpy(x->rgb->last, l->last, sizeof l->last);
        laz_rgb12_decode(x->rgb, &layer[0].dec, out);
        memcpy(l->last, x->rgb->last, sizeof l->last);
    } else {
        for (int i = 0; i < 3; i++)
            put_u16(out + 2 * i, l->last[i]);
    }
    if (c->nir) {
        if (layer[1].active)
            nir_decode(x, l, &layer[1].dec);
        put_u16(out + 6, l->last_nir);
    }
    return 0;
}

/* NIR from the encoder's side: nir_decode's flags and differences. */
static void nir_encode(color14_context *x, color14_context *l, laz_enc *e, uint16_t nir)
{
    uint32_t used = (uint32_t)((nir & 0xFF) != (l->last_nir & 0xFF)) |
                    (uint32_t)((nir >> 8) != (l->last_nir >> 8)) << 1;
    laz_enc_symbol(e, &x->m_nir_used, used);
    if (used & 1)
        laz_enc_symbol(e, &x->m_nir_diff[0], (uint8_t)((nir & 0xFF) - (l->last_nir & 0xFF)));
    if (used & 2)
        laz_enc_symbol(e, &x->m_nir_diff[1], (uint8_t)((nir >> 8) - (l->last_nir >> 8)));
    l->last_nir = nir;
}

int laz_color14_encode(color14 *c, laz_layer *layer, unsigned ch, const uint8_t *rec)
{
    color14_context *l;
    if (color_switch(c, ch, &l))
        return -1;
    color14_context *x = c->ctx[c->current];
    /* LASzip writes the colour layer when any point's symbol is not 0:
     * a byte changed, or the colour is not grey (its bit 6). */
    uint16_t r = get_u16(rec), g = get_u16(rec + 2), b = get_u16(rec + 4);
    layer[0].changed |= r != l->last[0] || g != l->last[1] || b != l->last[2] || g != r || b != r;
    memcpy(x->rgb->last, l->last, sizeof l->last);
    laz_rgb12_encode(x->rgb, &layer[0].enc, rec);
    memcpy(l->last, x->rgb->last, sizeof l->last);
    if (c->nir) {
        layer[1].changed |= get_u16(rec + 6) != l->last_nir;
        nir_encode(x, l, &layer[1].enc, get_u16(rec + 6));
    }
    return 0;
}

/* ---- extra bytes ---- */

bytes14 *laz_bytes14_create(uint32_t n)
{
    bytes14 *b = calloc(1, sizeof *b);
    if (b)
        b->n = n;
    return b;
}

void laz_bytes14_free(bytes14 *b)
{
    if (!b)
        return;
    for (int i = 0; i < 4; i++)
        laz_bytes_free(b->ctx[i]);
    free(b);
}

static int bytes_context(bytes14 *b, unsigned ch, const uint8_t *last)
{
    if (!b->ctx[ch] && !(b->ctx[ch] = laz_bytes_create(b->n)))
        return -1;
    bytes *x = b->ctx[ch];
    for (uint32_t i = 0; i < b->n; i++)
        laz_sym_reset(&x->m[i]);
    memmove(x->last, last, b->n);
    b->used |= 1u << ch;
    return 0;
}

int laz_bytes14_start(bytes14 *b, unsigned ch, const uint8_t *rec)
{
    b->used = 0;
    b->current = ch;
    return bytes_context(b, ch, rec);
}

/* As color_switch: *last is the previous values that predict. */
static int bytes_switch(bytes14 *b, unsigned ch, uint8_t **last)
{
    bytes *prev = b->ctx[b->current];
    *last = prev->last;
    if (ch == b->current)
        return 0;
    b->current = ch;
    if (b->used & (1u << ch))
        return 0;
    if (bytes_context(b, ch, prev->last))
        return -1;
    *last = b->ctx[ch]->last;
    return 0;
}

int laz_bytes14_decode(bytes14 *b, laz_layer *layer, unsigned ch, uint8_t *out)
{
    uint8_t *last;
    if (bytes_switch(b, ch, &last))
        return -2;
    laz_sym *m = b->ctx[b->current]->m;
    for (uint32_t i = 0; i < b->n; i++)
        if (layer[i].active)
            last[i] = fold8(last[i] + (int)laz_dec_symbol(&layer[i].dec, &m[i]));
    memcpy(out, last, b->n);
    return 0;
}

int laz_bytes14_encode(bytes14 *b, laz_layer *layer, unsigned ch, const uint8_t *rec)
{
    uint8_t *last;
    if (bytes_switch(b, ch, &last))
        return -1;
    laz_sym *m = b->ctx[b->current]->m;
    for (uint32_t i = 0; i < b->n; i++) {
        laz_enc_symbol(&layer[i].enc, &m[i], (uint8_t)(rec[i] - last[i]));
        layer[i].changed |= rec[i] != last[i];
    }
    memcpy(last, rec, b->n);
    return 0;
}
