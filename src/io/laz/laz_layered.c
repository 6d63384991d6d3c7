/* laz_layered.c - chunks of the layered compressor: layer byte counts,
 * loading or skipping layers, and the item chain (contract in
 * laz_layered.h).
 *
 * Chunk layout (LAZ specification, "LASzip for LAS 1.4"): the raw first
 * record; the chunk's point count (u32, the raw record included); one u32
 * byte count per layer, items in VLR order (POINT14: 9 layers, RGB14: 1,
 * RGBNIR14: 2, BYTE14: one per byte); then the layers in the same order,
 * each an arithmetic stream of its own.
 */
#include "io/laz/laz_layered.h"
#include "io/laz/laz_items.h"
#include "io/laz/laz_layered_state.h"
#include "io/las/las_internal.h"

#include <stdlib.h>
#include <string.h>

typedef struct item14 {
    uint16_t type;
    uint32_t offset;            /* in the record */
    uint32_t first, nlayers;    /* its layers in L->layer */
    union {
        point14 *p;
        color14 *c;
        bytes14 *b;
    } u;
} item14;

struct laz_layered {
    uint32_t n;
    item14 it[WPD_LAZ_MAX_ITEMS];
    uint32_t nlayers;
    laz_layer *layer;
    uint8_t *buf;               /* the loaded layers of the chunk */
    size_t cap;
    int xyz_only;
    uint32_t count;             /* points of the chunk */
};

static uint32_t layers_of(const wpd_laz_item *x)
{
    switch (x->type) {
    case LAZ_ITEM_POINT14: return P14_LAYERS;
    case LAZ_ITEM_RGB14: return 1;
    case LAZ_ITEM_RGBNIR14: return 2;
    default: return x->size;
    }
}

void laz_layered_free(laz_layered *L)
{
    if (!L)
        return;
    for (uint32_t i = 0; i < L->n; i++) {
        item14 *x = &L->it[i];
        switch (x->type) {
        case LAZ_ITEM_POINT14: laz_point14_free(x->u.p); break;
        case LAZ_ITEM_RGB14: case LAZ_ITEM_RGBNIR14: laz_color14_free(x->u.c); break;
        default: laz_bytes14_free(x->u.b); break;
        }
    }
    if (L->layer)
        for (uint32_t i = 0; i < L->nlayers; i++)
            laz_out_free(&L->layer[i].out);
    free(L->layer);
    free(L->buf);
    free(L);
}

laz_layered *laz_layered_create(const wpd_laz_item *list, uint32_t n)
{
    laz_layered *L = calloc(1, sizeof *L);
    if (!L || n > WPD_LAZ_MAX_ITEMS) {
        free(L);
        return NULL;
    }
    uint32_t off = 0;
    for (uint32_t i = 0; i < n; i++) {
        item14 *x = &L->it[i];
        x->type = list[i].type;
        x->offset = off;
        x->first = L->nlayers;
        x->nlayers = layers_of(&list[i]);
        L->nlayers += x->nlayers;
        off += list[i].size;
        void *made;
        switch (x->type) {
        case LAZ_ITEM_POINT14: made = x->u.p = laz_point14_create(); break;
        case LAZ_ITEM_RGB14: made = x->u.c = laz_color14_create(0); break;
        case LAZ_ITEM_RGBNIR14: made = x->u.c = laz_color14_create(1); break;
        default: made = x->u.b = laz_bytes14_create(list[i].size); break;
        }
        L->n = i + 1;
        if (!made) {
            laz_layered_free(L);
            return NULL;
        }
    }
    if (!(L->layer = calloc(L->nlayers ? L->nlayers : 1, sizeof *L->layer))) {
        laz_layered_free(L);
        return NULL;
    }
    return L;
}

void laz_layered_xyz_only(laz_layered *L, int xyz_only)
{
    L->xyz_only = xyz_only;
}

