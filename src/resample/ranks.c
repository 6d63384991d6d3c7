/* ranks.c - the tiles of a run shared between the ranks of an MPI run
 * (par/par.h, ranks.h): an owner rank per tile, and after the tiles
 * of a colour ran, each tile's samples handed from its owner to every
 * other rank's sample store, so that every rank holds what any tile of a
 * later colour reads, as one process would. */
#include "resample/ranks.h"
#include "resample/run.h"
#include "resample/sample_store.h"

#include <stdlib.h>
#include <string.h>

int wpd_run_assign_owners(wpd_run *run, wpd_error *err)
{
    int ntiles = run->plan.ntiles, ranks = wpd_par_ranks(run->opt->par);
    run->owner = calloc((size_t)(ntiles ? ntiles : 1), sizeof *run->owner);
    uint64_t *load = calloc(2 * (size_t)ranks, sizeof *load), *total = load + ranks;
    int *order = malloc((size_t)(ntiles ? ntiles : 1) * sizeof *order);
    if (!run->owner || !load || !order) {
        free(load);
        free(order);
        return wpd_fail(err, WPD_E_MEMORY, "out of memory");
    }
    /* Colour by colour (the ranks work on one colour at a time), largest
     * tile first, each to the rank with the fewest points of that colour so
     * far, on a tie the one with the fewest points of all colours (a colour
     * of one tile goes to each rank in turn), then the lower rank: the
     * owners depend on the plan and the number of ranks only. */
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
                if (load[k] < load[best] || (load[k] == load[best] && total[k] < total[best]))
                    best = k;
            run->owner[order[i]] = best;
            load[best] += run->plan.tiles[order[i]].points + 1;
            total[best] += run->plan.tiles[order[i]].points + 1;
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

void wpd_samples_pack(const wpd_tile_samples *s, wpd_bytes *out)
{
    wpd_bytes_put_u64(out, s->n);
    wpd_bytes_put_u64(out, s->edge != NULL);
    wpd_bytes_put(out, s->gid, s->n * sizeof *s->gid);
    wpd_bytes_put(out, s->xyz, 3 * s->n * sizeof *s->xyz);
    if (s->edge)
        wpd_bytes_put(out, s->edge, s->n);
}

int wpd_samples_unpack(wpd_tile_samples *s, wpd_bytes_in *in)
{
    uint64_t n = wpd_bytes_get_u64(in), labelled = wpd_bytes_get_u64(in);
    /* Each sample takes 32 bytes at least: a count beyond that lies. */
    if (in->bad || n > wpd_bytes_left(in) / 32 || labelled > 1)
        return -1;
    if (wpd_samples_alloc(s, (size_t)n, labelled != 0))
        return -1;
    s->n = (size_t)n;
    if (wpd_bytes_get(in, s->gid, s->n * sizeof *s->gid) ||
        wpd_bytes_get(in, s->xyz, 3 * s->n * sizeof *s->xyz) ||
        (s->edge && wpd_bytes_get(in, s->edge, s->n))) {
        wpd_samples_free(s);
        return -1;
    }
    return 0;
}

/* Appends tile t (its number, its samples as its store holds them - in
 * memory or in its files - and what the phase adds) to out. */
static int pack_tile(wpd_run *run, int t, const wpd_tile_share *extra, void *arg,
                     wpd_bytes *out, wpd_error *err)
{
    wpd_tile_samples s = {0};
    int samples = !extra || !extra->keep_samples;
    if (samples && run->files &&
        wpd_runs_read(run->files, t, &s.gid, &s.xyz, &s.edge, &s.n, err))
        return -1;
    wpd_bytes_put_u64(out, (uint64_t)t);
    if (samples)
        wpd_samples_pack(run->files ? &s : &run->store[t], out);
    wpd_samples_free(&s);
    if (extra && extra->pack)
        extra->pack(run, t, arg, out);
    if (out->failed)
        return out->error == WPD_E_IO
                   ? wpd_fail(err, WPD_E_IO, "tile %d: cannot read its fields back", t)
                   : wpd_fail(err, WPD_E_MEMORY, "out of memory for the samples between ranks");
    return 0;
}

/* Puts the tiles packed in in into this rank's store (and the phase's
 * state). */
static int unpack_tiles(wpd_run *run, const wpd_tile_share *extra, void *arg, wpd_bytes_in *in,
                        wpd_error *err)
{
    while (wpd_bytes_left(in) > 0) {
        uint64_t t = wpd_bytes_get_u64(in);
        if (in->bad || t >= (uint64_t)run->plan.ntiles)
            return wpd_fail(err, WPD_E_IO, "samples from another rank do not add up");
        wpd_tile_samples *s = &run->store[t];
        if (!extra || !extra->keep_samples) {
            wpd_samples_free(s);
            if (wpd_samples_unpack(s, in))
                return wpd_fail(err, in->bad ? WPD_E_IO : WPD_E_MEMORY,
                                in->bad ? "samples from another rank do not add up"
                                        : "out of memory for the samples between ranks");
            if (wpd_store_save(run, (int)t, err)) /* in files: written, let go */
                return -1;
        }
        if (extra && extra->unpack && extra->unpack(run, (int)t, arg, in, err))
            return -1;
    }
    return 0;
}

int wpd_run_share_colour(wpd_run *run, int colour, const wpd_tile_share *extra, void *arg,
                         wpd_error *err)
{
    const wpd_par *par = run->opt->par;
    wpd_bytes mine = {0};
    uint8_t *all = NULL;
    size_t ranks = (size_t)wpd_par_ranks(par);
    size_t *off = calloc(ranks, sizeof *off), *part = calloc(ranks, sizeof *part);
    if (err->code == WPD_OK && (!off || !part))
        wpd_fail(err, WPD_E_MEMORY, "out of memory");
    for (int t = 0; err->code == WPD_OK && t < run->plan.ntiles; t++)
        if ((colour < 0 || run->plan.tiles[t].colour == colour) && wpd_run_owns(run, t))
            pack_tile(run, t, extra, arg, &mine, err);
    int rc = -1;
    if (wpd_par_agree(par, err) ||
        wpd_par_gather_all(par, mine.p, mine.len, &all, off, part, err))
        goto done;
    wpd_bytes_free(&mine);
    for (size_t k = 0; k < ranks; k++) {
        wpd_bytes_in in = {all + off[k], part[k], 0, 0};
        if (k != (size_t)wpd_par_rank(par) && unpack_tiles(run, extra, arg, &in, err))
            goto done;
    }
    rc = 0;
done:
    wpd_bytes_free(&mine);
    free(all);
    free(off);
    free(part);
    return rc;
}
