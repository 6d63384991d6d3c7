/* laz_point14_enc.c - the POINT14 v3 encoder: the inverse of
 * laz_point14_decode (laz_point14.c). It codes what that decoder reads,
 * layer by layer, with the same models and contexts, leaves the shared
 * state as the decoder will, and marks each layer whose field differs
 * from the predecessor's at least once in the chunk (layer->changed): the
 * others are written empty, which a decoder reads as "never changes".
 */
#include "io/laz/laz_layered_state.h"

#include <string.h>

static int16_t get_i16(const uint8_t *p)
{
    int16_t v;
    memcpy(&v, p, 2);
    return v;
}

/* Whether the GPS time at a differs from the one at b. LASzip compares
 * them as doubles, so a NaN always counts as changed (it is then coded as
 * a difference of 0, which we must code too for the same bytes); it would
 * also take -0.0 after 0.0 as unchanged and lose the sign, so bits that
 * differ count as changed as well (the one case where our bytes differ,
 * both readable). */
static int gps_differs(const uint8_t *a, const uint8_t *b)
{
    double x, y;
    memcpy(&x, a, 8);
    memcpy(&y, b, 8);
    return x != y || memcmp(a, b, 8) != 0;
}

/* The change bits of the XY layer's symbol (see laz_point14.c), rec
 * against last, the predecessor of the same scanner channel. */
static uint32_t changes(const uint8_t *last, const uint8_t *rec, int channel_changed)
{
    unsigned lr = last[14] & 15, r = rec[14] & 15;
    uint32_t ret = r == lr ? 0 : r == ((lr + 1) & 15) ? 1 : r == ((lr + 15) & 15) ? 2 : 3;
    return (uint32_t)channel_changed << 6 | (uint32_t)(get_u16(rec + 20) != get_u16(last + 20)) << 5 |
           (uint32_t)gps_differs(rec + 22, last + 22) << 4 |
           (uint32_t)(get_i16(rec + 18) != get_i16(last + 18)) << 3 |
           (uint32_t)((rec[14] >> 4) != (last[14] >> 4)) << 2 | ret;
}

/* Number of returns and return number, as returns() decodes them. */
static int returns(p14_context *c, laz_enc *e, const uint8_t *rec, uint32_t changed)
{
    unsigned lr = c->last[14] & 15, ln = c->last[14] >> 4;
    unsigned r = rec[14] & 15, n = rec[14] >> 4;
    if (changed & 4) {
        laz_sym *m = laz_lazy_model(&c->m_nreturns[ln], 16, c->epoch);
        if (!m)
            return -1;
        laz_enc_symbol(e, m, n);
    }
    if ((changed & 3) == 3) {
        if (changed & 16) {
            laz_sym *m = laz_lazy_model(&c->m_return[lr], 16, c->epoch);
            if (!m)
                return -1;
            laz_enc_symbol(e, m, r);
        } else {
            laz_enc_symbol(e, &c->m_return_gps_same, (r - lr - 2) & 15);
        }
    }
    c->last[14] = rec[14];
    return 0;
}

static void xy(p14_context *c, laz_enc *e, const uint8_t *rec, unsigned n, unsigned m, int gps)
{
    unsigned i = m << 1 | (unsigned)gps;
    int32_t diff = (int32_t)((uint32_t)get_i32(rec) - (uint32_t)get_i32(c->last));
    laz_ic_encode(&c->ic_dx, e, c->dx[i].v[2], diff, n == 1);
    median5_add(&c->dx[i], diff);
    uint32_t k = c->ic_dx.k;
    diff = (int32_t)((uint32_t)get_i32(rec + 4) - (uint32_t)get_i32(c->last + 4));
    laz_ic_encode(&c->ic_dy, e, c->dy[i].v[2], diff, (n == 1) + (k < 20 ? k & ~1u : 20));
    median5_add(&c->dy[i], diff);
    memcpy(c->last, rec, 8);
}

static void z(p14_context *c, laz_layer *y, const uint8_t *rec, unsigned n, unsigned l)
{
    uint32_t k = (c->ic_dx.k + c->ic_dy.k) / 2;
    int32_t v = get_i32(rec + 8);
    laz_ic_encode(&c->ic_z, &y->enc, c->last_z[l], v, (n == 1) + (k < 18 ? k & ~1u : 18));
    c->last_z[l] = v;
}

