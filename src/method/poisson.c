/* poisson.c - greedy Poisson-disk pruning on the sorted-cell grid. */
#include "method/poisson.h"

#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "core/grid.h"
#include "common/hugepage.h"
#include "core/hash.h"
#include "core/sort.h"
#include "method/poisson_state.h"

/* Marks REMOVED every undecided slot in conflict with a point at p of
 * radius rp (a fixed point), TENTATIVE where that depends on a label not
 * known yet. */
static void remove_around(pass_state *ps, const double p[3], double rp)
{
    const wpd_grid *g = ps->g;
    int64_t lo[3], hi[3];
    if (!wpd_grid_box(g, p, 0.5 * (rp + ps->r), lo, hi))
        return;
    double full2 = full_conflict2(ps, rp), hd = 0.5 * (rp + 0.5 * ps->r), half2 = hd * hd;
    for (int64_t b = lo[1]; b <= hi[1]; b++)
        for (int64_t a = lo[0]; a <= hi[0]; a++) {
            uint32_t sb, se;
            wpd_grid_column_slots(g, a, b, lo[2], hi[2], &sb, &se);
            for (uint32_t s = sb; s < se; s++) {
                if ((ps->state[s] & STATUS_MASK) != UNDECIDED)
                    continue;
                double d2 = dist2(g->xyz + 3 * (size_t)s, p);
                if (d2 >= full2)
                    continue;
                /* Beyond half2 only a point of radius r is in conflict (a
                 * blind slot's smallest radius is r/2: KIND_BLIND is 2). */
                uint8_t k = ps->half && d2 >= half2 ? ps->half[s] : 0;
                if (k & LABEL_UNSURE)
                    ps->state[s] |= TENTATIVE;
                else if (!(k & 3))
                    set_removed(&ps->state[s]);
            }
        }
}

/* Tries to accept slot t: one scan of its neighbourhood collects the
 * undecided slots in conflict with it (DEFERRED ones count as undecided);
 * if one of them has a smaller priority (it can only be in t's band), that
 * one must be decided first and is returned - DEFER_ME if it is DEFERRED -
 * and nothing changes but labels asked. Otherwise t is accepted, the
 * collected slots are removed (TENTATIVE where that depends on a label not
 * known yet), and UINT32_MAX is returned. Returns UINT32_MAX - 1 if a
 * collection buffer cannot grow. */
static uint32_t try_accept(pass_state *ps, uint32_t t, double rt)
{
    const wpd_grid *g = ps->g;
    const double *p = g->xyz + 3 * (size_t)t;
    uint64_t pt = ps->prio[t];
    uint8_t band = BAND_OF(ps->state[t]);
    size_t found = 0, maybes = 0;
    int64_t lo[3], hi[3];
    double full2 = full_conflict2(ps, rt), hd = 0.5 * (rt + 0.5 * ps->r), half2 = hd * hd;
    if (wpd_grid_box(g, p, 0.5 * (rt + ps->r), lo, hi))
        for (int64_t b = lo[1]; b <= hi[1]; b++)
            for (int64_t a = lo[0]; a <= hi[0]; a++) {
                uint32_t sb, se;
                wpd_grid_column_slots(g, a, b, lo[2], hi[2], &sb, &se);
                for (uint32_t s = sb; s < se; s++) {
                    uint8_t st = ps->state[s], status = st & STATUS_MASK;
                    if ((status != UNDECIDED && status != DEFERRED) || s == t)
                        continue;
                    double d2 = dist2(g->xyz + 3 * (size_t)s, p);
                    if (d2 >= full2)
                        continue;
                    int where = d2 >= half2 && ps->half ? beyond_half(ps, s, st, 0) : IN;
                    if (where == SKIP)
                        continue;
                    if (BAND_OF(st) == band && ps->prio[s] < pt) {
                        if (!blocks(ps, s, where == MAYBE, st))
                            continue;
                        return (ps->state[s] & STATUS_MASK) == DEFERRED ? DEFER_ME : s;
                    }
                    if (where == MAYBE ? collect_slot(&ps->maybe, &ps->maybe_cap, &maybes, s)
                                       : collect_slot(&ps->hits, &ps->hit_cap, &found, s))
                        return UINT32_MAX - 1;
                }
            }
    ps->state[t] |= ACCEPTED;
    for (size_t i = 0; i < found; i++)
        set_removed(&ps->state[ps->hits[i]]);
    for (size_t i = 0; i < maybes; i++)
        ps->state[ps->maybe[i]] |= TENTATIVE;
    return UINT32_MAX;
}

