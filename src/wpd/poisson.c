/* poisson.c - greedy Poisson-disk pruning on the sorted-cell grid. */
#include "wpd/poisson.h"

#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "core/grid.h"
#include "core/hash.h"


/* The greedy pass is exact but visits points in bands of priority rather
 * than one by one in priority order: bands are taken in order, the points
 * of one band in slot (cell) order, so that consecutive neighbourhood scans
 * touch nearby memory. A point is accepted only once every undecided point
 * of smaller priority within its conflict distance has been decided first
 * (resolved recursively, through an explicit stack); points of earlier
 * bands are all decided already. The result is the same as visiting every
 * point in priority order. */
#define BAND_BITS 5
#define NBANDS (1u << BAND_BITS)

/* Per-slot state byte: band << 2 | status, so "undecided and in band b" is
 * one byte comparison (points of smaller priority that are still undecided
 * can only be in the current band). */
enum { UNDECIDED = 0, REMOVED = 1, ACCEPTED = 2, STATUS_MASK = 3 };

typedef struct pass_state {
    const wpd_grid *g;
    const uint8_t *half;  /* per slot: sharp-feature point, or NULL */
    const uint64_t *prio; /* per slot */
    uint8_t *state;       /* per slot */
    double r;
    uint32_t *stack;
    size_t stack_cap;
    uint32_t *hits;       /* slots collected by try_accept */
    size_t hit_cap;
} pass_state;

/* Conflict threshold (squared) between a point of radius rp and slot s;
 * full2 is the threshold against a point of radius r, the only one when no
 * point is a sharp-feature point (computed once per scan). */
static inline double conflict2(const pass_state *ps, double rp, uint32_t s, double full2)
{
    if (!ps->half || !ps->half[s])
        return full2;
    double d = 0.5 * (rp + 0.5 * ps->r);
    return d * d;
}

static inline double full_conflict2(const pass_state *ps, double rp)
{
    double d = 0.5 * (rp + ps->r);
    return d * d;
}

static inline double dist2(const double *a, const double *b)
{
    double dx = a[0] - b[0], dy = a[1] - b[1], dz = a[2] - b[2];
    return dx * dx + dy * dy + dz * dz;
}

/* Marks REMOVED every undecided slot in conflict with a point at p of
 * radius rp. */
static void remove_around(const pass_state *ps, const double p[3], double rp)
{
    const wpd_grid *g = ps->g;
    int64_t lo[3], hi[3];
    if (!wpd_grid_box(g, p, 0.5 * (rp + ps->r), lo, hi))
        return;
    double full2 = full_conflict2(ps, rp);
    for (int64_t b = lo[1]; b <= hi[1]; b++)
        for (int64_t a = lo[0]; a <= hi[0]; a++) {
            uint32_t sb, se;
            wpd_grid_column_slots(g, a, b, lo[2], hi[2], &sb, &se);
            for (uint32_t s = sb; s < se; s++)
                if ((ps->state[s] & STATUS_MASK) == UNDECIDED &&
                    dist2(g->xyz + 3 * (size_t)s, p) < conflict2(ps, rp, s, full2))
                    ps->state[s] |= REMOVED;
        }
}

/* Tries to accept slot t: one scan of its neighbourhood collects the
 * undecided slots in conflict with it; if one of them has a smaller
 * priority (it can only be in t's band), that one must be decided first and
 * is returned, nothing changes. Otherwise t is accepted, the collected
 * slots are removed, and UINT32_MAX is returned. Returns UINT32_MAX - 1 if
 * the collection buffer cannot grow. */
static uint32_t try_accept(pass_state *ps, uint32_t t, double rt)
{
    const wpd_grid *g = ps->g;
    const double *p = g->xyz + 3 * (size_t)t;
    uint64_t pt = ps->prio[t];
    uint8_t waiting = ps->state[t]; /* undecided, same band */
    size_t found = 0;
    int64_t lo[3], hi[3];
    double full2 = full_conflict2(ps, rt);
    if (wpd_grid_box(g, p, 0.5 * (rt + ps->r), lo, hi))
        for (int64_t b = lo[1]; b <= hi[1]; b++)
            for (int64_t a = lo[0]; a <= hi[0]; a++) {
                uint32_t sb, se;
                wpd_grid_column_slots(g, a, b, lo[2], hi[2], &sb, &se);
                for (uint32_t s = sb; s < se; s++) {
                    uint8_t st = ps->state[s];
                    if ((st & STATUS_MASK) != UNDECIDED || s == t ||
                        dist2(g->xyz + 3 * (size_t)s, p) >= conflict2(ps, rt, s, full2))
                        continue;
                    if (st == waiting && ps->prio[s] < pt)
                        return s;
                    if (found == ps->hit_cap) {
                        size_t cap = 2 * ps->hit_cap;
                        uint32_t *grown = realloc(ps->hits, cap * sizeof *grown);
                        if (!grown)
                            return UINT32_MAX - 1;
                        ps->hits = grown;
                        ps->hit_cap = cap;
                    }
                    ps->hits[found++] = s;
                }
            }
    ps->state[t] |= ACCEPTED;
    for (size_t i = 0; i < found; i++)
        ps->state[ps->hits[i]] |= REMOVED;
    return UINT32_MAX;
}

/* Decides slot s and whatever it depends on. Returns 0, or -1 if out of
 * memory. */
