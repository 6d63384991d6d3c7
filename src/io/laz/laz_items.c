/* laz_items.c - POINT10, GPSTIME11, RGB12 and BYTE item decoders, version
 * 2 (contracts in laz_items.h). Each follows the item's description in the
 * LAZ specification: which fields are predicted from what, and which
 * model or context codes the difference. */
#include "io/laz/laz_item_state.h"

#include <stdlib.h>
#include <string.h>

/* ---- POINT10 ---- */

static void point10_free(point10 *p)
{
    if (!p)
        return;
    laz_sym_free(&p->m_changed);
    laz_sym_free(&p->m_scan_angle[0]);
    laz_sym_free(&p->m_scan_angle[1]);
    for (int f = 0; f < BYTE_FIELDS; f++) {
        if (p->m_byte[f])
            for (int i = 0; i < 256; i++)
                laz_sym_free(&p->m_byte[f][i]);
        free(p->m_byte[f]);
        free(p->stamp[f]);
    }
    laz_ic_free(&p->ic_intensity);
    laz_ic_free(&p->ic_source);
    laz_ic_free(&p->ic_dx);
    laz_ic_free(&p->ic_dy);
    laz_ic_free(&p->ic_z);
    free(p);
}

/* Context counts of the integer decompressors: intensity by return class
 * (4), dx by single return (2), dy and z also by the k of the previous
 * coordinate (22, 20). */
static point10 *point10_create(void)
{
    point10 *p = calloc(1, sizeof *p);
    if (!p)
        return NULL;
    int bad = laz_sym_create(&p->m_changed, 64) || laz_sym_create(&p->m_scan_angle[0], 256) ||
              laz_sym_create(&p->m_scan_angle[1], 256) ||
              laz_ic_create(&p->ic_intensity, 16, 4) || laz_ic_create(&p->ic_source, 16, 1) ||
              laz_ic_create(&p->ic_dx, 32, 2) || laz_ic_create(&p->ic_dy, 32, 22) ||
              laz_ic_create(&p->ic_z, 32, 20);
    for (int f = 0; f < BYTE_FIELDS && !bad; f++) {
        p->m_byte[f] = calloc(256, sizeof *p->m_byte[f]);
        p->stamp[f] = calloc(256, sizeof *p->stamp[f]);
        bad = !p->m_byte[f] || !p->stamp[f];
    }
    if (bad) {
        point10_free(p);
        return NULL;
    }
    return p;
}

static void point10_start(point10 *p, const uint8_t *rec)
{
    for (int i = 0; i < 16; i++) {
        median5_init(&p->dx_median[i]);
        median5_init(&p->dy_median[i]);
        p->last_intensity[i] = 0;
    }
    memset(p->last_height, 0, sizeof p->last_height);
    laz_sym_reset(&p->m_changed);
    laz_sym_reset(&p->m_scan_angle[0]);
    laz_sym_reset(&p->m_scan_angle[1]);
    laz_ic_reset(&p->ic_intensity);
    laz_ic_reset(&p->ic_source);
    laz_ic_reset(&p->ic_dx);
    laz_ic_reset(&p->ic_dy);
    laz_ic_reset(&p->ic_z);
    memcpy(p->last, rec, 20);
}

laz_sym *laz_point10_byte_model(point10 *p, int f, uint8_t prev, uint32_t epoch)
{
    laz_sym *m = &p->m_byte[f][prev];
    if (!m->distribution) {
        if (laz_sym_create(m, 256))
            return NULL;
        p->stamp[f][prev] = epoch;
    } else if (p->stamp[f][prev] != epoch) {
        laz_sym_reset(m);
        p->stamp[f][prev] = epoch;
    }
    return m;
}

/* Decodes byte field f (at byte off of the record) with the model chosen
 * by its previous value. Returns -1 if the model cannot be allocated. */
static int point10_byte(point10 *p, laz_dec *d, int f, int off, uint32_t epoch)
{
    laz_sym *m = laz_point10_byte_model(p, f, p->last[off], epoch);
    if (!m)
        return -1;
    p->last[off] = (uint8_t)laz_dec_symbol(d, m);
    return 0;
}

/* The fields other than x, y, z, flagged in changed (bit 5 the return
 * byte, 4 intensity, 3 classification, 2 scan angle, 1 user data,
 * 0 point source). m is the return context of the new return byte. */