/* Decides slot s and whatever it depends on, with the two-valued
 * (try_accept) or the three-valued rules (try_decide). Returns 0, or -1 if
 * out of memory. */
static int resolve(pass_state *ps, uint32_t s, int certain)
{
    size_t top = 0;
    ps->stack[top++] = s;
    while (top > 0) {
        uint32_t t = ps->stack[top - 1];
        if (ps->half)
            settle_tentative(ps, t);
        if ((ps->state[t] & STATUS_MASK) != UNDECIDED) {
            top--;
            continue;
        }
        uint32_t blocker = certain ? wpd_poisson_try_decide(ps, t)
                                   : try_accept(ps, t, ps->half && label_of(ps, t) ? 0.5 * ps->r
                                                                                  : ps->r);
        if (blocker == UINT32_MAX) {
            top--;
            continue;
        }
        if (blocker == UINT32_MAX - 1)
            return -1;
        if (top == ps->stack_cap && grow(&ps->stack, &ps->stack_cap) < 0)
            return -1;
        ps->stack[top++] = blocker;
    }
    return 0;
}

static int cmp_u32(const void *a, const void *b)
{
    uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return (x > y) - (x < y);
}

struct wpd_poisson {
    wpd_poisson_input in;  /* the candidates (pointers borrowed) */
    int threads;
    wpd_grid own;          /* the grid built here (cell = the radius it was
                              prepared for), unless one is borrowed */
    const wpd_grid *g;     /* &own, or the caller's grid (never rebuilt) */
    uint64_t *prio;        /* [n] per slot */
    uint8_t *band;         /* [n] per slot: band << 2 (the initial state byte) */
    uint8_t *half;         /* [n] per slot: sharp-feature point, or NULL */
    uint8_t *kind;         /* [n] per slot: KIND_* (blind flags given), or NULL */
    const uint8_t *blind;  /* per point, borrowed; NULL: a two-valued context */
    const uint8_t *fixed_edge; /* per fixed point, borrowed, or NULL */
    const uint8_t *wanted; /* per point, borrowed, or NULL (all wanted) */
    uint32_t *order;       /* [n] slots by band, then slot */
    size_t band_first[NBANDS + 1]; /* where each band starts in order */
    uint8_t *state;        /* [n] per slot, per pass */
    uint32_t *stack;
    size_t stack_cap;
    uint32_t *hits;
    size_t hit_cap;
    uint32_t *maybe;
    size_t maybe_cap;
    size_t unsure;         /* slots whose label is asked on demand */
    wpd_labeller label;    /* asked for them, or NULL */
    void *label_ctx;
};

/* Builds the grid for cell size r (unless it is borrowed) and everything
 * that depends on slots. */
static int prepare_slots(wpd_poisson *ps, double r, wpd_error *err)
{
    const wpd_poisson_input *in = &ps->in;
    size_t n = in->ncand;
    if (ps->g == &ps->own &&
        wpd_grid_build(&ps->own, in->xyz, in->cand, n, r, ps->threads, err) < 0)
        return -1;
    const wpd_grid *g = ps->g;
    uint64_t seed = in->seed;
    const uint64_t *gid = in->gid;
    const uint8_t *edge = in->edge, *blind = ps->blind;
    uint64_t *prio = ps->prio;
    uint8_t *band = ps->band, *half = ps->half, *kind = ps->kind;
    size_t unsure = 0;
#pragma omp parallel for num_threads(ps->threads) schedule(static) reduction(+ : unsure)
    for (size_t s = 0; s < n; s++) {
        uint32_t id = g->id[s];
        prio[s] = wpd_priority(seed, gid[id]);
        band[s] = (uint8_t)((prio[s] >> (64 - BAND_BITS)) << 2);
        int b = blind && blind[id];
        uint8_t l = !edge ? 0 : edge[id] == WPD_LABEL_UNKNOWN ? (b ? 0 : LABEL_UNSURE)
                              : edge[id] != 0 ? LABEL_HALF : 0;
        if (half)
            half[s] = l;
        if (kind)
            kind[s] = (uint8_t)(l | (b ? KIND_BLIND | KIND_LAZY : 0) |
                                (ps->wanted && !ps->wanted[id] ? KIND_LAZY : 0));
        unsure += l == LABEL_UNSURE;
    }
    ps->unsure = unsure;
    size_t start[NBANDS + 1] = {0};
    for (size_t s = 0; s < n; s++)
        start[(band[s] >> 2) + 1]++;
    for (unsigned b = 0; b < NBANDS; b++)
        start[b + 1] += start[b];
    memcpy(ps->band_first, start, sizeof start);
    for (size_t s = 0; s < n; s++)
        ps->order[start[band[s] >> 2]++] = (uint32_t)s;
    return 0;
}

