/* poisson.c - the Poisson-disk passes over the tiles with the paper's
 * count refinement (until a pass keeps at least n; refine.h), and
 * the take-everything run for n >= the input.
 *
 * A pass over tiles gives exactly the one-block sample set, whatever the
 * tiling. A tile sees its own points and the halo (points of neighbours
 * within H of its box). Each point of that view is, for the tile:
 *   fixed      kept for certain by its owner (or by this tile in an earlier
 *              round): it removes every candidate within conflict distance;
 *   dropped    removed for certain;
 *   candidate  undecided: own points, halo points of neighbours not yet
 *              processed, and points their owner could not decide.
 * Candidates farther than H - max(r, r0) from the box are blind (with
 * --sharp H - max(r, 2 r0): a label looks that far, sharp.h): unseen points
 * may lie within r of them and their sharp label may be off. The three-valued
 * pass (wpd_poisson_pass_certain) then decides each candidate KEPT or
 * REMOVED only where that is the one-block decision, and UNKNOWN where the
 * view cannot tell (a chain of decisions reaching past the halo). Round 1
 * runs every tile colour by colour; each further round re-runs the tiles
 * that still have UNKNOWN own points, with every other tile's decisions
 * so far. Each round settles at least the UNKNOWN point of smallest
 * priority (its view holds every point within r of it, all decided), so
 * the rounds end. Most UNKNOWN points lie near a border with a neighbour
 * of a later colour, which sees them as candidates, not blind, and
 * decides them for certain when it runs: such decisions go back to their
 * owner after each colour, so few points are left for a second round. */
#include "resample/poisson.h"
#include "resample/run.h"

#include <stdlib.h>
#include <string.h>

#include "core/grid.h"
#include "core/knn.h"
#include "core/sort.h"
#include "method/refine.h"
#include "method/sharp.h"
#include "resample/sample_store.h"
#include "resample/ranks.h"
#include "resample/fixed.h"

enum { MAX_ROUNDS = 10000 }; /* each round settles a point: only a bug gets here */

/* Certain decisions a tile made about other tiles' UNKNOWN points. */
typedef struct foreign {
    size_t n;
    uint64_t *gid;
    double *xyz;
    uint8_t *edge;
    uint8_t *kept;             /* 1 kept, 0 removed */
    int *owner;
} foreign;

/* What a pass shares between its tiles. */
typedef struct pass_ctx {
    double r;
    int round;
    wpd_tile_samples *unknown; /* [ntiles] own points a tile could not decide */
    foreign *foreign;          /* [ntiles] decisions on neighbours' UNKNOWN points */
    uint8_t *processed;        /* [ntiles] decided in this pass at least once */
    wpd_poisson *memo;         /* one in-memory tile: grid and priorities prepared
                                  once for every pass */
    uint8_t *memo_edge;        /* and its sharp labels (the context borrows them),
                                  computed as the passes ask (WPD_LABEL_UNKNOWN until) */
    wpd_sharp_labeller *memo_labeller;
} pass_ctx;

/* One tile's view, classified. */
typedef struct view {
    wpd_tile_data d;
    uint8_t *edge;             /* [d.n] sharp labels (WPD_LABEL_UNKNOWN until the pass
                                  asks), or NULL */
    wpd_grid label_grid;       /* the view's points, for the labeller */
    wpd_sharp_labeller *labeller;
    uint32_t *cand;            /* candidates (view indices) */
    size_t ncand;
    size_t theirs;             /* candidates that are other tiles' UNKNOWN points */
    uint8_t *cls;              /* [d.n] CANDIDATE, FIXED, THEIRS (a neighbour's UNKNOWN
                                  point, a candidate) or DROPPED */
    uint8_t *blind;            /* [d.n] */
    uint8_t *wanted;           /* [d.n] own points and theirs: decisions needed; the
                                  other halo points are decided on demand */
    double *fixed;             /* [3 nfixed] */
    uint8_t *fixed_edge;       /* [nfixed], or NULL */
    size_t nfixed;
    uint32_t *kept, *unknown;  /* outputs, room for ncand */
    wpd_tile_samples *near;    /* [ntiles] each neighbour's samples within the halo */
} view;

