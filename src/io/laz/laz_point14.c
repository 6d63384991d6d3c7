/* laz_point14.c - the POINT14 item of the layered compressor, version 3:
 * its contexts and its decoder (contracts in laz_layered_state.h).
 *
 * Record fields (LAS 1.4, point formats 6-10): 0 X, 4 Y, 8 Z (i32),
 * 12 intensity (u16), 14 return number (low nibble) and number of returns
 * (high nibble), 15 classification flags (bits 0-3), scanner channel
 * (4-5), scan direction (6), edge of flight line (7), 16 classification,
 * 17 user data, 18 scan angle (i16), 20 point source (u16), 22 GPS time.
 *
 * Each point opens with a 7-bit symbol in the XY layer: bit 6 the scanner
 * channel changed, 5 the point source, 4 the GPS time, 3 the scan angle,
 * 2 the number of returns, bits 0-1 the return number (same, +1, -1,
 * other). The other layers are decoded only when asked for.
 */
#include "io/laz/laz_layered_state.h"

#include <stdlib.h>
#include <string.h>

const uint8_t laz_return_map14[16][16] = {
    {0, 1, 2, 3, 4, 5, 3, 4, 4, 5, 5, 5, 5, 5, 5, 5}, {1, 0, 1, 3, 3, 3, 3, 3, 3, 3, 3, 3, 3, 3, 3, 3},
    {2, 1, 2, 4, 4, 4, 4, 4, 4, 4, 4, 3, 3, 3, 3, 3}, {3, 3, 4, 5, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4},
    {4, 3, 4, 4, 5, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4}, {5, 3, 4, 4, 4, 5, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4},
    {3, 3, 4, 4, 4, 4, 5, 4, 4, 4, 4, 4, 4, 4, 4, 4}, {4, 3, 4, 4, 4, 4, 4, 5, 4, 4, 4, 4, 4, 4, 4, 4},
    {4, 3, 4, 4, 4, 4, 4, 4, 5, 4, 4, 4, 4, 4, 4, 4}, {5, 3, 4, 4, 4, 4, 4, 4, 4, 5, 4, 4, 4, 4, 4, 4},
    {5, 3, 4, 4, 4, 4, 4, 4, 4, 4, 5, 4, 4, 4, 4, 4}, {5, 3, 3, 4, 4, 4, 4, 4, 4, 4, 4, 5, 5, 4, 4, 4},
    {5, 3, 3, 4, 4, 4, 4, 4, 4, 4, 4, 5, 5, 5, 4, 4}, {5, 3, 3, 4, 4, 4, 4, 4, 4, 4, 4, 4, 5, 5, 5, 4},
    {5, 3, 3, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 5, 5, 5}, {5, 3, 3, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 5, 5},
};

/* ---- contexts ---- */

static void lazy_free(laz_lazy_sym *l, int n)
{
    for (int i = 0; i < n; i++)
        laz_sym_free(&l[i].m);
}

static void context_free(p14_context *c)
{
    if (!c)
        return;
    laz_gpstime_free(c->gps);
    for (int i = 0; i < 8; i++)
        laz_sym_free(&c->m_changed[i]);
    laz_sym_free(&c->m_channel);
    laz_sym_free(&c->m_return_gps_same);
    lazy_free(c->m_nreturns, 16);
    lazy_free(c->m_return, 16);
    lazy_free(c->m_class, 64);
    lazy_free(c->m_flags, 64);
    lazy_free(c->m_user, 64);
    laz_ic_free(&c->ic_dx);
    laz_ic_free(&c->ic_dy);
    laz_ic_free(&c->ic_z);
    laz_ic_free(&c->ic_intensity);
    laz_ic_free(&c->ic_scan);
    laz_ic_free(&c->ic_source);
    free(c);
}

/* Integer coder contexts (specification): dx by single return (2); dy and
 * z also by the magnitude of the previous coordinate's corrector (22, 20);
 * intensity by the current return context (4); scan angle by GPS change
 * (2). */
static p14_context *context_create(void)
{
    p14_context *c = calloc(1, sizeof *c);
    if (!c)
        return NULL;
    int bad = !(c->gps = laz_gpstime_create(1));
    for (int i = 0; i < 8 && !bad; i++)
        bad = laz_sym_create(&c->m_changed[i], 128);
    bad = bad || laz_sym_create(&c->m_channel, 3) || laz_sym_create(&c->m_return_gps_same, 13) ||
          laz_ic_create(&c->ic_dx, 32, 2) || laz_ic_create(&c->ic_dy, 32, 22) ||
          laz_ic_create(&c->ic_z, 32, 20) || laz_ic_create(&c->ic_intensity, 16, 4) ||
          laz_ic_create(&c->ic_scan, 16, 2) || laz_ic_create(&c->ic_source, 16, 1);
    if (bad) {
        context_free(c);
        return NULL;
    }
    return c;
}