static wpd_poisson *prepare(const wpd_poisson_input *in, const wpd_grid *grid,
                            const uint8_t *blind, const uint8_t *fixed_edge, const uint8_t *wanted,
                            wpd_error *err)
{
    if (!(in->r > 0) || !isfinite(in->r)) {
        wpd_fail(err, WPD_E_USAGE, "poisson: radius %g is not positive", in->r);
        return NULL;
    }
    size_t n = in->ncand;
    wpd_poisson *ps = calloc(1, sizeof *ps);
    if (!ps)
        goto oom;
    ps->in = *in;
    ps->g = grid ? grid : &ps->own;
    ps->blind = blind;
    ps->fixed_edge = fixed_edge;
    ps->wanted = wanted;
    ps->threads = in->threads > 0 ? in->threads : omp_get_max_threads();
    size_t m = n ? n : 1;
    ps->prio = wpd_malloc_large(m * sizeof *ps->prio);
    ps->band = wpd_malloc_large(m);
    ps->half = in->edge ? wpd_malloc_large(m) : NULL;
    ps->kind = blind || wanted ? wpd_malloc_large(m) : NULL;
    ps->order = wpd_malloc_large(m * sizeof *ps->order);
    ps->state = wpd_malloc_large(m);
    ps->stack_cap = 1024;
    ps->stack = malloc(ps->stack_cap * sizeof *ps->stack);
    ps->hit_cap = ps->maybe_cap = 1024;
    ps->hits = malloc(ps->hit_cap * sizeof *ps->hits);
    ps->maybe = malloc(ps->maybe_cap * sizeof *ps->maybe);
    if (!ps->prio || !ps->band || (in->edge && !ps->half) || ((blind || wanted) && !ps->kind) ||
        !ps->order || !ps->state ||
        !ps->stack || !ps->hits || !ps->maybe)
        goto oom;
    if (prepare_slots(ps, in->r, err) < 0) {
        wpd_poisson_release(ps);
        return NULL;
    }
    return ps;
oom:
    wpd_poisson_release(ps);
    wpd_fail(err, WPD_E_MEMORY, "poisson: out of memory for %zu candidates", n);
    return NULL;
}

wpd_poisson *wpd_poisson_prepare(const wpd_poisson_input *in, wpd_error *err)
{
    return prepare(in, NULL, NULL, NULL, NULL, err);
}

wpd_poisson *wpd_poisson_prepare_on(const wpd_poisson_input *in, const wpd_grid *grid,
                                    wpd_error *err)
{
    if (grid->n != in->ncand) {
        wpd_fail(err, WPD_E_USAGE, "poisson: a grid of %zu points for %zu candidates (a bug)",
                 grid->n, in->ncand);
        return NULL;
    }
    return prepare(in, grid, NULL, NULL, NULL, err);
}

wpd_poisson *wpd_poisson_prepare_certain(const wpd_poisson_certain_input *in, wpd_error *err)
{
    return prepare(&in->base, NULL, in->blind, in->fixed_edge, in->wanted, err);
}

void wpd_poisson_set_labeller(wpd_poisson *ps, wpd_labeller fn, void *ctx)
{
    ps->label = fn;
    ps->label_ctx = ctx;
}

