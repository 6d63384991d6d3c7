/* laz_item_state.h - the state the item coders of the LAZ point-wise
 * compressor keep between records (previous values, medians, models), and
 * the small helpers both directions use. The decoders (laz_items.c) and
 * the encoders (laz_items_enc.c) share it: an encoder must update exactly
 * the state its decoder will, so it is defined once. Not for use outside
 * src/io.
 */
#ifndef WPD_LAZ_ITEM_STATE_H
#define WPD_LAZ_ITEM_STATE_H

#include <string.h>

#include "io/laz/laz_items.h"

/* ---- helpers ---- */

/* Byte arithmetic of the item coders: a difference is added modulo 256
 * (fold), a prediction is clamped to the byte range (clamp). */
static inline uint8_t fold8(int v) { return (uint8_t)(v < 0 ? v + 256 : v > 255 ? v - 256 : v); }
static inline int clamp8(int v) { return v <= 0 ? 0 : v >= 255 ? 255 : v; }

static inline int32_t get_i32(const uint8_t *p) { int32_t v; memcpy(&v, p, 4); return v; }
static inline void put_i32(uint8_t *p, int32_t v) { memcpy(p, &v, 4); }
static inline uint16_t get_u16(const uint8_t *p) { uint16_t v; memcpy(&v, p, 2); return v; }
static inline void put_u16(uint8_t *p, uint16_t v) { memcpy(p, &v, 2); }

/* Median of the last five values, kept incrementally: LASzip's predictor
 * of the x and y differences. high says on which side the next value
 * replaces an end, so the window ages symmetrically. */
typedef struct median5 {
    int32_t v[5];
    int high;
} median5;

static inline void median5_init(median5 *m)
{
    memset(m->v, 0, sizeof m->v);
    m->high = 1;
}

static inline void median5_add(median5 *m, int32_t x)
{
    int32_t *v = m->v;
    if (m->high) {
        if (x < v[2]) {
            v[4] = v[3], v[3] = v[2];
            if (x < v[0])
                v[2] = v[1], v[1] = v[0], v[0] = x;
            else if (x < v[1])
                v[2] = v[1], v[1] = x;
            else
                v[2] = x;
        } else {
            if (x < v[3])
                v[4] = v[3], v[3] = x;
            else
                v[4] = x;
            m->high = 0;
        }
    } else {
        if (v[2] < x) {
            v[0] = v[1], v[1] = v[2];
            if (v[4] < x)
                v[2] = v[3], v[3] = v[4], v[4] = x;
            else if (v[3] < x)
                v[2] = v[3], v[3] = x;
            else
                v[2] = x;
        } else {
            if (v[1] < x)
                v[0] = v[1], v[1] = x;
            else
                v[0] = x;
            m->high = 1;
        }
    }
}

/* Contexts by return: number_return_map[n][r] separates the 16 usual
 * (number of returns, return number) pairs, odd ones folded in;
 * number_return_level[n][r] = |n - r| groups returns by depth below the
 * first, for the z prediction. Tables of the specification. */
static const uint8_t number_return_map[8][8] = {
    {15, 14, 13, 12, 11, 10, 9, 8}, {14, 0, 1, 3, 6, 10, 10, 9},
    {13, 1, 2, 4, 7, 11, 11, 10},   {12, 3, 4, 5, 8, 12, 12, 11},
    {11, 6, 7, 8, 9, 13, 13, 12},   {10, 10, 11, 12, 13, 14, 14, 13},
    {9, 10, 11, 12, 13, 14, 15, 14}, {8, 9, 10, 11, 12, 13, 14, 15},
};
static const uint8_t number_return_level[8][8] = {
    {0, 1, 2, 3, 4, 5, 6, 7}, {1, 0, 1, 2, 3, 4, 5, 6}, {2, 1, 0, 1, 2, 3, 4, 5},
    {3, 2, 1, 0, 1, 2, 3, 4}, {4, 3, 2, 1, 0, 1, 2, 3}, {5, 4, 3, 2, 1, 0, 1, 2},
    {6, 5, 4, 3, 2, 1, 0, 1}, {7, 6, 5, 4, 3, 2, 1, 0},
};

/* ---- state ---- */

/* Byte fields of POINT10 coded with one 256-symbol model per previous
 * value. Most files use a handful of values, so models are made on first
 * use and reset on first use in each chunk (stamp != epoch), which is the
 * same as resetting all at the chunk start. */
enum { BYTE_BITS, BYTE_CLASS, BYTE_USER, BYTE_FIELDS };

