/* laz_items_enc.c - POINT10, GPSTIME11, RGB12 and BYTE item encoders,
 * version 2 (contract in laz_items.h). Each is the inverse of its decoder
 * in laz_items.c: it codes what that decoder reads, in the same order and
 * with the same models and contexts, and leaves the shared state
 * (laz_item_state.h) as the decoder will after reading the record. */
#include "io/laz/laz_item_state.h"

/* ---- POINT10 ---- */

/* Byte field f at offset off with the model chosen by its previous value. */
static int point10_byte(point10 *p, laz_enc *e, int f, int off, const uint8_t *rec,
                        uint32_t epoch)
{
    laz_sym *m = laz_point10_byte_model(p, f, p->last[off], epoch);
    if (!m)
        return -1;
    laz_enc_symbol(e, m, rec[off]);
    return 0;
}

/* Which fields other than x, y, z differ from the previous record: the
 * flags of point10_fields in laz_items.c. Intensity is compared with the
 * last intensity of the record's return context m. */
static uint32_t point10_changed(const point10 *p, const uint8_t *rec, unsigned m)
{
    const uint8_t *last = p->last;
    return (uint32_t)(last[14] != rec[14]) << 5 |
           (uint32_t)(p->last_intensity[m] != get_u16(rec + 12)) << 4 |
           (uint32_t)(last[15] != rec[15]) << 3 | (uint32_t)(last[16] != rec[16]) << 2 |
           (uint32_t)(last[17] != rec[17]) << 1 | (uint32_t)(get_u16(last + 18) != get_u16(rec + 18));
}

static int point10_fields(point10 *p, laz_enc *e, const uint8_t *rec, uint32_t changed,
                          unsigned m, uint32_t epoch)
{
    const uint8_t *last = p->last;
    if ((changed & 32) && point10_byte(p, e, BYTE_BITS, 14, rec, epoch))
        return -1;
    if (changed & 16) {
        uint16_t v = get_u16(rec + 12);
        laz_ic_encode(&p->ic_intensity, e, p->last_intensity[m], v, m < 3 ? m : 3);
        p->last_intensity[m] = v;
    }
    if ((changed & 8) && point10_byte(p, e, BYTE_CLASS, 15, rec, epoch))
        return -1;
    if (changed & 4) /* the model of the new scan direction */
        laz_enc_symbol(e, &p->m_scan_angle[(rec[14] >> 6) & 1], (uint8_t)(rec[16] - last[16]));
    if ((changed & 2) && point10_byte(p, e, BYTE_USER, 17, rec, epoch))
        return -1;
    if (changed & 1)
        laz_ic_encode(&p->ic_source, e, get_u16(last + 18), get_u16(rec + 18), 0);
    return 0;
}

/* x, y against the median of the last differences, z against the last z
 * of the return level (see point10_xyz in laz_items.c). */
static void point10_xyz(point10 *p, laz_enc *e, const uint8_t *rec, unsigned m, unsigned l,
                        uint32_t single)
{
    const uint8_t *last = p->last;
    int32_t diff = (int32_t)((uint32_t)get_i32(rec) - (uint32_t)get_i32(last));
    laz_ic_encode(&p->ic_dx, e, p->dx_median[m].v[2], diff, single);
    median5_add(&p->dx_median[m], diff);
    uint32_t k = p->ic_dx.k;
    diff = (int32_t)((uint32_t)get_i32(rec + 4) - (uint32_t)get_i32(last + 4));
    laz_ic_encode(&p->ic_dy, e, p->dy_median[m].v[2], diff, single + (k < 20 ? k & ~1u : 20));
    median5_add(&p->dy_median[m], diff);
    k = (p->ic_dx.k + p->ic_dy.k) / 2;
    int32_t z = get_i32(rec + 8);
    laz_ic_encode(&p->ic_z, e, p->last_height[l], z, single + (k < 18 ? k & ~1u : 18));
    p->last_height[l] = z;
}

static int point10_encode(point10 *p, laz_enc *e, const uint8_t *rec, uint32_t epoch)
{
    unsigned r = rec[14] & 7, n = (rec[14] >> 3) & 7;
    unsigned m = number_return_map[n][r], l = number_return_level[n][r];
    uint32_t changed = point10_changed(p, rec, m);
    laz_enc_symbol(e, &p->m_changed, changed);
    if (changed && point10_fields(p, e, rec, changed, m, epoch))
        return -1;
    point10_xyz(p, e, rec, m, l, n == 1);
    memcpy(p->last, rec, 20);
    return 0;
}