static void view_free(const wpd_run *run, view *v)
{
    wpd_tiles_release(&run->tiles, &v->d);
    free(v->edge);
    wpd_sharp_labeller_free(v->labeller);
    wpd_grid_free(&v->label_grid);
    free(v->cand);
    free(v->blind);
    free(v->cls);
    free(v->wanted);
    free(v->fixed);
    free(v->fixed_edge);
    free(v->kept);
    free(v->unknown);
    for (int t = 0; v->near && t < run->plan.ntiles; t++)
        wpd_samples_free(&v->near[t]);
    free(v->near);
}

/* The samples of home that t's view may hold: t's own (held while t
 * runs), or a neighbour's within the halo. */
static const wpd_tile_samples *samples_of(const wpd_run *run, const view *v, int t, int home)
{
    return home == t ? &run->store[t] : &v->near[home];
}

/* Every neighbour's samples within the halo of t's box into v->near. */
static int load_near(const wpd_run *run, int t, view *v, wpd_error *err)
{
    const wpd_tile *tile = &run->plan.tiles[t];
    if (!(v->near = calloc((size_t)run->plan.ntiles, sizeof *v->near)))
        return wpd_fail(err, WPD_E_MEMORY, "out of memory in tile %d", t);
    for (int j = 0; j < tile->nadj; j++) {
        int u = tile->adj[j];
        if (wpd_store_count(run, u) && wpd_store_near(run, t, u, run->halo, &v->near[u], err))
            return -1;
    }
    return 0;
}

/* Index of gid among s's samples (ascending), or -1. */
static long find(const wpd_tile_samples *s, uint64_t gid)
{
    size_t lo = wpd_lower_bound_u64(s->gid, s->n, gid);
    return lo < s->n && s->gid[lo] == gid ? (long)lo : -1;
}

/* find, for gids asked in ascending order: *at walks s once (a view's
 * points ascend by gid, so do those from one tile). A smaller gid than the
 * last one asked falls back to a binary search. */
static long find_next(const wpd_tile_samples *s, size_t *at, uint64_t gid)
{
    if (*at > 0 && *at <= s->n && s->gid[*at - 1] >= gid)
        *at = wpd_lower_bound_u64(s->gid, s->n, gid);
    while (*at < s->n && s->gid[*at] < gid)
        (*at)++;
    return *at < s->n && s->gid[*at] == gid ? (long)*at : -1;
}

/* One walk position per tile in its samples and in its UNKNOWN list. */
typedef struct cursors {
    size_t *store, *unknown;
} cursors;

/* Sharp labels of the points of d as the Poisson pass asks for them: *edge
 * all WPD_LABEL_UNKNOWN, and a labeller over a grid of d's points (built in
 * *surface on `threads` unless it holds one already: the one tile in memory
 * shares the run's surface grid, which the Poisson pass and smoothing use
 * too), asked from `callers` threads at once (the pass's). The labels are
 * those of every point's (take_all.c); the pass asks for about a fifth of
 * them (docs/algorithm.md section 5, Cost). */
static int labels_on_demand(const wpd_run *run, const wpd_tile_data *d, wpd_grid *surface,
                            int threads, int callers, uint8_t **edge,
                            wpd_sharp_labeller **labeller, wpd_error *err)
{
    *edge = malloc(d->n ? d->n : 1);
    if (!*edge)
        return wpd_fail(err, WPD_E_MEMORY, "out of memory for %zu edge labels", d->n);
    memset(*edge, WPD_LABEL_UNKNOWN, d->n);
    if (!surface->n && wpd_grid_build_knn(surface, d->xyz, NULL, d->n, run->p->k,
                                          run->surface_dk, threads, err))
        return -1;
    *labeller = wpd_sharp_labeller_new(surface, d->xyz, run->res->radius_estimate, *edge,
                                       callers);
    return *labeller ? 0 : wpd_fail(err, WPD_E_MEMORY, "out of memory for the labeller");
}

/* What a view point is for the tile (view.cls). */
enum { DROPPED = 0, CANDIDATE = 1, FIXED = 2, THEIRS = 4 /* with CANDIDATE */ };

/* The tile that owns view point i of d. */
static int home_of(const wpd_run *run, int t, const wpd_tile_data *d, size_t i)
{
    return d->halo[i] ? run->plan.cell_tile[wpd_scan_cell_of(&run->scan, d->xyz + 3 * i)] : t;
}

/* Point i of tile t's view (asked in ascending i): fixed, dropped or
 * candidate. */