unsigned laz_layered_channels(const laz_layered *L)
{
    /* POINT14 is the first item (laz_vlr.c checks it) and marks each
     * channel whose context it starts in the chunk. */
    return L->n && L->it[0].type == LAZ_ITEM_POINT14 ? L->it[0].u.p->used : 0;
}

/* Whether layer i is needed: all, or those of X Y (the XY layer, which
 * also carries what every other layer depends on) and Z. */
static int wanted(const laz_layered *L, uint32_t i)
{
    return !L->xyz_only || i == P14_XY || i == P14_Z;
}

/* Reads the layer byte counts and checks they fit the chunk. */
static const char *read_sizes(laz_layered *L, laz_in *in, uint64_t limit, uint64_t *load)
{
    uint64_t total = 0;
    *load = 0;
    for (uint32_t i = 0; i < L->nlayers; i++) {
        uint8_t b[4];
        laz_in_bytes(in, b, 4);
        L->layer[i].size = las_get_u32(b);
        total += L->layer[i].size;
        if (wanted(L, i))
            *load += L->layer[i].size;
    }
    if (in->overrun)
        return "the data end inside the chunk (file truncated?)";
    if (total > limit - laz_in_tell(in))
        return "its layer byte counts pass the chunk's end (corrupt)";
    return NULL;
}

/* Loads the wanted layers into L->buf and skips the others. */
static int load_layers(laz_layered *L, laz_in *in, uint64_t load, const char **why)
{
    if (load > L->cap) {
        uint8_t *b = realloc(L->buf, (size_t)load);
        if (!b)
            return -2;
        L->buf = b, L->cap = (size_t)load;
    }
    size_t at = 0;
    for (uint32_t i = 0; i < L->nlayers; i++) {
        laz_layer *y = &L->layer[i];
        y->active = y->size && wanted(L, i);
        if (!y->active) {
            laz_in_seek(in, laz_in_tell(in) + y->size, in->limit);
            continue;
        }
        laz_in_bytes(in, L->buf + at, y->size);
        laz_in_memory(&y->in, L->buf + at, y->size);
        at += y->size;
    }
    if (in->overrun) {
        for (uint32_t i = 0; i < L->nlayers; i++)
            L->layer[i].active = 0; /* no stream was opened */
        *why = "the data end inside the chunk (file truncated?)";
        return -1;
    }
    /* The streams open once every layer is in place (the buffer is final). */
    for (uint32_t i = 0; i < L->nlayers; i++)
        if (L->layer[i].active)
            laz_dec_init(&L->layer[i].dec, &L->layer[i].in);
    return 0;
}

/* Starts every item's context from the raw record. */
static int start_items(laz_layered *L, const uint8_t *rec)
{
    unsigned ch = (rec[15] >> 4) & 3;
    for (uint32_t i = 0; i < L->n; i++) {
        item14 *x = &L->it[i];
        const uint8_t *p = rec + x->offset;
        int rc;
        switch (x->type) {
        case LAZ_ITEM_POINT14: rc = laz_point14_start(x->u.p, p); break;
        case LAZ_ITEM_RGB14: case LAZ_ITEM_RGBNIR14: rc = laz_color14_start(x->u.c, ch, p); break;
        default: rc = laz_bytes14_start(x->u.b, ch, p); break;
        }
        if (rc)
            return -2;
    }
    return 0;
}

int laz_layered_open(laz_layered *L, laz_in *in, uint64_t limit, uint32_t record_length,
                     uint8_t *rec, uint32_t *count, const char **why)
{
    uint8_t b[4];
    uint64_t load;
    laz_in_bytes(in, rec, record_length);
    laz_in_bytes(in, b, 4);
    L->count = *count = las_get_u32(b);
    if ((*why = read_sizes(L, in, limit, &load)))
        return -1;
    /* Every point after the first codes its changed fields in the XY layer,
     * which the decoder reads unconditionally: empty, it has no stream. */
    if (L->count > 1 && !L->layer[P14_XY].size) {
        *why = "its XY layer is empty, yet the chunk holds more than one point (corrupt)";
        return -1;
    }
    int rc = load_layers(L, in, load, why);
    return rc ? rc : start_items(L, rec);
}