static int point10_fields(point10 *p, laz_dec *d, uint32_t changed, uint32_t epoch)
{
    uint8_t *last = p->last;
    if ((changed & 32) && point10_byte(p, d, BYTE_BITS, 14, epoch))
        return -1;
    unsigned r = last[14] & 7, n = (last[14] >> 3) & 7, m = number_return_map[n][r];
    if (changed & 16) {
        uint16_t v = (uint16_t)laz_ic_decode(&p->ic_intensity, d, p->last_intensity[m],
                                             m < 3 ? m : 3);
        p->last_intensity[m] = v;
    }
    put_u16(last + 12, p->last_intensity[m]);
    if ((changed & 8) && point10_byte(p, d, BYTE_CLASS, 15, epoch))
        return -1;
    if (changed & 4) {
        uint32_t v = laz_dec_symbol(d, &p->m_scan_angle[(last[14] >> 6) & 1]);
        last[16] = fold8((int)v + last[16]);
    }
    if ((changed & 2) && point10_byte(p, d, BYTE_USER, 17, epoch))
        return -1;
    if (changed & 1)
        put_u16(last + 18, (uint16_t)laz_ic_decode(&p->ic_source, d, get_u16(last + 18), 0));
    return 0;
}

/* x and y: the difference to the previous point, predicted by the median
 * of the last five differences of the same return context; z: predicted
 * by the last z of the same return level. The k (magnitude) of the x
 * correction picks the y context, the mean k of both the z context. */
static void point10_xyz(point10 *p, laz_dec *d)
{
    uint8_t *last = p->last;
    unsigned r = last[14] & 7, n = (last[14] >> 3) & 7;
    unsigned m = number_return_map[n][r], l = number_return_level[n][r];
    uint32_t single = n == 1;
    int32_t diff = laz_ic_decode(&p->ic_dx, d, p->dx_median[m].v[2], single);
    put_i32(last, (int32_t)((uint32_t)get_i32(last) + (uint32_t)diff));
    median5_add(&p->dx_median[m], diff);
    uint32_t k = p->ic_dx.k;
    diff = laz_ic_decode(&p->ic_dy, d, p->dy_median[m].v[2], single + (k < 20 ? k & ~1u : 20));
    put_i32(last + 4, (int32_t)((uint32_t)get_i32(last + 4) + (uint32_t)diff));
    median5_add(&p->dy_median[m], diff);
    k = (p->ic_dx.k + p->ic_dy.k) / 2;
    int32_t z = laz_ic_decode(&p->ic_z, d, p->last_height[l], single + (k < 18 ? k & ~1u : 18));
    put_i32(last + 8, z);
    p->last_height[l] = z;
}

static int point10_decode(point10 *p, laz_dec *d, uint8_t *out, uint32_t epoch)
{
    uint32_t changed = laz_dec_symbol(d, &p->m_changed);
    if (changed) {
        if (point10_fields(p, d, changed, epoch))
            return -1;
    } else {
        unsigned r = p->last[14] & 7, n = (p->last[14] >> 3) & 7;
        put_u16(p->last + 12, p->last_intensity[number_return_map[n][r]]);
    }
    point10_xyz(p, d);
    memcpy(out, p->last, 20);
    return 0;
}

/* ---- GPSTIME11 ---- */

void laz_gpstime_free(gpstime *g)
{
    if (!g)
        return;
    laz_sym_free(&g->m_multi);
    laz_sym_free(&g->m_0diff);
    laz_ic_free(&g->ic);
    free(g);
}

gpstime *laz_gpstime_create(int v3)
{
    gpstime *g = calloc(1, sizeof *g);
    if (g)
        g->v3 = v3;
    if (g && (laz_sym_create(&g->m_multi, v3 ? GPS14_TOTAL : GPS_MULTI_TOTAL) ||
              laz_sym_create(&g->m_0diff, v3 ? 5 : 6) || laz_ic_create(&g->ic, 32, 9))) {
        laz_gpstime_free(g);
        return NULL;
    }
    return g;
}

