/* laz_items14.c - the RGB14, RGBNIR14 and BYTE14 items of the layered
 * compressor, version 3: contexts and decoders (contracts in
 * laz_layered_state.h).
 *
 * Colour is coded as RGB12 v2 (laz_items.c), in its own layer; NIR in a
 * second layer, its two bytes flagged as changed by a 2-bit symbol and
 * coded as differences modulo 256. Each extra byte is its own layer, the
 * difference to the same byte of the previous point. All of them keep one
 * context per scanner channel, which POINT14 decides: a channel's first
 * point in a chunk starts its context from the previous channel's values.
 */
#include "io/laz_layered_state.h"

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

/* Starts context ch from the colour rgb (u16[3]) and NIR value. */
static int color_context(color14 *c, unsigned ch, const uint16_t *rgb, uint16_t nir)
{
    if (!c->ctx[ch] && !(c->ctx[ch] = color_context_create()))
        return -1;
    color14_context *x = c->ctx[ch];
    uint8_t raw[6];
    for (int i = 0; i < 3; i++)
        put_u16(raw + 2 * i, rgb[i]);
    laz_rgb12_start(x->rgb, raw);
    laz_sym_reset(&x->m_nir_used);
    laz_sym_reset(&x->m_nir_diff[0]);
    laz_sym_reset(&x->m_nir_diff[1]);
    x->last_nir = nir;
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

int laz_color14_switch(color14 *c, unsigned ch)
{
    if (ch != c->current && !(c->used & (1u << ch))) {
        color14_context *x = c->ctx[c->current];
        uint16_t rgb[3];
        memcpy(rgb, x->rgb->last, sizeof rgb);
        if (color_context(c, ch, rgb, x->last_nir))
            return -1;
    }
    c->current = ch;
    return 0;
}

/* NIR: which of its two bytes changed, then each as a difference. */
static uint16_t nir_decode(color14_context *x, laz_dec *d)
{
    uint32_t used = laz_dec_symbol(d, &x->m_nir_used);
    unsigned lo = x->last_nir & 0xFF, hi = x->last_nir >> 8;
    if (used & 1)
        lo = fold8((int)laz_dec_symbol(d, &x->m_nir_diff[0]) + (int)lo);
    if (used & 2)
        hi = fold8((int)laz_dec_symbol(d, &x->m_nir_diff[1]) + (int)hi);
    return x->last_nir = (uint16_t)(lo | hi << 8);
}

int laz_color14_decode(color14 *c, laz_layer *layer, unsigned ch, uint8_t *out)
{
    if (laz_color14_switch(c, ch))
        return -2;
    color14_context *x = c->ctx[c->current];
    if (layer[0].active) {
        laz_rgb12_decode(x->rgb, &layer[0].dec, out);
    } else {
        for (int i = 0; i < 3; i++)
            put_u16(out + 2 * i, x->rgb->last[i]);
    }
    if (c->nir)
        put_u16(out + 6, layer[1].active ? nir_decode(x, &layer[1].dec) : x->last_nir);
    return 0;
}

/* ---- extra bytes ---- */

static void bytes_context_free(bytes14_context *x, uint32_t n)
{
    if (!x)
        return;
    if (x->m)
        for (uint32_t i = 0; i < n; i++)
            laz_sym_free(&x->m[i]);
    free(x->m);
    free(x->last);
    free(x);
}

static bytes14_context *bytes_context_create(uint32_t n)
{
    bytes14_context *x = calloc(1, sizeof *x);
    if (!x)
        return NULL;
    x->last = malloc(n ? n : 1);
    x->m = calloc(n ? n : 1, sizeof *x->m);
    int bad = !x->last || !x->m;
    for (uint32_t i = 0; i < n && !bad; i++)
        bad = laz_sym_create(&x->m[i], 256);
    if (bad) {
        bytes_context_free(x, n);
        return NULL;
    }
    return x;
}

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
        bytes_context_free(b->ctx[i], b->n);
    free(b);
}

static int bytes_context(bytes14 *b, unsigned ch, const uint8_t *last)
{
    if (!b->ctx[ch] && !(b->ctx[ch] = bytes_context_create(b->n)))
        return -1;
    bytes14_context *x = b->ctx[ch];
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

int laz_bytes14_switch(bytes14 *b, unsigned ch)
{
    if (ch != b->current && !(b->used & (1u << ch)) &&
        bytes_context(b, ch, b->ctx[b->current]->last))
        return -1;
    b->current = ch;
    return 0;
}

int laz_bytes14_decode(bytes14 *b, laz_layer *layer, unsigned ch, uint8_t *out)
{
    if (laz_bytes14_switch(b, ch))
        return -2;
    bytes14_context *x = b->ctx[b->current];
    for (uint32_t i = 0; i < b->n; i++)
        if (layer[i].active)
            x->last[i] = fold8(x->last[i] + (int)laz_dec_symbol(&layer[i].dec, &x->m[i]));
    memcpy(out, x->last, b->n);
    return 0;
}