void wpd_poisson_release(wpd_poisson *ps)
{
    if (!ps)
        return;
    wpd_grid_free(&ps->own);
    free(ps->prio);
    free(ps->band);
    free(ps->half);
    free(ps->kind);
    free(ps->order);
    free(ps->state);
    free(ps->stack);
    free(ps->hits);
    free(ps->maybe);
    free(ps);
}

/* ---- The two-valued pass on several threads ------------------------------
 *
 * Slots are in key order, rows of the grid's outer column axis one after
 * the other, so the slots are cut into one territory of whole rows per
 * thread (up to MAX_TERRITORIES). Band by band, each thread decides the
 * undecided slots of its territory as the sequential pass would
 * (try_accept, resolving blockers first), but never one whose conflict
 * box leaves its rows: such a slot,
 * and every slot on the resolve stack that waits for it, is DEFERRED (the
 * UNKNOWN status, unused by this pass). A slot decided this way had every
 * undecided slot of smaller priority in conflict decided first, as in the
 * sequential pass, and touched only its own rows, so the threads never
 * share a slot. The deferred slots then go through the sequential pass,
 * in band order, before the next band starts: every slot gets the
 * sequential pass's decision, whatever the threads. On NC Raleigh to 10 K
 * on 2 threads, 951 of the 2.27 M slots are deferred (those within r of
 * the cut and the few that wait for them). */
#define PARALLEL_GREEDY_MIN ((size_t)1 << 18)

/* One thread's part of a band. */
typedef struct territory {
    int64_t row_lo, row_hi;  /* its rows (outer column axis), inclusive */
    size_t slot_lo, slot_hi; /* its slots */
    pass_state st;           /* own stack and hits */
    uint32_t *deferred;
    size_t ndeferred, deferred_cap;
    int failed;
} territory;

/* Whether slot u's conflict box leaves the territory's rows. */
static int leaves(const pass_state *ps, const territory *tr, uint32_t u)
{
    int64_t lo[3], hi[3];
    if (!wpd_grid_box(ps->g, ps->g->xyz + 3 * (size_t)u, ps->r, lo, hi))
        return 0;
    return lo[1] < tr->row_lo || hi[1] > tr->row_hi;
}

/* Marks the undecided slots of the stack DEFERRED. Returns 0, or -1 if
 * the list cannot grow. */
static int defer_stack(territory *tr, size_t top)
{
    pass_state *ps = &tr->st;
    for (size_t i = 0; i < top; i++) {
        uint32_t u = ps->stack[i];
        if ((ps->state[u] & STATUS_MASK) != UNDECIDED)
            continue;
        if (tr->ndeferred == tr->deferred_cap && grow(&tr->deferred, &tr->deferred_cap) < 0)
            return -1;
        ps->state[u] |= DEFERRED;
        tr->deferred[tr->ndeferred++] = u;
    }
    return 0;
}

/* resolve (two-valued) within a territory. Returns 0, or -1 out of memory. */
static int resolve_local(territory *tr, uint32_t s)
{
    pass_state *ps = &tr->st;
    size_t top = 0;
    ps->stack[top++] = s;
    while (top > 0) {
        uint32_t t = ps->stack[top - 1];
        if (ps->half)
            settle_tentative(ps, t);
        uint8_t status = ps->state[t] & STATUS_MASK;
        if (status != UNDECIDED && status != DEFERRED) {
            top--;
            continue;
        }
        uint32_t blocker = status == DEFERRED || leaves(ps, tr, t)
                               ? DEFER_ME
                               : try_accept(ps, t, ps->half && label_of(ps, t) ? 0.5 * ps->r : ps->r);
        if (blocker == UINT32_MAX) {
            top--;
            continue;
        }
        if (blocker == DEFER_ME)
            return defer_stack(tr, top);
        if (blocker == UINT32_MAX - 1 ||
            (top == ps->stack_cap && grow(&ps->stack, &ps->stack_cap) < 0))
            return -1;
        ps->stack[top++] = blocker;
    }
    return 0;
}

static int64_t row_of(const wpd_grid *g, size_t s)
{
    return wpd_grid_coord(g, g->axis[1], g->xyz[3 * s + (size_t)g->axis[1]]);
}