void laz_gpstime_start(gpstime *g, const uint8_t *rec)
{
    g->last = g->next = 0;
    memset(g->last_diff, 0, sizeof g->last_diff);
    memset(g->extreme_count, 0, sizeof g->extreme_count);
    memset(g->last_time, 0, sizeof g->last_time);
    memcpy(&g->last_time[0], rec, 8);
    laz_sym_reset(&g->m_multi);
    laz_sym_reset(&g->m_0diff);
    laz_ic_reset(&g->ic);
}

/* A time that does not fit a 32-bit difference: its high 32 bits
 * predicted by the current sequence's, the low 32 raw. Opens a new
 * sequence in the next of the four slots. */
void laz_gpstime_full(gpstime *g, laz_dec *d)
{
    g->next = (g->next + 1) & 3;
    uint32_t high = (uint32_t)laz_ic_decode(&g->ic, d,
                                            (int32_t)(uint32_t)((uint64_t)g->last_time[g->last] >> 32), 8);
    uint64_t t = ((uint64_t)high << 32) | laz_dec_u32(d);
    g->last = g->next;
    g->last_time[g->last] = (int64_t)t;
    g->last_diff[g->last] = 0;
    g->extreme_count[g->last] = 0;
}

void laz_gpstime_add(gpstime *g, int32_t diff)
{
    g->last_time[g->last] = (int64_t)((uint64_t)g->last_time[g->last] + (uint64_t)(int64_t)diff);
}

/* A difference coded against multi times the last difference (multi in
 * 0..510 of the symbol): 0 and the extremes also count towards replacing
 * the last difference after four in a row, as the encoder does. */
void laz_gpstime_multi(gpstime *g, laz_dec *d, int32_t multi)
{
    int32_t last = g->last_diff[g->last], diff;
    int extreme = 0;
    if (multi == 0) {
        diff = laz_ic_decode(&g->ic, d, 0, 7);
        extreme = 1;
    } else if (multi < GPS_MULTI) {
        diff = laz_ic_decode(&g->ic, d, (int32_t)((uint32_t)multi * (uint32_t)last),
                             multi < 10 ? 2 : 3);
    } else if (multi == GPS_MULTI) {
        diff = laz_ic_decode(&g->ic, d, (int32_t)((uint32_t)GPS_MULTI * (uint32_t)last), 4);
        extreme = 1;
    } else {
        multi = GPS_MULTI - multi;
        if (multi > GPS_MULTI_MINUS) {
            diff = laz_ic_decode(&g->ic, d, (int32_t)((uint32_t)multi * (uint32_t)last), 5);
        } else {
            diff = laz_ic_decode(&g->ic, d,
                                 (int32_t)((uint32_t)GPS_MULTI_MINUS * (uint32_t)last), 6);
            extreme = 1;
        }
    }
    if (extreme && ++g->extreme_count[g->last] > 3) {
        g->last_diff[g->last] = diff;
        g->extreme_count[g->last] = 0;
    }
    laz_gpstime_add(g, diff);
}

/* One step; returns 1 when the stream switched sequence and the time
 * follows (the encoder codes the switch, then the time in the new
 * sequence), else 0. Version 2 has an "unchanged" code in both models;
 * version 3 does not (POINT14 flags a changed time itself), so its other
 * codes are one lower. */
static int gpstime_step(gpstime *g, laz_dec *d)
{
    if (g->last_diff[g->last] == 0) {
        uint32_t multi = laz_dec_symbol(d, &g->m_0diff);
        if (!g->v3 && multi-- == 0)
            return 0;
        if (multi == 0) {
            int32_t diff = laz_ic_decode(&g->ic, d, 0, 0);
            g->last_diff[g->last] = diff;
            laz_gpstime_add(g, diff);
            g->extreme_count[g->last] = 0;
        } else if (multi == 1) {
            laz_gpstime_full(g, d);
        } else {
            g->last = (g->last + multi - 1) & 3;
            return 1;
        }
        return 0;
    }
    uint32_t multi = laz_dec_symbol(d, &g->m_multi);
    uint32_t full = g->v3 ? GPS14_CODE_FULL : GPS_MULTI_CODE_FULL;
    if (multi == 1) {
        laz_gpstime_add(g, laz_ic_decode(&g->ic, d, g->last_diff[g->last], 1));
        g->extreme_count[g->last] = 0;
    } else if (multi < GPS_MULTI_UNCHANGED) {
        laz_gpstime_multi(g, d, (int32_t)multi);
    } else if (multi == full) {
        laz_gpstime_full(g, d);
    } else if (multi > full) {
        g->last = (g->last + multi - full) & 3;
        return 1;
    }
    return 0;
}