static int resolve(pass_state *ps, uint32_t s)
{
    size_t top = 0;
    ps->stack[top++] = s;
    while (top > 0) {
        uint32_t t = ps->stack[top - 1];
        if ((ps->state[t] & STATUS_MASK) != UNDECIDED) {
            top--;
            continue;
        }
        double rt = ps->half && ps->half[t] ? 0.5 * ps->r : ps->r;
        uint32_t blocker = try_accept(ps, t, rt);
        if (blocker == UINT32_MAX) {
            top--;
            continue;
        }
        if (blocker == UINT32_MAX - 1)
            return -1;
        if (top == ps->stack_cap) {
            size_t cap = 2 * ps->stack_cap;
            uint32_t *grown = realloc(ps->stack, cap * sizeof *grown);
            if (!grown)
                return -1;
            ps->stack = grown;
            ps->stack_cap = cap;
        }
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
    wpd_grid g;            /* cell = the radius it was prepared for */
    uint64_t *prio;        /* [n] per slot */
    uint8_t *band;         /* [n] per slot: band << 2 (the initial state byte) */
    uint8_t *half;         /* [n] per slot: sharp-feature point, or NULL */
    uint32_t *order;       /* [n] slots by band, then slot */
    uint8_t *state;        /* [n] per slot, per pass */
    uint32_t *stack;
    size_t stack_cap;
    uint32_t *hits;
    size_t hit_cap;
};

/* Builds the grid for cell size r and everything that depends on slots. */
static int prepare_slots(wpd_poisson *ps, double r, wpd_error *err)
{
    const wpd_poisson_input *in = &ps->in;
    size_t n = in->ncand;
    if (wpd_grid_build(&ps->g, in->xyz, in->cand, n, r, ps->threads, err) < 0)
        return -1;
    const wpd_grid *g = &ps->g;
    uint64_t seed = in->seed;
    const uint64_t *gid = in->gid;
    const uint8_t *edge = in->edge;
    uint64_t *prio = ps->prio;
    uint8_t *band = ps->band, *half = ps->half;
#pragma omp parallel for num_threads(ps->threads) schedule(static)
    for (size_t s = 0; s < n; s++) {
        uint32_t id = g->id[s];
        prio[s] = wpd_priority(seed, gid[id]);
        band[s] = (uint8_t)((prio[s] >> (64 - BAND_BITS)) << 2);
        if (half)
            half[s] = edge[id] != 0;
    }
    size_t start[NBANDS + 1] = {0};
    for (size_t s = 0; s < n; s++)
        start[(band[s] >> 2) + 1]++;
    for (unsigned b = 0; b < NBANDS; b++)
        start[b + 1] += start[b];
    for (size_t s = 0; s < n; s++)
        ps->order[start[band[s] >> 2]++] = (uint32_t)s;
    return 0;
}

wpd_poisson *wpd_poisson_prepare(const wpd_poisson_input *in, wpd_error *err)
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
    ps->threads = in->threads > 0 ? in->threads : omp_get_max_threads();
    size_t m = n ? n : 1;
    ps->prio = malloc(m * sizeof *ps->prio);
    ps->band = malloc(m);
    ps->half = in->edge ? malloc(m) : NULL;
    ps->order = malloc(m * sizeof *ps->order);
    ps->state = malloc(m);
    ps->stack_cap = 1024;
    ps->stack = malloc(ps->stack_cap * sizeof *ps->stack);
    ps->hit_cap = 1024;
    ps->hits = malloc(ps->hit_cap * sizeof *ps->hits);
    if (!ps->prio || !ps->band || (in->edge && !ps->half) || !ps->order || !ps->state ||
        !ps->stack || !ps->hits)
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

void wpd_poisson_release(wpd_poisson *ps)
{
    if (!ps)
        return;
    wpd_grid_free(&ps->g);
    free(ps->prio);
    free(ps->band);
    free(ps->half);
    free(ps->order);
    free(ps->state);
    free(ps->stack);
    free(ps->hits);
    free(ps);
}

size_t wpd_poisson_occupied_cells(const wpd_poisson *ps, double *cell)
{
    if (cell)
        *cell = ps->g.cell;
    return ps->g.nruns;
}

long wpd_poisson_run(wpd_poisson *ps, double r, uint32_t *out, wpd_error *err)
{
    size_t n = ps->in.ncand;
    if (!(r > 0) || !isfinite(r))
        return wpd_fail(err, WPD_E_USAGE, "poisson: radius %g is not positive", r);
    if (n == 0)
        return 0;
    /* Scans cost most when cells are much smaller or larger than r. */
    if (r > 1.6 * ps->g.cell || r < 0.6 * ps->g.cell)
        if (prepare_slots(ps, r, err) < 0)
            return -1;
    pass_state st = {&ps->g, ps->half, ps->prio, ps->state, r, ps->stack, ps->stack_cap,
                     ps->hits, ps->hit_cap};
    memcpy(ps->state, ps->band, n);
    for (size_t f = 0; f < ps->in.nfixed; f++)
        remove_around(&st, ps->in.fixed_xyz + 3 * f, r);
    int failed = 0;
    for (size_t i = 0; i < n && !failed; i++)
        if ((ps->state[ps->order[i]] & STATUS_MASK) == UNDECIDED)
            failed = resolve(&st, ps->order[i]) < 0;
    ps->stack = st.stack;
    ps->stack_cap = st.stack_cap;
    ps->hits = st.hits;
    ps->hit_cap = st.hit_cap;
    if (failed)
        return wpd_fail(err, WPD_E_MEMORY, "poisson: out of memory for the conflict lists");
    size_t kept = 0;
    for (size_t s = 0; s < n; s++)
        if ((ps->state[s] & STATUS_MASK) == ACCEPTED)
            out[kept++] = ps->g.id[s];
    qsort(out, kept, sizeof *out, cmp_u32);
    return (long)kept;
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
