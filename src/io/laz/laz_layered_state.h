/* laz_layered_state.h - the state of the layered compressor of LAZ 1.4
 * (point formats 6-10, item version 3): layers, the per-scanner-channel
 * contexts of POINT14, RGB14, RGBNIR14 and BYTE14, shared by the decoders
 * (laz_point14.c, laz_items14.c) and the encoders, which must update
 * exactly the state their decoders will. Not for use outside src/io.
 *
 * Written from the LAZ specification ("LASzip for LAS 1.4 (native
 * extension)", rapidlasso): after a chunk's raw first record, every
 * attribute group is its own arithmetic-coded stream (layer) with its
 * byte count stored before the layers, so a reader can skip the layers it
 * does not need. Each item keeps up to four contexts: POINT14 one per
 * scanner channel, the others one per context number POINT14 hands them
 * (below; docs/formats.md, "Scanner channels").
 */
#ifndef WPD_LAZ_LAYERED_STATE_H
#define WPD_LAZ_LAYERED_STATE_H

#include "io/laz/laz_encoder.h"
#include "io/laz/laz_item_state.h"

/* The layers of POINT14, in the order of the chunk's byte counts. XY
 * carries the scanner channel, the change flags and the return counts:
 * every other layer depends on it and on itself only. */
enum {
    P14_XY, P14_Z, P14_CLASS, P14_FLAGS, P14_INTENSITY, P14_SCAN, P14_USER, P14_SOURCE,
    P14_GPS, P14_LAYERS
};

/* One layer of a chunk: its byte count, whether it is decoded (wanted and
 * not empty; an empty layer means the attribute never changes in the
 * chunk), and its stream (decoding: in and dec over the chunk buffer;
 * encoding: out and enc). */
typedef struct laz_layer {
    uint32_t size;
    int active;
    int changed;                /* encoding: the field changed in the chunk */
    laz_in in;
    laz_dec dec;
    laz_out out;
    laz_enc enc;
} laz_layer;

/* POINT14 state of one scanner channel. */
typedef struct p14_context {
    uint32_t epoch;             /* lazy models reset on first use after a change */
    uint8_t last[30];           /* previous point of this channel */
    int gps_change;             /* its GPS time differed from its predecessor's */
    uint16_t last_intensity[8]; /* by current return context * 2 + GPS change */
    median5 dx[12], dy[12];     /* by return map * 2 + GPS change */
    int32_t last_z[8];          /* by return level */
    gpstime *gps;
    laz_sym m_changed[8], m_channel, m_return_gps_same;
    laz_lazy_sym m_nreturns[16], m_return[16], m_class[64], m_flags[64], m_user[64];
    laz_ic ic_dx, ic_dy, ic_z, ic_intensity, ic_scan, ic_source;
} p14_context;

/* item: the context POINT14 hands the items after it for the point just
 * coded. LASzip hands them the new scanner channel on a point whose channel
 * changed (and the first point's channel at a chunk's start), and context 0
 * on every other point, whatever its channel: its point reader starts each
 * point with context 0 and only a channel change sets it. So on a chunk of
 * channels 1 1 2 2 the items use contexts 1 0 2 0. */
typedef struct point14 {
    uint32_t current;           /* scanner channel of the previous point */
    uint32_t used;              /* bit c: context c started in this chunk */
    uint32_t item;              /* context of the other items, see above */
    p14_context *ctx[4];        /* made on first use */
} point14;

/* Colour (RGB14, and NIR of RGBNIR14) and extra bytes (BYTE14) keep
 * models and a previous value per item context (point14.item, not the
 * scanner channel). A point of item context k after one of context j: if
 * k == j, context k predicts and is updated; if context k is not yet used
 * in the chunk, it starts from j's previous values (fresh models) and then
 * predicts and is updated as before; if k was used already, k's models
 * code the point but j's previous values predict it, and the value coded
 * replaces j's, while k's stay as they were. (LASzip's items take their
 * previous values before looking at the context and move to the new
 * context's only when they start it; this is the format.) */
typedef struct color14_context {
    rgb12 *rgb;                 /* models (its last is scratch) */
    uint16_t last[3], last_nir;
    laz_sym m_nir_used, m_nir_diff[2];
} color14_context;

typedef struct color14 {
    int nir;
    uint32_t current, used;     /* channel of the previous point; contexts started */
    color14_context *ctx[4];
} color14;

/* Extra bytes (BYTE14): one layer and one model per byte; a context is
 * the point-wise BYTE item's state (previous bytes and models). */
typedef struct bytes14 {
    uint32_t n;
    uint32_t current, used;
    bytes *ctx[4];
} bytes14;

/* Contexts by return (LAZ specification tables): the return map m
 * serialises (number of returns, return number) pairs into 6 classes for
 * the x/y predictions; the return level l is |n - r| capped at 7, for z. */
extern const uint8_t laz_return_map14[16][16];

static inline unsigned laz_return_level14(unsigned n, unsigned r)
{
    unsigned l = n > r ? n - r : r - n;
    return l < 7 ? l : 7;
}

/* ---- POINT14 (laz_point14.c) ---- */

point14 *laz_point14_create(void);
void laz_point14_free(point14 *p);
/* Chunk start: every context unused, the one of rec's scanner channel
 * started from rec (30 bytes). Returns 0, or -1 if out of memory. */
int laz_point14_start(point14 *p, const uint8_t *rec);
/* Starts context ch from the record last (a channel's first point takes
 * the previous point of another channel as its predecessor). Returns 0 or
 * -1 if out of memory. */
int laz_point14_context(point14 *p, unsigned ch, const uint8_t *last);

/* Decodes the next record's 30 bytes into out from the active layers
 * (layer[P14_XY] must be); fields of inactive layers keep the previous
 * point's values. Returns 0, -1 for a corrupt stream (*why says why) or
 * -2 if a model cannot be allocated. */
int laz_point14_decode(point14 *p, laz_layer *layer, uint8_t *out, const char **why);

/* Encodes rec (30 bytes) into the layers (laz_point14_enc.c), setting
 * layer->changed for each layer whose field changes. Returns 0 or -1 if a
 * model cannot be allocated. */
int laz_point14_encode(point14 *p, laz_layer *layer, const uint8_t *rec);

/* ---- colour and extra bytes (laz_items14.c) ---- */

color14 *laz_color14_create(int nir);
void laz_color14_free(color14 *c);
/* Chunk start in channel ch from the item's raw bytes (6, or 8 with
 * NIR). Returns 0 or -1 (out of memory). */
int laz_color14_start(color14 *c, unsigned ch, const uint8_t *rec);

/* Decodes the next colour (from layer[0], NIR from layer[1]) of a point
 * of channel ch into out. Returns 0 or -2 (out of memory). */
int laz_color14_decode(color14 *c, laz_layer *layer, unsigned ch, uint8_t *out);
/* Encodes the colour at rec in context ch: the inverse of the above.
 * Returns 0 or -1 (out of memory). */
int laz_color14_encode(color14 *c, laz_layer *layer, unsigned ch, const uint8_t *rec);

bytes14 *laz_bytes14_create(uint32_t n);
void laz_bytes14_free(bytes14 *b);
int laz_bytes14_start(bytes14 *b, unsigned ch, const uint8_t *rec);
/* Decodes the next n bytes (byte i from layer[i]) into out in context ch.
 * Returns 0 or -2 (out of memory). */
int laz_bytes14_decode(bytes14 *b, laz_layer *layer, unsigned ch, uint8_t *out);
int laz_bytes14_encode(bytes14 *b, laz_layer *layer, unsigned ch, const uint8_t *rec);

#endif