/* Cuts the slots into nt territories of whole rows. */
static void cut_territories(const wpd_grid *g, territory *tr, int nt)
{
    size_t n = g->n, at = 0;
    for (int k = 0; k < nt; k++) {
        size_t end = n;
        if (k + 1 < nt) {
            end = n * (size_t)(k + 1) / (size_t)nt;
            int64_t row = row_of(g, end);
            while (end > at && row_of(g, end - 1) == row) /* back to the row's start */
                end--;
        }
        tr[k].slot_lo = at;
        tr[k].slot_hi = end;
        tr[k].row_lo = k == 0 ? INT64_MIN : row_of(g, at);
        tr[k].row_hi = k + 1 == nt ? INT64_MAX : row_of(g, end) - 1;
        at = end;
    }
}

/* At most this many territories: beyond, the cuts' deferred slots would
 * outweigh the gain. */
#define MAX_TERRITORIES 8

/* The two-valued pass over every band, on nt threads (at most
 * MAX_TERRITORIES; st: the sequential state, used for the deferred slots).
 * Returns 0, or -1 out of memory. */
static int greedy_parallel(wpd_poisson *ps, pass_state *st, int nt)
{
    territory tr[MAX_TERRITORIES];
    nt = nt > MAX_TERRITORIES ? MAX_TERRITORIES : nt;
    memset(tr, 0, sizeof tr);
    cut_territories(ps->g, tr, nt);
    int failed = 0;
    for (int k = 0; k < nt; k++) {
        tr[k].st = *st;
        tr[k].st.stack_cap = tr[k].st.hit_cap = tr[k].st.maybe_cap = tr[k].deferred_cap = 1024;
        tr[k].st.stack = malloc(1024 * sizeof(uint32_t));
        tr[k].st.hits = malloc(1024 * sizeof(uint32_t));
        tr[k].st.maybe = malloc(1024 * sizeof(uint32_t));
        tr[k].deferred = malloc(1024 * sizeof(uint32_t));
        failed |= !tr[k].st.stack || !tr[k].st.hits || !tr[k].st.maybe || !tr[k].deferred;
    }
    for (unsigned b = 0; b < NBANDS && !failed; b++) {
        size_t first = ps->band_first[b], last = ps->band_first[b + 1];
#pragma omp parallel for num_threads(nt) schedule(static, 1)
        for (int k = 0; k < nt; k++) {
            territory *t = &tr[k];
            t->ndeferred = 0;
            /* The band's slots are ascending in order[first, last). */
            size_t i = first + wpd_lower_bound_u32(ps->order + first, last - first, t->slot_lo);
            size_t end = i + wpd_lower_bound_u32(ps->order + i, last - i, t->slot_hi);
            for (; i < end && !t->failed; i++)
                if ((ps->state[ps->order[i]] & STATUS_MASK) == UNDECIDED)
                    t->failed = resolve_local(t, ps->order[i]) < 0;
        }
        for (int k = 0; k < nt; k++) {
            failed |= tr[k].failed;
            for (size_t i = 0; i < tr[k].ndeferred; i++) {
                uint32_t u = tr[k].deferred[i];
                if ((ps->state[u] & STATUS_MASK) == DEFERRED)
                    ps->state[u] &= (uint8_t)~STATUS_MASK;
            }
        }
        for (size_t i = first; i < last && !failed; i++)
            if ((ps->state[ps->order[i]] & STATUS_MASK) == UNDECIDED)
                failed = resolve(st, ps->order[i], 0) < 0;
    }
    for (int k = 0; k < nt; k++) {
        free(tr[k].st.stack);
        free(tr[k].st.hits);
        free(tr[k].st.maybe);
        free(tr[k].deferred);
    }
    return failed ? -1 : 0;
}

/* One pass at radius r: two-valued (wpd_poisson_run) unless `certain`, in
 * which case ps->kind is set and UNKNOWN slots go to unknown. */