point14 *laz_point14_create(void)
{
    return calloc(1, sizeof(point14));
}

void laz_point14_free(point14 *p)
{
    if (!p)
        return;
    for (int i = 0; i < 4; i++)
        context_free(p->ctx[i]);
    free(p);
}

int laz_point14_context(point14 *p, unsigned ch, const uint8_t *last)
{
    if (!p->ctx[ch] && !(p->ctx[ch] = context_create()))
        return -1;
    p14_context *c = p->ctx[ch];
    c->epoch++;
    for (int i = 0; i < 8; i++)
        laz_sym_reset(&c->m_changed[i]);
    laz_sym_reset(&c->m_channel);
    laz_sym_reset(&c->m_return_gps_same);
    laz_ic_reset(&c->ic_dx);
    laz_ic_reset(&c->ic_dy);
    laz_ic_reset(&c->ic_z);
    laz_ic_reset(&c->ic_intensity);
    laz_ic_reset(&c->ic_scan);
    laz_ic_reset(&c->ic_source);
    memcpy(c->last, last, 30);
    c->last[15] = (uint8_t)((c->last[15] & ~0x30u) | ch << 4);
    c->gps_change = 0;
    for (int i = 0; i < 12; i++) {
        median5_init(&c->dx[i]);
        median5_init(&c->dy[i]);
    }
    for (int i = 0; i < 8; i++) {
        c->last_intensity[i] = get_u16(last + 12);
        c->last_z[i] = get_i32(last + 8);
    }
    laz_gpstime_start(c->gps, last + 22);
    p->used |= 1u << ch;
    return 0;
}

int laz_point14_start(point14 *p, const uint8_t *rec)
{
    p->used = 0;
    p->item = p->current = (rec[15] >> 4) & 3;
    return laz_point14_context(p, p->current, rec);
}

/* ---- decoding ---- */

/* The scanner channel after a change: +1..3 modulo 4. A channel's first
 * point in the chunk starts its context from the current one's. */
static int switch_channel(point14 *p, laz_dec *d)
{
    p14_context *c = p->ctx[p->current];
    unsigned ch = (p->current + laz_dec_symbol(d, &c->m_channel) + 1) & 3;
    if (!(p->used & (1u << ch)) && laz_point14_context(p, ch, c->last))
        return -1;
    p->current = ch;
    return 0;
}

/* Number of returns and return number (byte 14) from the change bits. */
static int returns(p14_context *c, laz_dec *d, uint32_t changed)
{
    uint8_t *last = c->last;
    unsigned r = last[14] & 15, n = last[14] >> 4;
    if (changed & 4) {
        laz_sym *m = laz_lazy_model(&c->m_nreturns[n], 16, c->epoch);
        if (!m)
            return -1;
        n = laz_dec_symbol(d, m);
    }
    switch (changed & 3) {
    case 1: r = (r + 1) & 15; break;
    case 2: r = (r + 15) & 15; break;
    case 3:
        if (changed & 16) {
            laz_sym *m = laz_lazy_model(&c->m_return[r], 16, c->epoch);
            if (!m)
                return -1;
            r = laz_dec_symbol(d, m);
        } else {
            r = (r + laz_dec_symbol(d, &c->m_return_gps_same) + 2) & 15;
        }
        break;
    default: break;
    }
    last[14] = (uint8_t)(r | n << 4);
    return 0;
}

/* x and y: the difference to the previous point predicted by the median of
 * the last five of the same return map and GPS change; the k of the x
 * corrector picks the y context. */
static void xy(p14_context *c, laz_dec *d, unsigned n, unsigned m, int gps)
{
    uint8_t *last = c->last;
    unsigned i = m << 1 | (unsigned)gps;
    int32_t diff = laz_ic_decode(&c->ic_dx, d, c->dx[i].v[2], n == 1);
    put_i32(last, (int32_t)((uint32_t)get_i32(last) + (uint32_t)diff));
    median5_add(&c->dx[i], diff);
    uint32_t k = c->ic_dx.k;
    diff = laz_ic_decode(&c->ic_dy, d, c->dy[i].v[2], (n == 1) + (k < 20 ? k & ~1u : 20));
    put_i32(last + 4, (int32_t)((uint32_t)get_i32(last + 4) + (uint32_t)diff));
    median5_add(&c->dy[i], diff);
}

