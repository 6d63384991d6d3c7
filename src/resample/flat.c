/* flat.c - the flat sample set (flat.h): every tile's samples in one
 * array in global-index order. */
#include "resample/flat.h"

#include <stdlib.h>
#include <string.h>


void wpd_flat_free(wpd_flat *f)
{
    free(f->gid);
    free(f->xyz);
    free(f->edge);
    free(f->tile);
    memset(f, 0, sizeof *f);
}

/* A min-heap of tiles keyed by the gid of their next sample. */
typedef struct head {
    uint64_t gid;
    int tile;
} head;

static void sift_down(head *h, size_t n, size_t i)
{
    for (;;) {
        size_t c = 2 * i + 1;
        if (c >= n)
            return;
        if (c + 1 < n && h[c + 1].gid < h[c].gid)
            c++;
        if (h[i].gid <= h[c].gid)
            return;
        head tmp = h[i];
        h[i] = h[c];
        h[c] = tmp;
        i = c;
    }
}

/* Each tile's samples ascend by gid: a merge of the tiles gives the flat
 * set in gid order with one heap entry per tile, not a sort with its index
 * arrays (24 bytes a sample at the run's memory peak). */
int wpd_flat_from_store(const wpd_run *run, wpd_flat *f)
{
    int ntiles = run->plan.ntiles;
    size_t n = f->n = wpd_run_store_count(run), m = n ? n : 1;
    int with_edge = wpd_store_labelled(run);
    f->gid = malloc(m * sizeof *f->gid);
    f->xyz = malloc(m * 3 * sizeof *f->xyz);
    f->edge = with_edge ? malloc(m) : NULL;
    f->tile = malloc(m * sizeof *f->tile);
    size_t *next = calloc((size_t)ntiles, sizeof *next);
    head *h = malloc((size_t)(ntiles ? ntiles : 1) * sizeof *h);
    int rc = f->gid && f->xyz && f->tile && (f->edge || !with_edge) && next && h ? 0 : -1;
    size_t nh = 0;
    for (int t = 0; rc == 0 && t < ntiles; t++)
        if (run->store[t].n)
            h[nh++] = (head){run->store[t].gid[0], t};
    for (size_t i = nh; i-- > 0;)
        sift_down(h, nh, i);
    for (size_t j = 0; rc == 0 && j < n; j++) {
        int t = h[0].tile;
        const wpd_tile_samples *s = &run->store[t];
        size_t i = next[t]++;
        f->gid[j] = s->gid[i];
        memcpy(f->xyz + 3 * j, s->xyz + 3 * i, 3 * sizeof *f->xyz);
        if (f->edge)
            f->edge[j] = s->edge ? s->edge[i] : 0;
        f->tile[j] = t;
        if (next[t] < s->n)
            h[0].gid = s->gid[next[t]];
        else
            h[0] = h[--nh];
        sift_down(h, nh, 0);
    }
    free(next);
    free(h);
    return rc;
}