static uint8_t classify(const wpd_run *run, const pass_ctx *pc, int t, const view *v, size_t i,
                        cursors *at)
{
    const wpd_tile_data *d = &v->d;
    int home = home_of(run, t, d, i), own = home == t;
    if (!own && !pc->processed[home]) /* a later colour of round 1: undecided */
        return CANDIDATE;
    if (own && pc->round == 0)
        return CANDIDATE;
    if (find_next(samples_of(run, v, t, home), &at->store[home], d->gid[i]) >= 0)
        return FIXED;
    if (find_next(&pc->unknown[home], &at->unknown[home], d->gid[i]) >= 0)
        return own ? CANDIDATE : CANDIDATE | THEIRS;
    return DROPPED; /* removed for certain */
}

/* The candidate and fixed lists of v, sized exactly (the arena is never
 * trimmed: an array sized by the view would stay resident). */
static int fill_lists(const wpd_run *run, int t, view *v, size_t ncand, size_t nfixed,
                      size_t *at)
{
    const wpd_tile_data *d = &v->d;
    v->cand = malloc((ncand ? ncand : 1) * sizeof *v->cand);
    v->kept = malloc((ncand ? ncand : 1) * sizeof *v->kept);
    v->unknown = malloc((ncand ? ncand : 1) * sizeof *v->unknown);
    v->fixed = malloc((nfixed ? nfixed : 1) * 3 * sizeof *v->fixed);
    v->fixed_edge = run->p->sharp ? malloc(nfixed ? nfixed : 1) : NULL;
    if (!v->cand || !v->kept || !v->unknown || !v->fixed || (run->p->sharp && !v->fixed_edge))
        return -1;
    for (size_t i = 0; i < d->n; i++) {
        if (v->cls[i] & CANDIDATE) {
            v->cand[v->ncand++] = (uint32_t)i;
        } else if (v->cls[i] == FIXED) {
            /* The owner's label of its own sample is the true one. */
            int home = home_of(run, t, d, i);
            const wpd_tile_samples *s = samples_of(run, v, t, home);
            long k = s->edge ? find_next(s, &at[home], d->gid[i]) : -1;
            memcpy(v->fixed + 3 * v->nfixed, d->xyz + 3 * i, 3 * sizeof *v->fixed);
            if (v->fixed_edge)
                v->fixed_edge[v->nfixed] = k >= 0 ? s->edge[k] : 0;
            v->nfixed++;
        }
    }
    return 0;
}

/* Reads tile t and sorts its view for the three-valued pass. */
static int build_view(const wpd_run *run, const pass_ctx *pc, int t, int threads, view *v,
                      wpd_error *err)
{
    memset(v, 0, sizeof *v);
    if (wpd_tiles_read(&run->tiles, t, &v->d, err) || load_near(run, t, v, err))
        return -1;
    size_t m = v->d.n ? v->d.n : 1;
    v->cls = malloc(m);
    v->blind = malloc(m);
    v->wanted = malloc(m);
    if (!v->cls || !v->blind || !v->wanted)
        return wpd_fail(err, WPD_E_MEMORY, "out of memory in tile %d", t);
    /* The three-valued pass asks from one thread */
    if (run->p->sharp &&
        labels_on_demand(run, &v->d, &v->label_grid, threads, 1, &v->edge, &v->labeller, err))
        return -1;
    const wpd_tile *tile = &run->plan.tiles[t];
    /* r-balls past the halo, and sharp labels (computed from the points
     * within WPD_SHARP_DEPTH r0) */
    double label_depth = run->p->sharp ? WPD_SHARP_DEPTH : 1.0;
    double blind_from = run->halo - fmax(pc->r, label_depth * run->res->radius_estimate);
    size_t ncand = 0, nfixed = 0, ntiles = (size_t)run->plan.ntiles;
    cursors at = {calloc(ntiles, sizeof *at.store), calloc(ntiles, sizeof *at.unknown)};
    int rc = at.store && at.unknown ? 0 : -1;
    for (size_t i = 0; rc == 0 && i < v->d.n; i++) {
        const double *x = v->d.xyz + 3 * i;
        uint8_t c = v->cls[i] = classify(run, pc, t, v, i, &at);
        ncand += (c & CANDIDATE) != 0;
        nfixed += c == FIXED;
        v->theirs += (c & THEIRS) != 0;
        v->blind[i] = v->d.halo[i] && wpd_tile_distance2(tile, x) >= blind_from * blind_from;
        v->wanted[i] = !v->d.halo[i] || (c & THEIRS);
    }
    if (rc == 0) {
        memset(at.store, 0, ntiles * sizeof *at.store);
        rc = fill_lists(run, t, v, ncand, nfixed, at.store);
    }
    /* Earlier nights' samples within conflict distance of a candidate. */
    if (rc == 0 && wpd_fixed_append(run, t, run->halo + pc->r, &v->fixed, &v->fixed_edge,
                                    &v->nfixed, err)) {
        free(at.store);
        free(at.unknown);
        return -1;
    }
    free(at.store);
    free(at.unknown);
    return rc ? wpd_fail(err, WPD_E_MEMORY, "out of memory in tile %d", t) : 0;
}