/* ---- GPSTIME11 ---- */

/* 1 when b - a (bit patterns of two doubles) fits a 32-bit difference. */
static int diff32(int64_t b, int64_t a, int32_t *diff)
{
    int64_t d = (int64_t)((uint64_t)b - (uint64_t)a);
    *diff = (int32_t)d;
    return d == (int64_t)*diff;
}

/* The slot (1..3 after the current one) of a sequence t continues, or 0. */
static uint32_t other_sequence(const gpstime *g, int64_t t)
{
    int32_t unused;
    for (uint32_t i = 1; i < 4; i++)
        if (diff32(t, g->last_time[(g->last + i) & 3], &unused))
            return i;
    return 0;
}

/* A time no sequence reaches with 32 bits: high half against the current
 * sequence's, low half raw; it opens a sequence in the next slot. */
static void gpstime_full(gpstime *g, laz_enc *e, int64_t t)
{
    uint64_t u = (uint64_t)t;
    laz_ic_encode(&g->ic, e, (int32_t)(uint32_t)((uint64_t)g->last_time[g->last] >> 32),
                  (int32_t)(uint32_t)(u >> 32), 8);
    laz_enc_u32(e, (uint32_t)u);
    g->next = (g->next + 1) & 3;
    g->last = g->next;
    g->last_diff[g->last] = 0;
    g->extreme_count[g->last] = 0;
}

/* multi = diff / last difference, rounded; kept within the symbol range
 * the coder distinguishes (beyond it only the sign matters). */
static int32_t gpstime_multi_of(int32_t diff, int32_t last)
{
    float ratio = (float)diff / (float)last;
    if (ratio >= GPS_MULTI)
        return GPS_MULTI;
    if (ratio <= GPS_MULTI_MINUS)
        return GPS_MULTI_MINUS;
    return ratio >= 0 ? (int32_t)(ratio + 0.5f) : (int32_t)(ratio - 0.5f);
}

/* A 32-bit difference when the last one was not 0 (gpstime_multi and the
 * multi == 1 case of gpstime_step in laz_items.c). */
static void gpstime_diff(gpstime *g, laz_enc *e, int32_t diff)
{
    int32_t last = g->last_diff[g->last];
    int32_t multi = gpstime_multi_of(diff, last);
    uint32_t pred = (uint32_t)multi * (uint32_t)last;
    int extreme = 0;
    if (multi == 1) {
        laz_enc_symbol(e, &g->m_multi, 1);
        laz_ic_encode(&g->ic, e, last, diff, 1);
        g->extreme_count[g->last] = 0;
    } else if (multi > 0) {
        extreme = multi == GPS_MULTI;
        laz_enc_symbol(e, &g->m_multi, (uint32_t)multi);
        laz_ic_encode(&g->ic, e, (int32_t)pred, diff, extreme ? 4 : multi < 10 ? 2 : 3);
    } else if (multi < 0) {
        extreme = multi == GPS_MULTI_MINUS;
        laz_enc_symbol(e, &g->m_multi, (uint32_t)(GPS_MULTI - multi));
        laz_ic_encode(&g->ic, e, (int32_t)pred, diff, extreme ? 6 : 5);
    } else {
        extreme = 1;
        laz_enc_symbol(e, &g->m_multi, 0);
        laz_ic_encode(&g->ic, e, 0, diff, 7);
    }
    if (extreme && ++g->extreme_count[g->last] > 3) {
        g->last_diff[g->last] = diff;
        g->extreme_count[g->last] = 0;
    }
}

/* One step of gpstime_step in laz_items.c, from the encoder's side.
 * Returns 1 after coding a switch to another sequence (t is then coded
 * again, in it), else 0. */
static int gpstime_step(gpstime *g, laz_enc *e, int64_t t)
{
    int zero = g->last_diff[g->last] == 0;
    laz_sym *m = zero ? &g->m_0diff : &g->m_multi;
    uint32_t v2 = !g->v3; /* version 2 codes "unchanged" first: the rest are one up */
    int32_t diff;
    if (v2 && t == g->last_time[g->last]) {
        laz_enc_symbol(e, m, zero ? 0 : GPS_MULTI_UNCHANGED);
        return 0;
    }
    if (diff32(t, g->last_time[g->last], &diff)) {
        if (zero) {
            laz_enc_symbol(e, m, v2);
            laz_ic_encode(&g->ic, e, 0, diff, 0);
            g->last_diff[g->last] = diff;
            g->extreme_count[g->last] = 0;
        } else {
            gpstime_diff(g, e, diff);
        }
    } else {
        uint32_t other = other_sequence(g, t);
        uint32_t full = zero ? 1 + v2 : GPS14_CODE_FULL + v2;
        laz_enc_symbol(e, m, full + other);
        if (other) {
            g->last = (g->last + other) & 3;
            return 1;
        }
        gpstime_full(g, e, t);
    }
    g->last_time[g->last] = t;
    return 0;
}

