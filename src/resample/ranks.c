/* ranks.c - the tiles of a run shared between the ranks of an MPI run
 * (par/par.h, run.h "Ranks"): an owner rank per tile, and after the tiles
 * of a colour ran, each tile's samples handed from its owner to every
 * other rank's sample store, so that every rank holds what any tile of a
 * later colour reads, as one process would. */
#include "resample/run.h"

#include <stdlib.h>
#include <string.h>

int wpd_run_assign_owners(wpd_run *run, wpd_error *err)
{
    int ntiles = run->plan.ntiles, ranks = wpd_par_ranks(run->opt->par);
    run->owner = calloc((size_t)(ntiles ? ntiles : 1), sizeof *run->owner);
    uint64_t *load = calloc((size_t)ranks, sizeof *load);
    int *order = malloc((size_t)(ntiles ? ntiles : 1) * sizeof *order);
    if (!run->owner || !load || !order) {
        free(load);
        free(order);
        return wpd_fail(err, WPD_E_MEMORY, "out of memory");
    }
    /* Colour by colour (the ranks work on one colour at a time), largest
     * tile first, each to the rank with the fewest points of that colour so
     * far, the lower rank on a tie: the owners depend on the plan and the
     * number of ranks only. */
    for (int c = 0; c < run->plan.ncolours; c++) {
        int m = 0;
        for (int t = 0; t < ntiles; t++)
            if (run->plan.tiles[t].colour == c)
                order[m++] = t;
        for (int i = 1; i < m; i++) /* insertion sort: points descending, then tile */
            for (int j = i; j > 0; j--) {
                const wpd_tile *a = &run->plan.tiles[order[j - 1]], *b = &run->plan.tiles[order[j]];
                if (a->points >= b->points)
                    break;
                int tmp = order[j];
                order[j] = order[j - 1], order[j - 1] = tmp;
            }
        memset(load, 0, (size_t)ranks * sizeof *load);
        for (int i = 0; i < m; i++) {
            int best = 0;
            for (int k = 1; k < ranks; k++)
                if (load[k] < load[best])
                    best = k;
            run->owner[order[i]] = best;
            load[best] += run->plan.tiles[order[i]].points + 1;
        }
    }
    free(load);
    free(order);
    return 0;
}

int wpd_run_owns(const wpd_run *run, int t)
{
    return !run->owner || run->owner[t] == wpd_par_rank(run->opt->par);
}

/* A tile's samples as bytes: tile, count, whether labelled, then the
 * global indices, coordinates and labels. */
typedef struct packed_head {
    uint64_t tile, n, labelled;
} packed_head;

static size_t packed_bytes(size_t n, int labelled)
{
    return sizeof(packed_head) + n * (sizeof(uint64_t) + 3 * sizeof(double)) +
           (labelled ? n : 0);
}

/* Appends tile t's samples (as its store holds them: in memory or in its
 * files) to *buf. */
static int pack_tile(wpd_run *run, int t, uint8_t **buf, size_t *len, size_t *cap,
                     wpd_error *err)
{
    wpd_tile_samples s = {0};
    const wpd_tile_samples *src = &run->store[t];
    if (run->files) {
        if (wpd_runs_read(run->files, t, &s.gid, &s.xyz, &s.edge, &s.n, err))
            return -1;
        src = &s;
    }
    size_t need = packed_bytes(src->n, src->edge != NULL);
    if (*len + need > *cap) {
        size_t grown = 2 * (*cap + need);
        uint8_t *b = realloc(*buf, grown);
        if (!b) {
            wpd_samples_free(&s);
            return wpd_fail(err, WPD_E_MEMORY, "out of memory for the samples between ranks");
        }
        *buf = b, *cap = grown;
    }
    packed_head h = {(uint64_t)t, src->n, src->edge != NULL};
    uint8_t *p = *buf + *len;
    memcpy(p, &h, sizeof h);
    p += sizeof h;
    memcpy(p, src->gid, src->n * sizeof *src->gid);
    p += src->n * sizeof *src->gid;
    memcpy(p, src->xyz, 3 * src->n * sizeof *src->xyz);
    p += 3 * src->n * sizeof *src->xyz;
    if (src->edge)
        memcpy(p, src->edge, src->n);
    *len += need;
    wpd_samples_free(&s);
    return 0;
}

/* Puts the tiles packed in buf[0..len) into this rank's store. */
static int unpack_tiles(wpd_run *run, const uint8_t *buf, size_t len, wpd_error *err)
{
    size_t at = 0;
    while (at < len) {
        packed_head h;
        if (len - at < sizeof h)
            return wpd_fail(err, WPD_E_IO, "samples from another rank cut short");
        memcpy(&h, buf + at, sizeof h);
        if (h.tile >= (uint64_t)run->plan.ntiles || h.n > (len - at) / 32 ||
            packed_bytes((size_t)h.n, h.labelled != 0) > len - at)
            return wpd_fail(err, WPD_E_IO, "samples from another rank do not add up");
        int t = (int)h.tile;
        size_t step = packed_bytes((size_t)h.n, h.labelled != 0);
        const uint8_t *p = buf + at + sizeof h;
        wpd_tile_samples *s = &run->store[t];
        wpd_samples_free(s);
        if (wpd_samples_alloc(s, (size_t)h.n, h.labelled != 0))
            return wpd_fail(err, WPD_E_MEMORY, "out of memory for the samples between ranks");
        s->n = (size_t)h.n;
        memcpy(s->gid, p, s->n * sizeof *s->gid);
        p += s->n * sizeof *s->gid;
        memcpy(s->xyz, p, 3 * s->n * sizeof *s->xyz);
        p += 3 * s->n * sizeof *s->xyz;
        if (s->edge)
            memcpy(s->edge, p, s->n);
        if (wpd_store_save(run, t, err)) /* in files: written, let go */
            return -1;
        at += step;
    }
    return 0;
}

int wpd_run_share_colour(wpd_run *run, int colour, wpd_error *err)
{
    const wpd_par *par = run->opt->par;
    uint8_t *mine = NULL, *all = NULL;
    size_t len = 0, cap = 0, ranks = (size_t)wpd_par_ranks(par);
    size_t *off = calloc(ranks, sizeof *off), *part = calloc(ranks, sizeof *part);
    if (err->code == WPD_OK && (!off || !part))
        wpd_fail(err, WPD_E_MEMORY, "out of memory");
    for (int t = 0; err->code == WPD_OK && t < run->plan.ntiles; t++)
        if (run->plan.tiles[t].colour == colour && wpd_run_owns(run, t))
            pack_tile(run, t, &mine, &len, &cap, err);
    int rc = -1;
    if (wpd_par_agree(par, err) || wpd_par_gather_all(par, mine, len, &all, off, part, err))
        goto done;
    free(mine);
    mine = NULL;
    for (size_t k = 0; k < ranks; k++)
        if (k != (size_t)wpd_par_rank(par) && unpack_tiles(run, all + off[k], part[k], err))
            goto done;
    rc = 0;
done:
    free(mine);
    free(all);
    free(off);
    free(part);
    return rc;
}