int laz_gpstime_decode(gpstime *g, laz_dec *d, uint8_t *out, const char **why)
{
    /* A valid stream switches at most once per point; a few more are
     * allowed, then the stream is taken as corrupt rather than looping. */
    int steps = 0;
    while (gpstime_step(g, d))
        if (++steps > 4) {
            *why = "GPS time sequence switches without end";
            return -1;
        }
    memcpy(out, &g->last_time[g->last], 8);
    return 0;
}

/* ---- RGB12 ---- */

void laz_rgb12_free(rgb12 *c)
{
    if (!c)
        return;
    laz_sym_free(&c->m_used);
    for (int i = 0; i < 6; i++)
        laz_sym_free(&c->m_diff[i]);
    free(c);
}

rgb12 *laz_rgb12_create(void)
{
    rgb12 *c = calloc(1, sizeof *c);
    int bad = !c || laz_sym_create(&c->m_used, 128);
    for (int i = 0; i < 6 && !bad; i++)
        bad = laz_sym_create(&c->m_diff[i], 256);
    if (bad) {
        laz_rgb12_free(c);
        return NULL;
    }
    return c;
}

void laz_rgb12_start(rgb12 *c, const uint8_t *rec)
{
    laz_sym_reset(&c->m_used);
    for (int i = 0; i < 6; i++)
        laz_sym_reset(&c->m_diff[i]);
    for (int i = 0; i < 3; i++)
        c->last[i] = get_u16(rec + 2 * i);
}

/* One byte (shift 0: low, 8: high) of channel ch when flag bit is set in
 * used: decoded as a difference to pred; else the previous value. */
static unsigned rgb12_byte(rgb12 *c, laz_dec *d, uint32_t used, int bit, int ch, int shift,
                           int pred)
{
    if (!(used & (1u << bit)))
        return (c->last[ch] >> shift) & 0xFF;
    return fold8((int)laz_dec_symbol(d, &c->m_diff[bit]) + pred);
}

/* Red is coded against the previous red; green and blue (flag bit 6:
 * not grey) against the previous value moved by red's change, blue by the
 * mean of red's and green's change, each clamped to a byte. */
void laz_rgb12_decode(rgb12 *c, laz_dec *d, uint8_t *out)
{
    uint16_t *last = c->last;
    uint32_t used = laz_dec_symbol(d, &c->m_used);
    unsigned rl = rgb12_byte(c, d, used, 0, 0, 0, last[0] & 0xFF);
    unsigned rh = rgb12_byte(c, d, used, 1, 0, 8, last[0] >> 8);
    uint16_t rgb[3];
    rgb[0] = (uint16_t)(rl | rh << 8);
    if (used & (1u << 6)) {
        int diff = (int)rl - (last[0] & 0xFF);
        unsigned gl = rgb12_byte(c, d, used, 2, 1, 0, clamp8(diff + (last[1] & 0xFF)));
        unsigned bl = 0;
        if (used & (1u << 4)) {
            int dd = (diff + ((int)gl - (last[1] & 0xFF))) / 2;
            bl = rgb12_byte(c, d, used, 4, 2, 0, clamp8(dd + (last[2] & 0xFF)));
        } else {
            bl = last[2] & 0xFF;
        }
        diff = (int)rh - (last[0] >> 8);
        unsigned gh = rgb12_byte(c, d, used, 3, 1, 8, clamp8(diff + (last[1] >> 8)));
        unsigned bh = 0;
        if (used & (1u << 5)) {
            int dd = (diff + ((int)gh - (last[1] >> 8))) / 2;
            bh = rgb12_byte(c, d, used, 5, 2, 8, clamp8(dd + (last[2] >> 8)));
        } else {
            bh = last[2] >> 8;
        }
        rgb[1] = (uint16_t)(gl | gh << 8);
        rgb[2] = (uint16_t)(bl | bh << 8);
    } else {
        rgb[1] = rgb[2] = rgb[0];
    }
    memcpy(last, rgb, sizeof rgb);
    for (int i = 0; i < 3; i++)
        put_u16(out + 2 * i, rgb[i]);
}

/* ---- BYTE (extra bytes) ---- */