/* Tile t's new state: its certain kept own points join its samples, its
 * unknown own points replace its unknown list. */
static int settle(wpd_run *run, pass_ctx *pc, int t, const view *v, size_t nkept,
                  size_t nunknown)
{
    const wpd_tile_data *d = &v->d;
    wpd_tile_samples *s = &run->store[t], *u = &pc->unknown[t], grown, left;
    size_t own_kept = 0, own_unknown = 0;
    for (size_t i = 0; i < nkept; i++)
        own_kept += !d->halo[v->kept[i]];
    for (size_t i = 0; i < nunknown; i++)
        own_unknown += !d->halo[v->unknown[i]];
    int with_edge = v->edge != NULL;
    if (wpd_samples_alloc(&grown, s->n + own_kept, with_edge) ||
        wpd_samples_alloc(&left, own_unknown, with_edge)) {
        wpd_samples_free(&grown);
        return -1;
    }
    /* Merge the old samples with the new ones, both ascending by gid. */
    size_t a = 0, b = 0;
    while (a < s->n || b < nkept) {
        if (b < nkept && d->halo[v->kept[b]]) {
            b++;
            continue;
        }
        int from_old = b == nkept || (a < s->n && s->gid[a] < d->gid[v->kept[b]]);
        size_t k = grown.n++;
        grown.gid[k] = from_old ? s->gid[a] : d->gid[v->kept[b]];
        memcpy(grown.xyz + 3 * k, from_old ? s->xyz + 3 * a : d->xyz + 3 * (size_t)v->kept[b],
               3 * sizeof *grown.xyz);
        if (with_edge)
            grown.edge[k] = from_old ? s->edge[a] : v->edge[v->kept[b]];
        from_old ? a++ : b++;
    }
    for (size_t i = 0; i < nunknown; i++) {
        uint32_t j = v->unknown[i];
        if (d->halo[j]) /* only own points go on the tile's list */
            continue;
        left.gid[left.n] = d->gid[j];
        memcpy(left.xyz + 3 * left.n, d->xyz + 3 * (size_t)j, 3 * sizeof *left.xyz);
        if (with_edge)
            left.edge[left.n] = v->edge[j];
        left.n++;
    }
    wpd_samples_free(s);
    wpd_samples_free(u);
    *s = grown;
    *u = left;
    pc->processed[t] = 1;
    return 0;
}

static void foreign_free(foreign *f)
{
    free(f->gid);
    free(f->xyz);
    free(f->edge);
    free(f->kept);
    free(f->owner);
    memset(f, 0, sizeof *f);
}

/* Walks v's candidates that are other tiles' UNKNOWN points and were
 * decided for certain here (kept[] and unknown[] ascending): counts them,
 * and with f's arrays allocated, stores them. */
static size_t walk_theirs(const wpd_run *run, const view *v, size_t nkept, size_t nunknown,
                          foreign *f)
{
    size_t a = 0, b = 0, m = 0;
    for (size_t c = 0; c < v->ncand; c++) {
        uint32_t i = v->cand[c];
        while (a < nkept && v->kept[a] < i)
            a++;
        while (b < nunknown && v->unknown[b] < i)
            b++;
        int kept = a < nkept && v->kept[a] == i, unknown = b < nunknown && v->unknown[b] == i;
        if (!(v->cls[i] & THEIRS) || unknown) /* UNKNOWN here too: nothing to tell */
            continue;
        if (f->gid) {
            const double *x = v->d.xyz + 3 * (size_t)i;
            f->gid[m] = v->d.gid[i];
            memcpy(f->xyz + 3 * m, x, 3 * sizeof *f->xyz);
            f->edge[m] = v->edge && v->edge[i] == 1; /* a removed point's may be unknown */
            f->kept[m] = (uint8_t)kept;
            f->owner[m] = run->plan.cell_tile[wpd_scan_cell_of(&run->scan, x)];
        }
        m++;
    }
    return m;
}