static long run_pass(wpd_poisson *ps, double r, int certain, uint32_t *out, uint32_t *unknown,
                     size_t *nunknown, wpd_error *err)
{
    size_t n = ps->in.ncand;
    if (!(r > 0) || !isfinite(r))
        return wpd_fail(err, WPD_E_USAGE, "poisson: radius %g is not positive", r);
    if (n == 0)
        return 0;
    /* Scans cost most when cells are much smaller or larger than r. */
    if (ps->g == &ps->own && (r > 1.6 * ps->own.cell || r < 0.6 * ps->own.cell))
        if (prepare_slots(ps, r, err) < 0)
            return -1;
    if (ps->unsure && !ps->label)
        return wpd_fail(err, WPD_E_USAGE, "poisson: labels to compute and no labeller (a bug)");
    pass_state st = {ps->g,          certain ? ps->kind : ps->half, ps->prio, ps->state, r,
                     ps->stack,      ps->stack_cap, ps->hits, ps->hit_cap, ps->in.edge != NULL,
                     ps->maybe,      ps->maybe_cap, ps->label, ps->label_ctx};
    memcpy(ps->state, ps->band, n);
    const uint8_t *fixed_edge = ps->fixed_edge; /* NULL but for prepare_certain */
    for (size_t f = 0; f < ps->in.nfixed; f++)
        remove_around(&st, ps->in.fixed_xyz + 3 * f, fixed_edge && fixed_edge[f] ? 0.5 * r : r);
    int failed = 0;
    if (certain) {
        /* Lazy slots only on demand (KIND_LAZY). */
        for (size_t i = 0; i < n && !failed; i++)
            if ((ps->state[ps->order[i]] & STATUS_MASK) == UNDECIDED &&
                !(ps->kind[ps->order[i]] & KIND_LAZY))
                failed = resolve(&st, ps->order[i], 1) < 0;
    } else if (ps->threads > 1 && n >= PARALLEL_GREEDY_MIN) {
        failed = greedy_parallel(ps, &st, ps->threads) < 0;
    } else {
        for (size_t i = 0; i < n && !failed; i++)
            if ((ps->state[ps->order[i]] & STATUS_MASK) == UNDECIDED)
                failed = resolve(&st, ps->order[i], 0) < 0;
    }
    ps->stack = st.stack;
    ps->stack_cap = st.stack_cap;
    ps->hits = st.hits;
    ps->hit_cap = st.hit_cap;
    ps->maybe = st.maybe;
    ps->maybe_cap = st.maybe_cap;
    if (failed)
        return wpd_fail(err, WPD_E_MEMORY, "poisson: out of memory for the conflict lists");
    size_t kept = 0, unk = 0;
    for (size_t s = 0; s < n; s++) {
        uint8_t status = ps->state[s] & STATUS_MASK;
        if (status == ACCEPTED)
            out[kept++] = ps->g->id[s];
        else if (status == UNKNOWN || (certain && status == UNDECIDED))
            unknown[unk++] = ps->g->id[s];
    }
    qsort(out, kept, sizeof *out, cmp_u32);
    if (certain) {
        qsort(unknown, unk, sizeof *unknown, cmp_u32);
        *nunknown = unk;
    }
    return (long)kept;
}

long wpd_poisson_run(wpd_poisson *ps, double r, uint32_t *out, wpd_error *err)
{
    return run_pass(ps, r, 0, out, NULL, NULL, err);
}

long wpd_poisson_run_certain(wpd_poisson *ps, double r, uint32_t *kept, uint32_t *unknown,
                             size_t *nunknown, wpd_error *err)
{
    *nunknown = 0;
    return run_pass(ps, r, ps->kind != NULL, kept, unknown, nunknown, err);
}

long wpd_poisson_pass(const wpd_poisson_input *in, uint32_t *out, wpd_error *err)
{
    if (in->ncand == 0)
        return 0;
    wpd_poisson *ps = wpd_poisson_prepare(in, err);
    if (!ps)
        return -1;
    long kept = wpd_poisson_run(ps, in->r, out, err);
    wpd_poisson_release(ps);
    return kept;
}

long wpd_poisson_pass_certain(const wpd_poisson_certain_input *in, uint32_t *kept,
                              uint32_t *unknown, size_t *nunknown, wpd_error *err)
{
    *nunknown = 0;
    if (in->base.ncand == 0)
        return 0;
    wpd_poisson *ps = wpd_poisson_prepare_certain(in, err);
    if (!ps)
        return -1;
    long got = wpd_poisson_run_certain(ps, in->base.r, kept, unknown, nunknown, err);
    wpd_poisson_release(ps);
    return got;
}
