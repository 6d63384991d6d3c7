/* fixed.c - earlier runs' samples kept by a run (fixed.h). */
#include "resample/fixed.h"

#include <stdlib.h>
#include <string.h>

#include "resample/sample_store.h"

/* How far from a tile's box a phase may ask: the sample store's band. */
static double reach(const wpd_run *run)
{
    return WPD_STORE_BAND * run->halo;
}

int wpd_fixed_open(wpd_run *run, wpd_error *err)
{
    wpd_fixed *f = &run->fixed;
    size_t n = run->opt->nfixed;
    int ntiles = run->plan.ntiles;
    if (n == 0)
        return 0;
    f->xyz = malloc(3 * n * sizeof *f->xyz);
    f->of_tile = calloc((size_t)ntiles, sizeof *f->of_tile);
    f->nof_tile = calloc((size_t)ntiles, sizeof *f->nof_tile);
    if (!f->xyz || !f->of_tile || !f->nof_tile)
        return wpd_fail(err, WPD_E_MEMORY, "out of memory for %zu fixed samples", n);
    f->n = n;
    for (size_t i = 0; i < 3 * n; i++)
        f->xyz[i] = run->opt->fixed_xyz[i] - run->scan.origin[i % 3];
    double d2 = reach(run) * reach(run);
    /* Two walks per tile: count, then list (sized exactly: the arena is
     * never trimmed). */
    for (int t = 0; t < ntiles; t++) {
        const wpd_tile *tile = &run->plan.tiles[t];
        size_t m = 0;
        for (size_t i = 0; i < n; i++)
            m += wpd_tile_distance2(tile, f->xyz + 3 * i) <= d2;
        if (!(f->of_tile[t] = malloc((m ? m : 1) * sizeof **f->of_tile)))
            return wpd_fail(err, WPD_E_MEMORY, "out of memory for %zu fixed samples", n);
        for (size_t i = 0; i < n; i++)
            if (wpd_tile_distance2(tile, f->xyz + 3 * i) <= d2)
                f->of_tile[t][f->nof_tile[t]++] = (uint32_t)i;
    }
    return 0;
}

void wpd_fixed_close(wpd_run *run)
{
    wpd_fixed *f = &run->fixed;
    for (int t = 0; f->of_tile && t < run->plan.ntiles; t++)
        free(f->of_tile[t]);
    free(f->of_tile);
    free(f->nof_tile);
    free(f->xyz);
    memset(f, 0, sizeof *f);
}

/* How many of tile t's fixed samples lie within dist of its box. */
static size_t count_near(const wpd_run *run, int t, double d2)
{
    const wpd_fixed *f = &run->fixed;
    size_t m = 0;
    for (size_t k = 0; f->n && k < f->nof_tile[t]; k++)
        m += wpd_tile_distance2(&run->plan.tiles[t], f->xyz + 3 * (size_t)f->of_tile[t][k]) <= d2;
    return m;
}

int wpd_fixed_near(const wpd_run *run, int t, double dist, wpd_tile_samples *out,
                   wpd_error *err)
{
    const wpd_fixed *f = &run->fixed;
    double d2 = dist * dist;
    memset(out, 0, sizeof *out);
    size_t m = count_near(run, t, d2);
    if (m == 0)
        return 0;
    if (wpd_samples_alloc(out, m, 0))
        return wpd_fail(err, WPD_E_MEMORY, "out of memory for %zu fixed samples", m);
    for (size_t k = 0; k < f->nof_tile[t]; k++) {
        uint32_t i = f->of_tile[t][k];
        if (wpd_tile_distance2(&run->plan.tiles[t], f->xyz + 3 * (size_t)i) > d2)
            continue;
        out->gid[out->n] = WPD_FIXED_GID + i; /* ascending: the lists are */
        memcpy(out->xyz + 3 * out->n++, f->xyz + 3 * (size_t)i, 3 * sizeof *out->xyz);
    }
    return 0;
}

int wpd_fixed_append(const wpd_run *run, int t, double dist, double **xyz, uint8_t **edge,
                     size_t *n, wpd_error *err)
{
    wpd_tile_samples s;
    if (run->fixed.n == 0)
        return 0;
    if (wpd_fixed_near(run, t, dist, &s, err))
        return -1;
    if (s.n == 0)
        return 0;
    double *x = realloc(*xyz, 3 * (*n + s.n) * sizeof *x);
    if (x)
        *xyz = x;
    uint8_t *e = *edge ? realloc(*edge, *n + s.n) : NULL;
    if (e)
        *edge = e;
    if (!x || (*edge && !e)) {
        wpd_samples_free(&s);
        return wpd_fail(err, WPD_E_MEMORY, "out of memory for %zu fixed samples", s.n);
    }
    memcpy(*xyz + 3 * *n, s.xyz, 3 * s.n * sizeof **xyz);
    if (*edge)
        memset(*edge + *n, 0, s.n);
    *n += s.n;
    wpd_samples_free(&s);
    return 0;
}