/* The certain decisions of v about other tiles' UNKNOWN points, into *f,
 * sized exactly: they wait for the end of the colour, and the
 * arena keeps whatever size it once held. Returns 0 or -1. */
static int record_theirs(const wpd_run *run, const view *v, size_t nkept, size_t nunknown,
                         foreign *f)
{
    size_t m = v->theirs ? walk_theirs(run, v, nkept, nunknown, f) : 0;
    if (m == 0)
        return 0;
    f->gid = malloc(m * sizeof *f->gid);
    f->xyz = malloc(3 * m * sizeof *f->xyz);
    f->edge = malloc(m);
    f->kept = malloc(m);
    f->owner = malloc(m * sizeof *f->owner);
    if (!f->gid || !f->xyz || !f->edge || !f->kept || !f->owner)
        return -1;
    f->n = walk_theirs(run, v, nkept, nunknown, f);
    return 0;
}

/* One decision handed back: entry i of foreign list f. */
typedef struct handed {
    int owner;
    uint64_t gid;
    const foreign *f;
    size_t i;
} handed;

static int cmp_handed(const void *a, const void *b)
{
    const handed *x = a, *y = b;
    if (x->owner != y->owner)
        return x->owner < y->owner ? -1 : 1;
    return (x->gid > y->gid) - (x->gid < y->gid);
}

/* Applies the decisions h[0..m-1] (one owner, ascending gid, no repeat)
 * to that owner: each point leaves its UNKNOWN list, and the kept ones join
 * its samples (both lists stay in gid order: one merge each). Returns 0 or
 * -1. */
static int settle_handed(wpd_run *run, pass_ctx *pc, const handed *h, size_t m,
                         wpd_error *err)
{
    int o = h[0].owner;
    if (wpd_store_load(run, o, err))
        return -1;
    wpd_tile_samples *u = &pc->unknown[o], *s = &run->store[o], grown;
    int with_edge = s->edge != NULL;
    if (wpd_samples_alloc(&grown, s->n + m, with_edge)) {
        wpd_store_drop(run, o);
        return wpd_fail(err, WPD_E_MEMORY, "out of memory in tile %d", o);
    }
    size_t a = 0, b = 0, left = 0, k = 0;
    for (size_t i = 0; i < u->n; i++) { /* the UNKNOWN list without h's points */
        while (k < m && h[k].gid < u->gid[i])
            k++;
        if (k < m && h[k].gid == u->gid[i])
            continue;
        u->gid[left] = u->gid[i];
        memmove(u->xyz + 3 * left, u->xyz + 3 * i, 3 * sizeof *u->xyz);
        if (u->edge)
            u->edge[left] = u->edge[i];
        left++;
    }
    u->n = left;
    while (a < s->n || b < m) { /* the samples with h's kept points */
        if (b < m && !h[b].f->kept[h[b].i]) {
            b++;
            continue;
        }
        int old = b == m || (a < s->n && s->gid[a] < h[b].gid);
        const foreign *f = old ? NULL : h[b].f;
        size_t j = old ? a : h[b].i, g = grown.n++;
        grown.gid[g] = old ? s->gid[j] : f->gid[j];
        memcpy(grown.xyz + 3 * g, old ? s->xyz + 3 * j : f->xyz + 3 * j, 3 * sizeof *grown.xyz);
        if (with_edge)
            grown.edge[g] = old ? s->edge[j] : f->edge[j];
        old ? a++ : b++;
    }
    wpd_samples_free(s);
    *s = grown;
    return wpd_store_save(run, o, err);
}

/* After the tiles of a colour: their certain decisions about other tiles'
 * UNKNOWN points go to the owners. Two tiles may decide the same point:
 * certain decisions agree, so it is applied once. */