static void z(p14_context *c, laz_dec *d, unsigned n, unsigned l)
{
    uint32_t k = (c->ic_dx.k + c->ic_dy.k) / 2;
    int32_t v = laz_ic_decode(&c->ic_z, d, c->last_z[l], (n == 1) + (k < 18 ? k & ~1u : 18));
    put_i32(c->last + 8, v);
    c->last_z[l] = v;
}

/* Classification (context: its last value's low 5 bits and whether the
 * point is a single return) and the flags (edge, scan direction and the
 * four classification flags as one 6-bit symbol, context their last
 * value). The scanner channel bits of byte 15 are the XY layer's. */
static int class_flags(p14_context *c, laz_layer *layer, unsigned cpr)
{
    uint8_t *last = c->last;
    if (layer[P14_CLASS].active) {
        laz_sym *m = laz_lazy_model(&c->m_class[((last[16] & 0x1Fu) << 1) + (cpr == 3)], 256,
                                    c->epoch);
        if (!m)
            return -1;
        last[16] = (uint8_t)laz_dec_symbol(&layer[P14_CLASS].dec, m);
    }
    if (layer[P14_FLAGS].active) {
        unsigned b = last[15], prev = (b >> 7) << 5 | ((b >> 6) & 1) << 4 | (b & 15);
        laz_sym *m = laz_lazy_model(&c->m_flags[prev], 64, c->epoch);
        if (!m)
            return -1;
        unsigned f = laz_dec_symbol(&layer[P14_FLAGS].dec, m);
        last[15] = (uint8_t)((f & 15) | (b & 0x30) | ((f >> 4) & 1) << 6 | ((f >> 5) & 1) << 7);
    }
    return 0;
}

/* Intensity against the last of the current return context and GPS
 * change; scan angle and point source only when flagged as changed. */
static void intensity_angle_source(p14_context *c, laz_layer *layer, uint32_t changed,
                                   unsigned cpr, int gps)
{
    uint8_t *last = c->last;
    if (layer[P14_INTENSITY].active) {
        unsigned i = cpr << 1 | (unsigned)gps;
        uint16_t v = (uint16_t)laz_ic_decode(&c->ic_intensity, &layer[P14_INTENSITY].dec,
                                             c->last_intensity[i], cpr);
        c->last_intensity[i] = v;
        put_u16(last + 12, v);
    }
    if (layer[P14_SCAN].active && (changed & 8)) {
        int16_t prev;
        memcpy(&prev, last + 18, 2);
        int16_t v = (int16_t)laz_ic_decode(&c->ic_scan, &layer[P14_SCAN].dec, prev, gps != 0);
        memcpy(last + 18, &v, 2);
    }
    if (layer[P14_SOURCE].active && (changed & 32))
        put_u16(last + 20, (uint16_t)laz_ic_decode(&c->ic_source, &layer[P14_SOURCE].dec,
                                                   get_u16(last + 20), 0));
}

static int user_data(p14_context *c, laz_layer *layer)
{
    if (!layer[P14_USER].active)
        return 0;
    laz_sym *m = laz_lazy_model(&c->m_user[c->last[17] / 4], 256, c->epoch);
    if (!m)
        return -1;
    c->last[17] = (uint8_t)laz_dec_symbol(&layer[P14_USER].dec, m);
    return 0;
}

int laz_point14_decode(point14 *p, laz_layer *layer, uint8_t *out, const char **why)
{
    laz_dec *d = &layer[P14_XY].dec;
    p14_context *c = p->ctx[p->current];
    unsigned lr = c->last[14] & 15, ln = c->last[14] >> 4;
    unsigned lpr = (lr == 1) + 2u * (lr >= ln) + 4u * (unsigned)c->gps_change;
    uint32_t changed = laz_dec_symbol(d, &c->m_changed[lpr]);
    p->item = 0;
    if (changed & 64) {
        if (switch_channel(p, d))
            return -2;
        p->item = p->current;
    }
    c = p->ctx[p->current];
    if (returns(c, d, changed))
        return -2;
    int gps = (changed & 16) != 0;
    unsigned r = c->last[14] & 15, n = c->last[14] >> 4;
    unsigned cpr = (r == 1 ? 2u : 0u) + (r >= n);
    xy(c, d, n, laz_return_map14[n][r], gps);
    if (layer[P14_Z].active)
        z(c, &layer[P14_Z].dec, n, laz_return_level14(n, r));
    if (class_flags(c, layer, cpr))
        return -2;
    intensity_angle_source(c, layer, changed, cpr, gps);
    if (user_data(c, layer))
        return -2;
    if (layer[P14_GPS].active && gps &&
        laz_gpstime_decode(c->gps, &layer[P14_GPS].dec, c->last + 22, why))
        return -1;
    c->gps_change = gps;
    memcpy(out, c->last, 30);
    return 0;
}
