/* exact_fields.c - a sweep's per-tile arrays, held in memory or in files
 * (exact.h). */
#include "resample/exact_internal.h"

#include <stdlib.h>
#include <string.h>

#include "spill/blobs.h"

/* Field f of x: where its pointer lives, its element size and count. */
static void **slot(exact_tile *x, exact_field f)
{
    switch (f) {
    case EF_COST: return (void **)&x->cost;
    case EF_NN: return (void **)&x->nn;
    case EF_HALF: return (void **)&x->half;
    case EF_CAND: return (void **)&x->cand;
    case EF_CGID: return (void **)&x->cgid;
    case EF_CXYZ: return (void **)&x->cxyz;
    case EF_CCOST: return (void **)&x->ccost;
    case EF_RANK: return (void **)&x->rank;
    case EF_STATE: return (void **)&x->state;
    case EF_NEXT: return (void **)&x->next;
    case EF_BIDX: return (void **)&x->bidx;
    case EF_BXYZ: return (void **)&x->bxyz;
    case EF_BGID: return (void **)&x->bgid;
    case EF_BCOST: return (void **)&x->bcost;
    case EF_BRANK: return (void **)&x->brank;
    default: return NULL;
    }
}

static size_t bytes_of(const exact_tile *x, exact_field f)
{
    static const size_t size[EF_COUNT] = {
        [EF_COST] = 8, [EF_NN] = 8, [EF_HALF] = 1,
        [EF_CAND] = 4, [EF_CGID] = 8, [EF_CXYZ] = 24, [EF_CCOST] = 8, [EF_RANK] = 8,
        [EF_STATE] = 1, [EF_NEXT] = 1,
        [EF_BIDX] = 4, [EF_BXYZ] = 24, [EF_BGID] = 8, [EF_BCOST] = 8, [EF_BRANK] = 8};
    size_t count = f <= EF_HALF ? x->n : f <= EF_NEXT ? x->ncand : x->nborder;
    return size[f] * count;
}

/* Whether field f exists for the sweep (sharp labels only when labelled). */
static int used(const exact_sweep *sw, exact_field f)
{
    return f != EF_HALF || sw->labelled;
}

static size_t key_of(int t, exact_field f)
{
    return (size_t)t * EF_COUNT + (size_t)f;
}

int wpd_exact_hold(exact_sweep *sw, int t, unsigned mask, wpd_error *err)
{
    exact_tile *x = &sw->tile[t];
    for (int f = 0; sw->blobs && f < EF_COUNT; f++) {
        void **p = slot(x, (exact_field)f);
        size_t bytes;
        if (!(mask & EF(f)) || !used(sw, (exact_field)f) || *p)
            continue;
        if (wpd_blobs_get(sw->blobs, key_of(t, (exact_field)f), p, &bytes, err))
            return -1;
    }
    return 0;
}

int wpd_exact_keep(exact_sweep *sw, int t, unsigned mask, wpd_error *err)
{
    exact_tile *x = &sw->tile[t];
    int rc = 0;
    for (int f = 0; sw->blobs && f < EF_COUNT; f++) {
        void **p = slot(x, (exact_field)f);
        if (!(mask & EF(f)) || !*p)
            continue;
        if (wpd_blobs_put(sw->blobs, key_of(t, (exact_field)f), *p, bytes_of(x, (exact_field)f),
                          rc ? NULL : err))
            rc = -1;
        *p = NULL;
    }
    return rc;
}

void wpd_exact_let_go(exact_sweep *sw, int t, unsigned mask)
{
    exact_tile *x = &sw->tile[t];
    for (int f = 0; sw->blobs && f < EF_COUNT; f++) {
        void **p = slot(x, (exact_field)f);
        if (mask & EF(f)) {
            free(*p);
            *p = NULL;
        }
    }
}

int wpd_exact_alloc(exact_sweep *sw, int t, unsigned mask, wpd_error *err)
{
    exact_tile *x = &sw->tile[t];
    for (int f = 0; f < EF_COUNT; f++) {
        void **p = slot(x, (exact_field)f);
        if (!(mask & EF(f)) || !used(sw, (exact_field)f))
            continue;
        free(*p);
        size_t bytes = bytes_of(x, (exact_field)f);
        if (!(*p = calloc(bytes ? bytes : 1, 1)))
            return wpd_fail(err, WPD_E_MEMORY, "out of memory for the exact count in tile %d",
                            t);
    }
    return 0;
}

void wpd_exact_free_all(exact_sweep *sw)
{
    for (int t = 0; sw->tile && t < sw->run->plan.ntiles; t++) {
        exact_tile *x = &sw->tile[t];
        for (int f = 0; f < EF_COUNT; f++) {
            void **p = slot(x, (exact_field)f);
            free(*p);
            *p = NULL;
        }
        memset(x, 0, sizeof *x);
    }
}

int wpd_exact_peek(const exact_sweep *sw, int u, exact_field f, void **copy, const void **p,
                   wpd_error *err)
{
    *copy = NULL;
    if (!sw->blobs) {
        *p = *slot((exact_tile *)&sw->tile[u], f);
        return 0;
    }
    size_t bytes;
    if (wpd_blobs_get(sw->blobs, key_of(u, f), copy, &bytes, err))
        return -1;
    *p = *copy;
    return 0;
}