static int hand_back(wpd_run *run, int colour, void *arg, wpd_error *err)
{
    pass_ctx *pc = arg;
    size_t total = 0;
    for (int t = 0; t < run->plan.ntiles; t++)
        if (run->plan.tiles[t].colour == colour)
            total += pc->foreign[t].n;
    handed *h = malloc((total ? total : 1) * sizeof *h);
    if (!h)
        return wpd_fail(err, WPD_E_MEMORY, "out of memory for %zu decisions", total);
    size_t m = 0;
    for (int t = 0; t < run->plan.ntiles; t++) {
        const foreign *f = &pc->foreign[t];
        for (size_t i = 0; run->plan.tiles[t].colour == colour && i < f->n; i++)
            if (find(&pc->unknown[f->owner[i]], f->gid[i]) >= 0) /* else settled already */
                h[m++] = (handed){f->owner[i], f->gid[i], f, i};
    }
    qsort(h, m, sizeof *h, cmp_handed);
    size_t unique = 0;
    for (size_t i = 0; i < m; i++)
        if (unique == 0 || h[i].gid != h[unique - 1].gid || h[i].owner != h[unique - 1].owner)
            h[unique++] = h[i];
    int rc = 0;
    for (size_t i = 0, j; rc == 0 && i < unique; i = j) {
        for (j = i; j < unique && h[j].owner == h[i].owner; j++)
            ;
        rc = settle_handed(run, pc, h + i, j - i, err);
    }
    free(h);
    for (int t = 0; t < run->plan.ntiles; t++)
        if (run->plan.tiles[t].colour == colour)
            foreign_free(&pc->foreign[t]);
    return rc;
}

/* With the tiles shared between ranks (ranks.h): what a tile's run leaves
 * beside its samples - its UNKNOWN own points, its decisions about other
 * tiles' (hand_back applies them on every rank alike) and that it ran. */
static void pack_tile_state(const wpd_run *run, int t, void *arg, wpd_bytes *out)
{
    (void)run;
    const pass_ctx *pc = arg;
    const foreign *f = &pc->foreign[t];
    wpd_samples_pack(&pc->unknown[t], out);
    wpd_tile_samples theirs = {f->n, f->gid, f->xyz, f->edge};
    wpd_samples_pack(&theirs, out);
    wpd_bytes_put(out, f->kept, f->n);
    wpd_bytes_put(out, f->owner, f->n * sizeof *f->owner);
    wpd_bytes_put(out, &pc->processed[t], 1);
}

static int unpack_tile_state(wpd_run *run, int t, void *arg, wpd_bytes_in *in, wpd_error *err)
{
    pass_ctx *pc = arg;
    foreign *f = &pc->foreign[t];
    wpd_tile_samples theirs;
    wpd_samples_free(&pc->unknown[t]);
    foreign_free(f);
    if (wpd_samples_unpack(&pc->unknown[t], in) || wpd_samples_unpack(&theirs, in))
        goto bad;
    f->n = theirs.n, f->gid = theirs.gid, f->xyz = theirs.xyz, f->edge = theirs.edge;
    f->kept = malloc(f->n ? f->n : 1);
    f->owner = malloc((f->n ? f->n : 1) * sizeof *f->owner);
    if (!f->kept || !f->owner || wpd_bytes_get(in, f->kept, f->n) ||
        wpd_bytes_get(in, f->owner, f->n * sizeof *f->owner) ||
        wpd_bytes_get(in, &pc->processed[t], 1))
        goto bad;
    for (size_t i = 0; i < f->n; i++)
        if (f->owner[i] < 0 || f->owner[i] >= run->plan.ntiles)
            goto bad;
    return 0;
bad:
    return wpd_fail(err, in->bad ? WPD_E_IO : WPD_E_MEMORY, "tile %d's Poisson state from "
                    "another rank: %s", t, in->bad ? "does not add up" : "out of memory");
}

static const wpd_tile_share tile_state = {pack_tile_state, unpack_tile_state, 0};

/* wpd_poisson_pass_certain with labels asked of labeller (NULL: none). */
static long certain_pass(const wpd_poisson_certain_input *in, wpd_sharp_labeller *labeller,
                         uint32_t *kept, uint32_t *unknown, size_t *nunknown, wpd_error *err)
{
    *nunknown = 0;
    if (in->base.ncand == 0)
        return 0;
    wpd_poisson *ps = wpd_poisson_prepare_certain(in, err);
    if (!ps)
        return -1;
    if (labeller)
        wpd_poisson_set_labeller(ps, wpd_sharp_label, labeller);
    long got = wpd_poisson_run_certain(ps, in->base.r, kept, unknown, nunknown, err);
    wpd_poisson_release(ps);
    return got;
}