void laz_bytes_free(bytes *b)
{
    if (!b)
        return;
    if (b->m)
        for (uint32_t i = 0; i < b->n; i++)
            laz_sym_free(&b->m[i]);
    free(b->m);
    free(b->last);
    free(b);
}

bytes *laz_bytes_create(uint32_t n)
{
    bytes *b = calloc(1, sizeof *b);
    if (!b)
        return NULL;
    b->n = n;
    b->last = malloc(n ? n : 1);
    b->m = calloc(n ? n : 1, sizeof *b->m);
    int bad = !b->last || !b->m;
    for (uint32_t i = 0; i < n && !bad; i++)
        bad = laz_sym_create(&b->m[i], 256);
    if (bad) {
        laz_bytes_free(b);
        return NULL;
    }
    return b;
}

static void bytes_start(bytes *b, const uint8_t *rec)
{
    for (uint32_t i = 0; i < b->n; i++)
        laz_sym_reset(&b->m[i]);
    memcpy(b->last, rec, b->n);
}

/* Each byte: the difference to the same byte of the previous record,
 * modulo 256, one model per byte position. */
static void bytes_decode(bytes *b, laz_dec *d, uint8_t *out)
{
    for (uint32_t i = 0; i < b->n; i++)
        b->last[i] = fold8(b->last[i] + (int)laz_dec_symbol(d, &b->m[i]));
    memcpy(out, b->last, b->n);
}

/* ---- the chain ---- */

void laz_items_free(laz_items *it)
{
    if (!it)
        return;
    for (uint32_t i = 0; i < it->n; i++) {
        item *x = &it->it[i];
        switch (x->type) {
        case LAZ_ITEM_POINT10: point10_free(x->u.p); break;
        case LAZ_ITEM_GPSTIME11: laz_gpstime_free(x->u.g); break;
        case LAZ_ITEM_RGB12: laz_rgb12_free(x->u.c); break;
        default: laz_bytes_free(x->u.b); break;
        }
    }
    free(it);
}

laz_items *laz_items_create(const wpd_laz_item *list, uint32_t n)
{
    laz_items *it = calloc(1, sizeof *it);
    if (!it || n > WPD_LAZ_MAX_ITEMS) {
        free(it);
        return NULL;
    }
    uint32_t off = 0;
    for (uint32_t i = 0; i < n; i++) {
        item *x = &it->it[i];
        x->type = list[i].type;
        x->offset = off;
        off += list[i].size;
        void *made;
        switch (x->type) {
        case LAZ_ITEM_POINT10: made = x->u.p = point10_create(); break;
        case LAZ_ITEM_GPSTIME11: made = x->u.g = laz_gpstime_create(0); break;
        case LAZ_ITEM_RGB12: made = x->u.c = laz_rgb12_create(); break;
        default: made = x->u.b = laz_bytes_create(list[i].size); break;
        }
        it->n = i + 1;
        if (!made) {
            laz_items_free(it);
            return NULL;
        }
    }
    return it;
}

void laz_items_start(laz_items *it, const uint8_t *rec)
{
    it->epoch++;
    for (uint32_t i = 0; i < it->n; i++) {
        item *x = &it->it[i];
        const uint8_t *p = rec + x->offset;
        switch (x->type) {
        case LAZ_ITEM_POINT10: point10_start(x->u.p, p); break;
        case LAZ_ITEM_GPSTIME11: laz_gpstime_start(x->u.g, p); break;
        case LAZ_ITEM_RGB12: laz_rgb12_start(x->u.c, p); break;
        default: bytes_start(x->u.b, p); break;
        }
    }
}

int laz_items_decode(laz_items *it, laz_dec *d, uint8_t *rec, const char **why)
{
    for (uint32_t i = 0; i < it->n; i++) {
        item *x = &it->it[i];
        uint8_t *p = rec + x->offset;
        switch (x->type) {
        case LAZ_ITEM_POINT10:
            if (point10_decode(x->u.p, d, p, it->epoch))
                return -2;
            break;
        case LAZ_ITEM_GPSTIME11:
            if (laz_gpstime_decode(x->u.g, d, p, why))
                return -1;
            break;
        case LAZ_ITEM_RGB12: laz_rgb12_decode(x->u.c, d, p); break;
        default: bytes_decode(x->u.b, d, p); break;
        }
    }
    return 0;
}