typedef struct point10 {
    uint8_t last[20];
    uint16_t last_intensity[16];
    median5 dx_median[16], dy_median[16];
    int32_t last_height[8];
    laz_sym m_changed, m_scan_angle[2];
    laz_sym *m_byte[BYTE_FIELDS];       /* [256] each, made lazily */
    uint32_t *stamp[BYTE_FIELDS];       /* [256]: epoch of the last reset */
    laz_ic ic_intensity, ic_source, ic_dx, ic_dy, ic_z;
} point10;

/* GPS time: up to four interleaved sequences (flight lines that alternate
 * within a chunk), each with its last time and last integer difference. */
enum {
    GPS_MULTI = 500, GPS_MULTI_MINUS = -10,
    GPS_MULTI_UNCHANGED = GPS_MULTI - GPS_MULTI_MINUS + 1, /* 511 */
    GPS_MULTI_CODE_FULL = GPS_MULTI - GPS_MULTI_MINUS + 2, /* 512 */
    GPS_MULTI_TOTAL = GPS_MULTI - GPS_MULTI_MINUS + 6,     /* 516 */
    /* version 3: no "unchanged" code */
    GPS14_CODE_FULL = GPS_MULTI - GPS_MULTI_MINUS + 1,    /* 511 */
    GPS14_TOTAL = GPS_MULTI - GPS_MULTI_MINUS + 5,        /* 515 */
};

typedef struct gpstime {
    int v3;                 /* version 3 (POINT14) codes, see gpstime_step */
    uint32_t last, next;
    int64_t last_time[4];
    int32_t last_diff[4];
    int32_t extreme_count[4];
    laz_sym m_multi, m_0diff;
    laz_ic ic;
} gpstime;

typedef struct rgb12 {
    uint16_t last[3];
    laz_sym m_used, m_diff[6];
} rgb12;

typedef struct bytes {
    uint32_t n;
    uint8_t *last;
    laz_sym *m;             /* [n] */
} bytes;

typedef struct item {
    uint16_t type;
    uint32_t offset;        /* in the record */
    union {
        point10 *p;
        gpstime *g;
        rgb12 *c;
        bytes *b;
    } u;
} item;

struct laz_items {
    uint32_t n;
    uint32_t epoch;
    item it[WPD_LAZ_MAX_ITEMS];
};

/* The model of POINT10 byte field f (BYTE_BITS, ...) after previous value
 * prev: made on first use, reset on first use in the chunk of epoch.
 * NULL if it cannot be allocated. */
laz_sym *laz_point10_byte_model(point10 *p, int f, uint8_t prev, uint32_t epoch);

/* GPS time and RGB state shared with the layered items (GPS time in
 * POINT14 v3, RGB14 v3 colour): same models and prediction; GPS time v3
 * has no "unchanged" code. NULL if out of memory. */
gpstime *laz_gpstime_create(int v3);
void laz_gpstime_free(gpstime *g);
/* Resets the models and takes the 8 bytes at rec as the only sequence. */
void laz_gpstime_start(gpstime *g, const uint8_t *rec);
/* Adds diff to the current sequence's time. */
void laz_gpstime_add(gpstime *g, int32_t diff);
/* A time beyond a 32-bit difference: opens the next sequence. */
void laz_gpstime_full(gpstime *g, laz_dec *d);
/* The difference coded against multi (0..510) times the last one. */
void laz_gpstime_multi(gpstime *g, laz_dec *d, int32_t multi);
/* Decodes the next time into out (8 bytes). Returns 0, or -1 with *why
 * set when the stream keeps switching sequences (corrupt). */
int laz_gpstime_decode(gpstime *g, laz_dec *d, uint8_t *out, const char **why);
/* Encodes the time at rec (laz_items_enc.c): the inverse of
 * laz_gpstime_decode. Version 3 is called only for a changed time. */
void laz_gpstime_encode(gpstime *g, laz_enc *e, const uint8_t *rec);

/* Extra bytes: n previous bytes and n 256-symbol models (also one
 * scanner channel's context of BYTE14). NULL if out of memory. */
bytes *laz_bytes_create(uint32_t n);
void laz_bytes_free(bytes *b);

rgb12 *laz_rgb12_create(void);
void laz_rgb12_free(rgb12 *c);
/* Resets the models and takes the 6 bytes at rec as the last colour. */
void laz_rgb12_start(rgb12 *c, const uint8_t *rec);
/* Decodes one colour (6 bytes) into out; it becomes the last colour. */
void laz_rgb12_decode(rgb12 *c, laz_dec *d, uint8_t *out);
/* Encodes the colour at rec (laz_items_enc.c); it becomes the last one. */
void laz_rgb12_encode(rgb12 *c, laz_enc *e, const uint8_t *rec);

#endif