/* One tile of a round of the pass at radius pc->r. */
static int certain_tile(wpd_run *run, int t, int threads, void *arg, wpd_error *err)
{
    pass_ctx *pc = arg;
    if (pc->round > 0 && pc->unknown[t].n == 0)
        return 0;
    if (pc->round > 0) {
#pragma omp atomic
        run->res->resolution_tiles++;
    }
    view v;
    int rc = -1;
    if (wpd_store_load(run, t, err))
        return -1;
    if (build_view(run, pc, t, threads, &v, err))
        goto done;
    const wpd_params *p = run->p;
    wpd_poisson_certain_input in = {
        {v.d.xyz, v.d.gid, v.edge, v.cand, v.ncand, v.fixed, v.nfixed, pc->r, p->seed, threads},
        v.blind, v.fixed_edge, v.wanted};
    size_t nunknown = 0;
    long m = certain_pass(&in, v.labeller, v.kept, v.unknown, &nunknown, err);
    if (m < 0)
        goto done;
    if (settle(run, pc, t, &v, (size_t)m, nunknown) ||
        record_theirs(run, &v, (size_t)m, nunknown, &pc->foreign[t])) {
        wpd_fail(err, WPD_E_MEMORY, "out of memory in tile %d", t);
        goto done;
    }
    if (v.edge && pc->round == 0 && run->res->passes == 0) {
        uint64_t sharp = 0;
        for (size_t i = 0; i < v.d.n; i++)
            sharp += v.edge[i] == 1 && !v.d.halo[i];
#pragma omp atomic
        run->res->sharp_points += sharp;
    }
    if (v.labeller) {
        uint64_t asked = wpd_sharp_labeller_count(v.labeller);
#pragma omp atomic
        run->res->sharp_labelled += asked;
    }
    rc = 0;
done:
    view_free(run, &v);
    return wpd_store_finish(run, t, rc, err);
}

/* The one tile of an in-memory run: no halo, nothing unknown; the grid and
 * priorities are prepared once for every pass of the refinement. */
static int memory_tile(wpd_run *run, pass_ctx *pc, wpd_error *err)
{
    const wpd_params *p = run->p;
    wpd_tile_data d;
    if (wpd_tiles_read(&run->tiles, 0, &d, err))
        return -1;
    uint32_t *kept = malloc((d.n ? d.n : 1) * sizeof *kept);
    int rc = -1;
    if (!kept) {
        wpd_fail(err, WPD_E_MEMORY, "out of memory for %zu points", d.n);
        goto done;
    }
    if (p->sharp && !pc->memo_edge &&
        labels_on_demand(run, &d, &run->surface, run->threads, run->threads, &pc->memo_edge,
                         &pc->memo_labeller, err))
        goto done;
    if (!pc->memo) {
        /* The surface grid, when the run built one over these points. */
        wpd_poisson_input in = {d.xyz, d.gid, pc->memo_edge, NULL, d.n, run->fixed.xyz,
                                run->fixed.n, pc->r, p->seed, run->threads};
        pc->memo = run->surface.n == d.n && d.n ? wpd_poisson_prepare_on(&in, &run->surface, err)
                                                : wpd_poisson_prepare(&in, err);
        if (!pc->memo)
            goto done;
        if (pc->memo_labeller)
            wpd_poisson_set_labeller(pc->memo, wpd_sharp_label, pc->memo_labeller);
    }
    long m = wpd_poisson_run(pc->memo, pc->r, kept, err);
    if (m < 0)
        goto done;
    view v = {.d = d, .edge = pc->memo_edge, .kept = kept};
    if (settle(run, pc, 0, &v, (size_t)m, 0)) {
        wpd_fail(err, WPD_E_MEMORY, "out of memory for %ld samples", m);
        goto done;
    }
    rc = 0;
done:
    free(kept);
    wpd_tiles_release(&run->tiles, &d);
    return rc;
}

static size_t unknown_count(const wpd_run *run, const pass_ctx *pc)
{
    size_t n = 0;
    for (int t = 0; t < run->plan.ntiles; t++)
        n += pc->unknown[t].n;
    return n;
}