void laz_gpstime_encode(gpstime *g, laz_enc *e, const uint8_t *rec)
{
    int64_t t;
    memcpy(&t, rec, 8);
    /* After a switch the difference fits 32 bits: the second step ends. */
    while (gpstime_step(g, e, t))
        ;
}

/* ---- RGB12 ---- */

/* Low (shift 0) or high (shift 8) byte of v. */
static inline int byte_of(uint16_t v, int shift) { return (v >> shift) & 0xFF; }

/* Channels green and blue of rgb12_decode for one byte half: green against
 * the previous green moved by red's change, blue by the mean change of red
 * and green; bits gbit and bbit of used say which were coded. */
static void rgb12_half(rgb12 *c, laz_enc *e, const uint16_t *rgb, uint32_t used, int shift,
                       int gbit, int bbit)
{
    const uint16_t *last = c->last;
    int diff = byte_of(rgb[0], shift) - byte_of(last[0], shift);
    if (used & (1u << gbit)) {
        int corr = byte_of(rgb[1], shift) - clamp8(diff + byte_of(last[1], shift));
        laz_enc_symbol(e, &c->m_diff[gbit], (uint8_t)corr);
    }
    if (used & (1u << bbit)) {
        int dd = (diff + byte_of(rgb[1], shift) - byte_of(last[1], shift)) / 2;
        int corr = byte_of(rgb[2], shift) - clamp8(dd + byte_of(last[2], shift));
        laz_enc_symbol(e, &c->m_diff[bbit], (uint8_t)corr);
    }
}

void laz_rgb12_encode(rgb12 *c, laz_enc *e, const uint8_t *rec)
{
    uint16_t rgb[3];
    const uint16_t *last = c->last;
    for (int i = 0; i < 3; i++)
        rgb[i] = get_u16(rec + 2 * i);
    /* Bits 0-5: which bytes changed (red low, red high, green low, ...);
     * bit 6: the colour is not grey (green or blue differs from red). */
    uint32_t used = 0;
    for (int i = 0; i < 6; i++)
        used |= (uint32_t)(byte_of(rgb[i / 2], 8 * (i & 1)) !=
                           byte_of(last[i / 2], 8 * (i & 1))) << i;
    used |= (uint32_t)(rgb[1] != rgb[0] || rgb[2] != rgb[0]) << 6;
    laz_enc_symbol(e, &c->m_used, used);
    for (int i = 0; i < 2; i++)
        if (used & (1u << i))
            laz_enc_symbol(e, &c->m_diff[i],
                           (uint8_t)(byte_of(rgb[0], 8 * i) - byte_of(last[0], 8 * i)));
    if (used & (1u << 6)) {
        rgb12_half(c, e, rgb, used, 0, 2, 4);
        rgb12_half(c, e, rgb, used, 8, 3, 5);
    }
    memcpy(c->last, rgb, sizeof rgb);
}

/* ---- BYTE (extra bytes) ---- */

static void bytes_encode(bytes *b, laz_enc *e, const uint8_t *rec)
{
    for (uint32_t i = 0; i < b->n; i++)
        laz_enc_symbol(e, &b->m[i], (uint8_t)(rec[i] - b->last[i]));
    memcpy(b->last, rec, b->n);
}

/* ---- the chain ---- */

int laz_items_encode(laz_items *it, laz_enc *e, const uint8_t *rec)
{
    for (uint32_t i = 0; i < it->n; i++) {
        item *x = &it->it[i];
        const uint8_t *p = rec + x->offset;
        switch (x->type) {
        case LAZ_ITEM_POINT10:
            if (point10_encode(x->u.p, e, p, it->epoch))
                return -1;
            break;
        case LAZ_ITEM_GPSTIME11: laz_gpstime_encode(x->u.g, e, p); break;
        case LAZ_ITEM_RGB12: laz_rgb12_encode(x->u.c, e, p); break;
        default: bytes_encode(x->u.b, e, p); break;
        }
    }
    return 0;
}