int laz_layered_decode(laz_layered *L, uint8_t *rec, const char **why)
{
    /* POINT14 comes first and decides the context of the rest. */
    unsigned ch = 0;
    for (uint32_t i = 0; i < L->n; i++) {
        item14 *x = &L->it[i];
        laz_layer *y = L->layer + x->first;
        uint8_t *p = rec + x->offset;
        int rc;
        switch (x->type) {
        case LAZ_ITEM_POINT14:
            rc = laz_point14_decode(x->u.p, y, p, why);
            ch = x->u.p->item;
            break;
        case LAZ_ITEM_RGB14: case LAZ_ITEM_RGBNIR14:
            rc = laz_color14_decode(x->u.c, y, ch, p);
            break;
        default: rc = laz_bytes14_decode(x->u.b, y, ch, p); break;
        }
        if (rc)
            return rc;
    }
    return 0;
}

const char *laz_layered_close(const laz_layered *L)
{
    if (L->count < 2) /* nothing was decoded: the streams were never read */
        return NULL;
    for (uint32_t i = 0; i < L->nlayers; i++) {
        const laz_layer *y = &L->layer[i];
        if (!y->active)
            continue;
        if (y->in.overrun)
            return "a layer's stream runs past its byte count (truncated or corrupt)";
        if (laz_in_tell(&y->in) != y->size)
            return "a layer's stream does not end at its byte count (corrupt)";
    }
    return NULL;
}

/* ---- encoding ---- */

int laz_layered_start_encode(laz_layered *L, const uint8_t *rec)
{
    for (uint32_t i = 0; i < L->nlayers; i++) {
        laz_layer *y = &L->layer[i];
        laz_out_clear(&y->out);
        laz_enc_init(&y->enc, &y->out);
        /* LASzip always writes the XY and Z layers, even for a Z that
         * never changes in the chunk: so do we, for the same bytes. */
        y->changed = i == P14_XY || i == P14_Z;
    }
    return start_items(L, rec) ? -1 : 0;
}

int laz_layered_encode(laz_layered *L, const uint8_t *rec)
{
    unsigned ch = 0;
    for (uint32_t i = 0; i < L->n; i++) {
        item14 *x = &L->it[i];
        laz_layer *y = L->layer + x->first;
        const uint8_t *p = rec + x->offset;
        int rc;
        switch (x->type) {
        case LAZ_ITEM_POINT14:
            rc = laz_point14_encode(x->u.p, y, p);
            ch = x->u.p->item;
            break;
        case LAZ_ITEM_RGB14: case LAZ_ITEM_RGBNIR14:
            rc = laz_color14_encode(x->u.c, y, ch, p);
            break;
        default: rc = laz_bytes14_encode(x->u.b, y, ch, p); break;
        }
        if (rc)
            return -1;
    }
    return 0;
}

int laz_layered_finish(laz_layered *L, laz_out *out, const uint8_t *first,
                       uint32_t record_length, uint32_t count)
{
    uint8_t b[4];
    laz_out_bytes(out, first, record_length);
    las_put_u32(b, count);
    laz_out_bytes(out, b, 4);
    for (uint32_t i = 0; i < L->nlayers; i++) {
        laz_layer *y = &L->layer[i];
        laz_enc_done(&y->enc);
        if (y->out.oom)
            return -1;
        las_put_u32(b, y->changed ? (uint32_t)y->out.len : 0);
        laz_out_bytes(out, b, 4);
    }
    for (uint32_t i = 0; i < L->nlayers; i++)
        if (L->layer[i].changed)
            laz_out_bytes(out, L->layer[i].out.buf, L->layer[i].out.len);
    return out->oom ? -1 : 0;
}