static int full_pass(wpd_run *run, pass_ctx *pc, size_t *count, wpd_error *err)
{
    int ntiles = run->plan.ntiles;
    wpd_run_store_clear(run);
    for (int t = 0; t < ntiles; t++)
        wpd_samples_free(&pc->unknown[t]);
    memset(pc->processed, 0, (size_t)run->plan.ntiles);
    if (ntiles == 1) {
        pc->round = 0;
        if (memory_tile(run, pc, err))
            return -1;
    } else {
        for (pc->round = 0; pc->round == 0 || unknown_count(run, pc) > 0; pc->round++) {
            if (pc->round == MAX_ROUNDS)
                return wpd_fail(err, WPD_E_USAGE, "poisson: %zu points still undecided after "
                                "%d rounds (a bug)", unknown_count(run, pc), MAX_ROUNDS);
            if (wpd_run_each_tile_shared(run, pc->round ? NULL : "poisson", certain_tile,
                                         hand_back, &tile_state, pc, err))
                return -1;
        }
        run->res->resolution_rounds += pc->round - 1;
    }
    *count = wpd_run_store_count(run);
    run->res->passes++;
    return 0;
}

static void pass_ctx_free(const wpd_run *run, pass_ctx *pc)
{
    for (int t = 0; pc->unknown && t < run->plan.ntiles; t++)
        wpd_samples_free(&pc->unknown[t]);
    for (int t = 0; pc->foreign && t < run->plan.ntiles; t++)
        foreign_free(&pc->foreign[t]);
    free(pc->unknown);
    free(pc->foreign);
    free(pc->processed);
    wpd_poisson_release(pc->memo);
    wpd_sharp_labeller_free(pc->memo_labeller);
    free(pc->memo_edge);
    memset(pc, 0, sizeof *pc);
}

/* Full passes until one keeps at least n samples (refine.h); the exact
 * count deletes the surplus. A pass runs at most at 1.25 r0 (a first pass
 * far above n is redone at a larger radius, capped there; an undershoot
 * shrinks r), so the halo of 2.5 r0 always holds the r-ball of every own
 * point, and blind points are those farther than H - max(r, r0) (with
 * --sharp H - max(r, 2 r0): build_view). */
int wpd_poisson_phase(wpd_run *run, wpd_error *err)
{
    size_t n = run->opt->target, count = 0;
    wpd_refine st;
    wpd_refine_init(&st, n, run->res->radius_estimate, run->p->max_passes);
    pass_ctx pc = {0};
    pc.unknown = calloc((size_t)run->plan.ntiles, sizeof *pc.unknown);
    pc.processed = calloc((size_t)run->plan.ntiles, 1);
    pc.foreign = calloc((size_t)run->plan.ntiles, sizeof *pc.foreign);
    if (!pc.unknown || !pc.processed || !pc.foreign) {
        pass_ctx_free(run, &pc);
        return wpd_fail(err, WPD_E_MEMORY, "out of memory");
    }
    int rc = -1;
    for (;;) {
        pc.r = st.r;
        if (full_pass(run, &pc, &count, err))
            break;
        if (run->res->passes == 1)
            run->res->first_pass_count = count;
        run->radius = pc.r;
        wpd_refine_status s = wpd_refine_report(&st, count);
        if (s != WPD_REFINE_AGAIN) {
            rc = 0;
            break;
        }
    }
    if (pc.memo_labeller) { /* the one tile in memory: labels asked in every pass */
        run->res->sharp_labelled = wpd_sharp_labeller_count(pc.memo_labeller);
        for (size_t i = 0; i < run->tiles.mem.n; i++)
            run->res->sharp_points += pc.memo_edge[i] == 1;
    }
    pass_ctx_free(run, &pc);
    run->res->poisson_count = wpd_run_store_count(run);
    if (rc == 0 && run->owner && run->plan.ntiles > 1) {
        /* Each rank counted its own tiles' (one tile is not shared: every
         * rank ran it and counted the same) */
        uint64_t sum[3] = {(uint64_t)run->res->resolution_tiles, run->res->sharp_points,
                           run->res->sharp_labelled};
        rc = wpd_par_sum_u64(run->opt->par, sum, 3, err);
        run->res->resolution_tiles = (int)sum[0];
        run->res->sharp_points = sum[1];
        run->res->sharp_labelled = sum[2];
    }
    return rc;
}