static int class_flags(p14_context *c, laz_layer *layer, const uint8_t *rec, unsigned cpr)
{
    uint8_t *last = c->last;
    laz_sym *m = laz_lazy_model(&c->m_class[((last[16] & 0x1Fu) << 1) + (cpr == 3)], 256,
                                c->epoch);
    if (!m)
        return -1;
    laz_enc_symbol(&layer[P14_CLASS].enc, m, rec[16]);
    layer[P14_CLASS].changed |= rec[16] != last[16];
    unsigned b = last[15], prev = (b >> 7) << 5 | ((b >> 6) & 1) << 4 | (b & 15);
    unsigned f = rec[15], now = (f >> 7) << 5 | ((f >> 6) & 1) << 4 | (f & 15);
    if (!(m = laz_lazy_model(&c->m_flags[prev], 64, c->epoch)))
        return -1;
    laz_enc_symbol(&layer[P14_FLAGS].enc, m, now);
    layer[P14_FLAGS].changed |= now != prev;
    return 0;
}

static void intensity_angle_source(p14_context *c, laz_layer *layer, const uint8_t *rec,
                                   uint32_t changed, unsigned cpr, int gps)
{
    unsigned i = cpr << 1 | (unsigned)gps;
    uint16_t v = get_u16(rec + 12);
    laz_ic_encode(&c->ic_intensity, &layer[P14_INTENSITY].enc, c->last_intensity[i], v, cpr);
    layer[P14_INTENSITY].changed |= v != get_u16(c->last + 12);
    c->last_intensity[i] = v;
    if (changed & 8) {
        laz_ic_encode(&c->ic_scan, &layer[P14_SCAN].enc, get_i16(c->last + 18),
                      get_i16(rec + 18), gps != 0);
        layer[P14_SCAN].changed = 1;
    }
    if (changed & 32) {
        laz_ic_encode(&c->ic_source, &layer[P14_SOURCE].enc, get_u16(c->last + 20),
                      get_u16(rec + 20), 0);
        layer[P14_SOURCE].changed = 1;
    }
}

static int user_data(p14_context *c, laz_layer *layer, const uint8_t *rec)
{
    laz_sym *m = laz_lazy_model(&c->m_user[c->last[17] / 4], 256, c->epoch);
    if (!m)
        return -1;
    laz_enc_symbol(&layer[P14_USER].enc, m, rec[17]);
    layer[P14_USER].changed |= rec[17] != c->last[17];
    return 0;
}

/* Encodes rec (30 bytes) into the 9 layers. Returns 0 or -1 if a model
 * cannot be allocated. */
int laz_point14_encode(point14 *p, laz_layer *layer, const uint8_t *rec)
{
    laz_enc *e = &layer[P14_XY].enc;
    p14_context *c = p->ctx[p->current];
    unsigned lr = c->last[14] & 15, ln = c->last[14] >> 4;
    unsigned lpr = (lr == 1) + 2u * (lr >= ln) + 4u * (unsigned)c->gps_change;
    unsigned ch = (rec[15] >> 4) & 3;
    /* A new channel's context starts from this one's last point, as the
     * decoder will start it: the changes are against that. */
    if (ch != p->current && !(p->used & (1u << ch)) && laz_point14_context(p, ch, c->last))
        return -1;
    uint32_t changed = changes(p->ctx[ch]->last, rec, ch != p->current);
    laz_enc_symbol(e, &c->m_changed[lpr], changed);
    p->item = 0;
    if (changed & 64) {
        laz_enc_symbol(e, &c->m_channel, (ch - p->current - 1) & 3);
        p->item = p->current = ch;
    }
    c = p->ctx[ch];
    if (returns(c, e, rec, changed))
        return -1;
    int gps = (changed & 16) != 0;
    unsigned r = rec[14] & 15, n = rec[14] >> 4, cpr = (r == 1 ? 2u : 0u) + (r >= n);
    xy(c, e, rec, n, laz_return_map14[n][r], gps);
    z(c, &layer[P14_Z], rec, n, laz_return_level14(n, r));
    if (class_flags(c, layer, rec, cpr))
        return -1;
    intensity_angle_source(c, layer, rec, changed, cpr, gps);
    if (user_data(c, layer, rec))
        return -1;
    if (gps) {
        laz_gpstime_encode(c->gps, &layer[P14_GPS].enc, rec + 22);
        layer[P14_GPS].changed = 1;
    }
    c->gps_change = gps;
    memcpy(c->last, rec, 30);
    return 0;
}
