/* test_poisson.c - the three-valued Poisson pass against the one-block pass
 * on random box partitions ("certain or unknown" decisions, then a
 * resolution loop), a brute-force reading of its rules, and a chain of
 * decisions longer than the halo. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "clouds.h"
#include "core/grid.h"
#include "core/hash.h"
#include "core/knn.h"
#include "harness.h"
#include "method/poisson.h"
#include "method/sharp.h"

static double box_box_dist(const box *a, const box *b)
{
    double s = 0;
    for (int k = 0; k < 3; k++) {
        double d = a->lo[k] > b->hi[k] ? a->lo[k] - b->hi[k] : b->lo[k] > a->hi[k] ? b->lo[k] - a->hi[k] : 0;
        s += d * d;
    }
    return sqrt(s);
}

enum { D_NONE = 0, D_KEPT = 1, D_REMOVED = 2, D_UNKNOWN = 3 };
enum { LABELS_NONE, LABELS_RANDOM, LABELS_DETECTED, NLABELS };
static const char *label_name[NLABELS] = {"none", "random", "detected"};
#define MAX_BLOCKS 16
#define SHARP_K 13

/* A cloud cut into boxes, the one-block answer, and the blocks' current
 * decisions on their own points. */
typedef struct world {
    const cloud *c;
    double r, H;
    uint64_t seed;
    int nb;
    box b[MAX_BLOCKS];
    int colour[MAX_BLOCKS];
    int *owner;       /* [n] block of each point */
    int labels;
    uint8_t *edge;    /* [n] true labels (detected on the whole cloud, or
                         random), NULL for LABELS_NONE */
    uint8_t *global;  /* [n] 1: kept by the one-block pass */
    uint8_t *dec;     /* [n] decision of the point's owner, D_* */
    /* scratch, [n] each */
    uint32_t *cand, *kept, *unknown, *view;
    uint8_t *blind, *bedge, *fedge, *status, *local_edge, *wanted;
    double *fixed, *local_xyz;
    int lazy;            /* 1: only own points wanted, the rest on demand */
    /* tallies */
    size_t wrong;        /* certain decisions that differ from the one-block pass */
    size_t label_wrong;  /* labels of non-blind view points that differ */
    size_t runs;
} world;

static void world_init(world *w, const cloud *c, int labels, uint64_t seed)
{
    size_t n = c->n;
    memset(w, 0, sizeof *w);
    w->c = c;
    w->r = 1;
    w->H = 2.5 * w->r;
    w->seed = seed;
    w->labels = labels;
    w->owner = malloc(n * sizeof *w->owner);
    w->global = calloc(n, 1);
    w->dec = calloc(n, 1);
    w->cand = malloc(n * sizeof *w->cand);
    w->kept = malloc(n * sizeof *w->kept);
    w->unknown = malloc(n * sizeof *w->unknown);
    w->view = malloc(n * sizeof *w->view);
    w->blind = calloc(n, 1);
    w->wanted = calloc(n, 1);
    w->bedge = calloc(n, 1);
    w->fedge = calloc(n, 1);
    w->status = calloc(n, 1);
    w->local_edge = calloc(n, 1);
    w->fixed = malloc(3 * n * sizeof *w->fixed);
    w->local_xyz = malloc(3 * n * sizeof *w->local_xyz);
    if (labels == LABELS_RANDOM) {
        w->edge = malloc(n);
        for (size_t i = 0; i < n; i++)
            w->edge[i] = wpd_mix64(c->gid[i] ^ seed) % 4 == 0;
    } else if (labels == LABELS_DETECTED) {
        w->edge = malloc(n);
        wpd_grid g = {0};
        wpd_error err;
        if (wpd_grid_build_knn(&g, c->xyz, NULL, n, SHARP_K, 0.5, 1, &err) == 0)
            wpd_detect_sharp_capped(&g, 0, n, w->r, w->edge, 1);
        wpd_grid_free(&g);
    }
    /* The reference: one block, every point, true labels. */
    wpd_poisson_input in = {c->xyz, c->gid, w->edge, NULL, n, NULL, 0, w->r, seed, 1};
    wpd_error err;
    long m = wpd_poisson_pass(&in, w->kept, &err);
    for (long i = 0; i < m; i++)
        w->global[w->kept[i]] = 1;
}

static void world_free(world *w)
{
    free(w->owner); free(w->global); free(w->dec); free(w->cand); free(w->kept);
    free(w->unknown); free(w->view); free(w->blind); free(w->wanted); free(w->bedge); free(w->fedge);
    free(w->status); free(w->local_edge); free(w->fixed); free(w->local_xyz); free(w->edge);
}

/* Assigns every point to the box containing it (half-open boxes). */
static void assign_owners(world *w)
{
    for (size_t i = 0; i < w->c->n; i++) {
        const double *p = w->c->xyz + 3 * i;
        w->owner[i] = -1;
        for (int b = 0; b < w->nb && w->owner[i] < 0; b++) {
            int in = 1;
            for (int a = 0; a < 3; a++)
                in &= p[a] >= w->b[b].lo[a] && p[a] < w->b[b].hi[a];
            if (in)
                w->owner[i] = b;
        }
    }
}

/* A random partition of the cloud's bounding box into nb boxes (repeated
 * splits of a random box across a random axis), greedily coloured so that
 * boxes closer than H get different colours. */
static void random_partition(world *w, int nb, uint64_t *st)
{
    box root;
    wpd_point_bounds(w->c->xyz, NULL, w->c->n, root.lo, root.hi, 1);
    for (int a = 0; a < 3; a++) {
        root.lo[a] -= 0.5;
        root.hi[a] += 0.5;
    }
    w->nb = 1;
    w->b[0] = root;
    while (w->nb < nb) {
        int k = (int)(unit(st) * w->nb);
        box *b = &w->b[k];
        int a = (int)(unit(st) * 3);
        if (b->hi[a] - b->lo[a] < 2 * w->r)
            continue; /* thin along that axis: another draw */
        double cut = b->lo[a] + (0.2 + 0.6 * unit(st)) * (b->hi[a] - b->lo[a]);
        w->b[w->nb] = *b;
        w->b[w->nb].lo[a] = cut;
        b->hi[a] = cut;
        w->nb++;
    }
    for (int b = 0; b < w->nb; b++) {
        int used = 0;
        for (int o = 0; o < b; o++)
            if (box_box_dist(&w->b[b], &w->b[o]) < w->H)
                used |= 1 << w->colour[o];
        int c = 0;
        while (used & (1 << c))
            c++;
        w->colour[b] = c;
    }
    assign_owners(w);
}

/* One block's three-valued pass. Its view is every point within H of its
 * box. Own points are candidates; a point of another block is, when
 * use_others is set and its owner has decided it in snap, a fixed point
 * (KEPT; within H + r) or dropped (REMOVED), and otherwise a candidate.
 * Blind: candidates at distance >= H - r from the box, so that a non-blind
 * candidate's r-ball lies inside the view (the guarantee's condition b);
 * with labels detected with cap r, at H - 2 r, where they are exact (c).
 * Checks every certain decision, own or not, against the one-block pass;
 * writes the own decisions to next. Returns how many own points are
 * UNKNOWN, or -1 if the pass failed. */
static long run_block(world *w, int b, int use_others, const uint8_t *snap, uint8_t *next)
{
    const cloud *c = w->c;
    const box *bx = &w->b[b];
    double r = w->r, H = w->H;
    size_t ncand = 0, nfixed = 0, nview = 0;
    for (int pass = 0; pass < 2; pass++) /* the view: own points first */
        for (size_t i = 0; i < c->n; i++)
            if ((w->owner[i] == b) == (pass == 0) && box_dist(bx, c->xyz + 3 * i) < H)
                w->view[nview++] = (uint32_t)i;
    const uint8_t *edge = w->edge;
    if (w->labels == LABELS_DETECTED) {
        for (size_t j = 0; j < nview; j++)
            memcpy(w->local_xyz + 3 * j, c->xyz + 3 * (size_t)w->view[j], 3 * sizeof(double));
        wpd_grid g = {0};
        wpd_error err;
        if (wpd_grid_build_knn(&g, w->local_xyz, NULL, nview, SHARP_K, 0.5, 1, &err) < 0)
            return -1;
        wpd_detect_sharp_capped(&g, 0, nview, r, w->local_edge, 1);
        wpd_grid_free(&g);
        for (size_t j = 0; j < nview; j++) {
            uint32_t i = w->view[j];
            w->bedge[i] = w->local_edge[j];
            if (box_dist(bx, c->xyz + 3 * (size_t)i) < H - WPD_SHARP_DEPTH * r)
                w->label_wrong += w->bedge[i] != w->edge[i];
        }
        edge = w->bedge;
    }
    for (size_t i = 0; i < c->n; i++) {
        double d = box_dist(bx, c->xyz + 3 * i);
        int own = w->owner[i] == b;
        uint8_t st = own || !use_others ? D_NONE : snap[i];
        if (st == D_KEPT && d < H + r) {
            memcpy(w->fixed + 3 * nfixed, c->xyz + 3 * i, 3 * sizeof(double));
            /* The owner's label of its own point is the true one. */
            w->fedge[nfixed++] = w->edge ? w->edge[i] : 0;
        } else if (st != D_KEPT && st != D_REMOVED && d < H) {
            w->cand[ncand++] = (uint32_t)i;
            /* Detected labels look WPD_SHARP_DEPTH caps far (sharp.h). */
            w->blind[i] = d >= H - (w->labels == LABELS_DETECTED ? WPD_SHARP_DEPTH * r : r);
            w->wanted[i] = (uint8_t)own;
        }
    }
    wpd_poisson_certain_input in = {
        {c->xyz, c->gid, edge, w->cand, ncand, w->fixed, nfixed, r, w->seed, 1},
        w->blind, w->edge ? w->fedge : NULL, w->lazy ? w->wanted : NULL};
    size_t nunk = 0;
    wpd_error err;
    long m = wpd_poisson_pass_certain(&in, w->kept, w->unknown, &nunk, &err);
    if (m < 0)
        return -1;
    w->runs++;
    for (size_t j = 0; j < ncand; j++)
        w->status[w->cand[j]] = D_REMOVED;
    for (long j = 0; j < m; j++)
        w->status[w->kept[j]] = D_KEPT;
    for (size_t j = 0; j < nunk; j++)
        w->status[w->unknown[j]] = D_UNKNOWN;
    long own_unknown = 0;
    for (size_t j = 0; j < ncand; j++) {
        uint32_t i = w->cand[j];
        uint8_t s = w->status[i];
        w->wrong += (s == D_KEPT && !w->global[i]) || (s == D_REMOVED && w->global[i]);
        if (w->owner[i] == b) {
            next[i] = s;
            own_unknown += s == D_UNKNOWN;
        }
        w->blind[i] = 0;
    }
    return own_unknown;
}

static size_t count_unknown(const world *w)
{
    size_t u = 0;
    for (size_t i = 0; i < w->c->n; i++)
        u += w->dec[i] != D_KEPT && w->dec[i] != D_REMOVED;
    return u;
}

/* First pass over the blocks (independent, or colour by colour with the
 * earlier colours' certain decisions), then rounds in which every block
 * with UNKNOWN own points is re-run against the others' current decisions
 * (all from the previous round: the blocks of a round are independent).
 * Returns the rounds after the first pass, or -1 if it did not settle
 * within max_rounds; *first_unknown: UNKNOWN own points after the first
 * pass. */
static int solve(world *w, int coloured, int max_rounds, size_t *first_unknown)
{
    size_t n = w->c->n;
    uint8_t *snap = malloc(n);
    memset(w->dec, D_NONE, n);
    if (!coloured) {
        for (int b = 0; b < w->nb; b++)
            run_block(w, b, 0, NULL, w->dec);
    } else {
        for (int col = 0; col < MAX_BLOCKS; col++) {
            memcpy(snap, w->dec, n);
            for (int b = 0; b < w->nb; b++)
                if (w->colour[b] == col)
                    run_block(w, b, 1, snap, w->dec);
        }
    }
    *first_unknown = count_unknown(w);
    int rounds = 0;
    while (count_unknown(w) > 0) {
        if (rounds == max_rounds) {
            free(snap);
            return -1;
        }
        memcpy(snap, w->dec, n);
        for (int b = 0; b < w->nb; b++) {
            int has = 0;
            for (size_t i = 0; i < n && !has; i++)
                has = w->owner[i] == b && snap[i] == D_UNKNOWN;
            if (has)
                run_block(w, b, 1, snap, w->dec);
        }
        rounds++;
    }
    free(snap);
    return rounds;
}

/* Points on which dec (KEPT or not) and the one-block pass differ. */
static size_t differences(const world *w)
{
    size_t d = 0;
    for (size_t i = 0; i < w->c->n; i++)
        d += (w->dec[i] == D_KEPT) != w->global[i];
    return d;
}

/* The scheme the engine used: each block runs wpd_poisson_pass over its
 * own points and its halo (independent blocks, or colour by colour with
 * the kept points of earlier colours fixed and their other points gone)
 * and keeps its own kept points. Leaves the result in w->dec. */
static void old_scheme(world *w, int coloured)
{
    const cloud *c = w->c;
    memset(w->dec, D_NONE, c->n);
    for (int col = 0; col < MAX_BLOCKS; col++)
        for (int b = 0; b < w->nb; b++) {
            if (coloured ? w->colour[b] != col : col > 0)
                continue;
            size_t ncand = 0, nfixed = 0;
            for (size_t i = 0; i < c->n; i++) {
                double d = box_dist(&w->b[b], c->xyz + 3 * i);
                int o = w->owner[i];
                int settled = coloured && o != b && w->colour[o] < col;
                if (settled && w->dec[i] == D_KEPT && d < w->H + w->r)
                    memcpy(w->fixed + 3 * nfixed++, c->xyz + 3 * i, 3 * sizeof(double));
                else if (!settled && d < w->H)
                    w->cand[ncand++] = (uint32_t)i;
            }
            wpd_poisson_input in = {c->xyz, c->gid, w->edge, w->cand, ncand, w->fixed, nfixed,
                                    w->r, w->seed, 1};
            wpd_error err;
            long m = wpd_poisson_pass(&in, w->kept, &err);
            for (size_t j = 0; j < ncand; j++)
                if (w->owner[w->cand[j]] == b)
                    w->dec[w->cand[j]] = D_REMOVED;
            for (long j = 0; j < m; j++)
                if (w->owner[w->kept[j]] == b)
                    w->dec[w->kept[j]] = D_KEPT;
        }
}

TEST(poisson_certain_without_blind_points_is_the_plain_pass)
{
    for (int kind = 0; kind < NKINDS; kind++) {
        cloud c = make_cloud(kind, 3000, 11);
        uint8_t *edge = malloc(c.n), *none = calloc(c.n, 1);
        for (size_t i = 0; i < c.n; i++)
            edge[i] = wpd_mix64(i + 5) % 3 == 0;
        double fixed[9] = {1, 1, 0, 4, 4, 0.5, 0, 0, 0};
        uint32_t *a = malloc(c.n * 4), *b = malloc(c.n * 4), *u = malloc(c.n * 4);
        wpd_error err;
        for (int e = 0; e < 2; e++) {
            wpd_poisson_input in = {c.xyz, c.gid, e ? edge : NULL, NULL, c.n, fixed, 3, 0.8, 3, 2};
            long ga = wpd_poisson_pass(&in, a, &err);
            /* blind NULL: the plain code; all-zero blind: the three-valued
             * machinery, which must then agree. */
            for (int z = 0; z < 2; z++) {
                wpd_poisson_certain_input ci = {in, z ? none : NULL, NULL, NULL};
                size_t nu = 99;
                long gb = wpd_poisson_pass_certain(&ci, b, u, &nu, &err);
                CHECK_MSG(ga > 0 && ga == gb && nu == 0 && memcmp(a, b, (size_t)ga * 4) == 0,
                          "%s edge %d blind %s: %ld vs %ld kept, %zu unknown", kind_name[kind], e,
                          z ? "zeros" : "NULL", ga, gb, nu);
            }
            /* Contexts, at radii that force a rebuild of the grid. */
            wpd_poisson_certain_input ci = {in, none, NULL, NULL};
            wpd_poisson *ps = wpd_poisson_prepare_certain(&ci, &err);
            CHECK(ps != NULL);
            for (int k = 0; ps && k < 3; k++) {
                double r = 0.8 * (k == 1 ? 2.0 : 1.0 + 0.1 * k);
                size_t nu = 99;
                long x = wpd_poisson_run(ps, r, a, &err);
                long y = wpd_poisson_run_certain(ps, r, b, u, &nu, &err);
                CHECK_MSG(x > 0 && x == y && nu == 0 && memcmp(a, b, (size_t)x * 4) == 0,
                          "context at r %g: %ld vs %ld", r, x, y);
            }
            wpd_poisson_release(ps);
        }
        free(a); free(b); free(u); free(edge); free(none);
        cloud_free(&c);
    }
}

/* The rules of poisson.h read literally, in O(n^2): candidates in priority
 * order; m(x) = r/2 if blind or sharp, else r; R(x) = r/2 if sharp and not
 * blind, else r. Writes D_* per point. */
static void brute_force(const wpd_poisson_certain_input *ci, uint8_t *out)
{
    const wpd_poisson_input *in = &ci->base;
    size_t n = in->ncand;
    double r = in->r;
    uint32_t *ord = malloc(n * sizeof *ord);
    for (size_t i = 0; i < n; i++)
        ord[i] = (uint32_t)i; /* cand NULL in these tests: candidate = point */
    for (size_t i = 1; i < n; i++) /* insertion sort by priority */
        for (size_t j = i; j > 0 && wpd_priority(in->seed, in->gid[ord[j]]) <
                                        wpd_priority(in->seed, in->gid[ord[j - 1]]); j--) {
            uint32_t t = ord[j];
            ord[j] = ord[j - 1];
            ord[j - 1] = t;
        }
#define SHARP(x) (in->edge && in->edge[x])
#define BLIND(x) (ci->blind && ci->blind[x])
#define MIN_R(x) (BLIND(x) || SHARP(x) ? 0.5 * r : r)
#define MAX_R(x) (SHARP(x) && !BLIND(x) ? 0.5 * r : r)
    for (size_t a = 0; a < n; a++) {
        uint32_t c = ord[a];
        const double *p = in->xyz + 3 * (size_t)c;
        uint8_t d = D_NONE;
        for (size_t f = 0; f < in->nfixed && d == D_NONE; f++) {
            const double *q = in->fixed_xyz + 3 * f;
            double lim = 0.5 * ((ci->fixed_edge && ci->fixed_edge[f] ? 0.5 * r : r) + MIN_R(c));
            double dx = p[0] - q[0], dy = p[1] - q[1], dz = p[2] - q[2];
            if (dx * dx + dy * dy + dz * dz < lim * lim)
                d = D_REMOVED;
        }
        int tainted = 0;
        for (size_t b = 0; b < a && d == D_NONE; b++) {
            uint32_t e = ord[b];
            const double *q = in->xyz + 3 * (size_t)e;
            double dx = p[0] - q[0], dy = p[1] - q[1], dz = p[2] - q[2], d2 = dx * dx + dy * dy + dz * dz;
            double kept_lim = 0.5 * ((SHARP(e) ? 0.5 * r : r) + MIN_R(c));
            double unk_lim = 0.5 * (MAX_R(e) + (SHARP(c) ? 0.5 * r : r));
            if (out[e] == D_KEPT && d2 < kept_lim * kept_lim)
                d = D_REMOVED;
            if (out[e] == D_UNKNOWN && d2 < unk_lim * unk_lim)
                tainted = 1;
        }
        out[c] = d != D_NONE ? d : BLIND(c) || tainted ? D_UNKNOWN : D_KEPT;
    }
#undef SHARP
#undef BLIND
#undef MIN_R
#undef MAX_R
    free(ord);
}

TEST(poisson_certain_agrees_with_a_brute_force_reading_of_the_rules)
{
    /* Dense enough that many conflicting pairs share a priority band (the
     * pass decides a band's points in cell order, resolving dependencies
     * on demand); every combination of blind and sharp. */
    size_t unknown = 0, all_undecided = 0, all_decided = 0;
    for (int kind = 0; kind < NKINDS; kind++)
        for (int t = 0; t < 4; t++) {
            cloud c = make_cloud(kind, 1500, 40 + (uint64_t)t);
            size_t n = c.n;
            uint8_t *edge = malloc(n), *blind = malloc(n), *want = malloc(n), *got = malloc(n);
            uint32_t *kept = malloc(n * 4), *unk = malloc(n * 4);
            uint64_t st = 7 * (uint64_t)t + (uint64_t)kind;
            for (size_t i = 0; i < n; i++) {
                edge[i] = unit(&st) < 0.3;
                blind[i] = unit(&st) < (t == 3 ? 0.03 : 0.3);
            }
            double fixed[3 * 8];
            uint8_t fedge[8];
            for (int f = 0; f < 8; f++) {
                memcpy(fixed + 3 * f, c.xyz + 3 * (size_t)(f * 97), 3 * sizeof(double));
                fixed[3 * f] += 0.6;
                fedge[f] = f % 2;
            }
            wpd_poisson_certain_input ci = {
                {c.xyz, c.gid, t == 1 ? NULL : edge, NULL, n, fixed, 8, 1.0, (uint64_t)t, 2},
                blind, t == 2 ? NULL : fedge, NULL};
            memset(want, D_NONE, n);
            brute_force(&ci, want);
            size_t nu = 0;
            wpd_error err;
            long m = wpd_poisson_pass_certain(&ci, kept, unk, &nu, &err);
            CHECK(m > 0);
            memset(got, D_REMOVED, n);
            for (long i = 0; i < m; i++)
                got[kept[i]] = D_KEPT;
            for (size_t i = 0; i < nu; i++)
                got[unk[i]] = D_UNKNOWN;
            /* The pass may leave UNKNOWN what the rules decide (blind
             * candidates are not scanned, poisson.h), never decide
             * otherwise; and it leaves few such. */
            size_t wrong = 0, undecided = 0, decided = 0;
            for (size_t i = 0; i < n; i++) {
                wrong += got[i] != D_UNKNOWN && got[i] != want[i];
                undecided += got[i] == D_UNKNOWN && want[i] != D_UNKNOWN;
                decided += want[i] != D_UNKNOWN;
            }
            CHECK_MSG(wrong == 0, "%s case %d: %zu of %zu decisions differ", kind_name[kind], t,
                      wrong, n);
            CHECK_MSG(undecided * 20 <= decided, "%s case %d: %zu of %zu decisions left UNKNOWN",
                      kind_name[kind], t, undecided, decided);
            all_undecided += undecided;
            all_decided += decided;
            unknown += nu;
            free(edge); free(blind); free(want); free(got); free(kept); free(unk);
            cloud_free(&c);
        }
    CHECK(unknown > 0);
    printf("     %zu of the %zu decisions of the rules left UNKNOWN by the pass\n", all_undecided,
           all_decided);
}

TEST(poisson_certain_blind_points_and_fixed_labels)
{
    /* Every candidate blind: nothing can be KEPT; only the fixed points
     * remove, and a blind candidate only within (r + r/2) / 2. */
    double xyz[] = {0, 0, 0, 0.7, 0, 0, 0.8, 0, 0, 5, 0, 0};
    uint64_t gid[] = {1, 2, 3, 4};
    uint8_t all[] = {1, 1, 1, 1};
    double fixed[] = {0, 0.74, 0};
    uint32_t kept[4], unk[4];
    size_t nu = 0;
    wpd_error err;
    wpd_poisson_certain_input ci = {{xyz, gid, NULL, NULL, 4, fixed, 1, 1.0, 7, 1}, all, NULL, NULL};
    long m = wpd_poisson_pass_certain(&ci, kept, unk, &nu, &err);
    /* Point 0 lies 0.74 from the fixed point (< 0.75): removed, whatever
     * its label; points 1 and 2 (0.7^2 + 0.74^2 > 0.75^2) and 3 are not. */
    CHECK_MSG(m == 0 && nu == 3 && unk[0] == 1 && unk[1] == 2 && unk[2] == 3, "%ld kept, %zu unknown",
              m, nu);
    /* Labels of fixed points: a sharp fixed point (r/2) removes a normal
     * candidate only within 0.75 r. */
    uint8_t none[4] = {0}, sharp_fixed[1] = {1};
    double f2[] = {0.8, 0.0, 0.0};
    double one[] = {0, 0, 0};
    wpd_poisson_certain_input a = {{one, gid, NULL, NULL, 1, f2, 1, 1.0, 7, 1}, none, sharp_fixed, NULL};
    CHECK(wpd_poisson_pass_certain(&a, kept, unk, &nu, &err) == 1 && nu == 0);
    a.fixed_edge = NULL;
    CHECK(wpd_poisson_pass_certain(&a, kept, unk, &nu, &err) == 0 && nu == 0);
    f2[0] = 0.7;
    a.fixed_edge = sharp_fixed;
    CHECK(wpd_poisson_pass_certain(&a, kept, unk, &nu, &err) == 0 && nu == 0);
    /* A blind UNKNOWN neighbour counts at radius r even when labelled
     * sharp: a normal candidate of larger priority 0.8 away (> 0.75, < 1)
     * becomes UNKNOWN. */
    double two[] = {0, 0, 0, 0.8, 0, 0};
    uint64_t g2[2];
    for (uint64_t x = 0, k = 0; k < 2; x++) /* gids with increasing priority */
        if (k == 0 || wpd_priority(7, x) > wpd_priority(7, g2[0]))
            g2[k++] = x;
    uint8_t e2[] = {1, 0}, b2[] = {1, 0};
    wpd_poisson_certain_input t = {{two, g2, e2, NULL, 2, NULL, 0, 1.0, 7, 1}, b2, NULL, NULL};
    CHECK(wpd_poisson_pass_certain(&t, kept, unk, &nu, &err) == 0 && nu == 2);
    b2[0] = 0; /* now its label is known: sharp, no conflict at 0.8 */
    CHECK(wpd_poisson_pass_certain(&t, kept, unk, &nu, &err) == 2 && nu == 0);
}

/* A ridge beside the cloud (4 x 4, spacing 0.1, faces 62 degrees apart),
 * so that detected labels at cap r = 1 are sharp along a line: the crease
 * test's lone verdicts in the clouds alone carry no label (no support). */
static void add_ridge(cloud *c, uint64_t seed)
{
    size_t side = 40, add = side * side, n = c->n;
    c->xyz = realloc(c->xyz, 3 * (n + add) * sizeof *c->xyz);
    c->gid = realloc(c->gid, (n + add) * sizeof *c->gid);
    uint64_t st = seed;
    for (size_t j = 0; j < side; j++)
        for (size_t i = 0; i < side; i++) {
            double *p = c->xyz + 3 * (n + j * side + i);
            p[0] = 10 + 0.1 * (i + 0.3 * unit(&st));
            p[1] = 10 + 0.1 * (j + 0.3 * unit(&st));
            p[2] = 3 + 0.6 * (2 - fabs(p[0] - 12)) + 0.005 * gauss(&st);
            c->gid[n + j * side + i] = 6000000000ULL + 3 * (uint64_t)(j * side + i);
        }
    c->n = n + add;
}

TEST(poisson_certain_decisions_on_random_partitions_match_the_one_block_pass)
{
    int max_rounds[NKINDS][NLABELS][2] = {{{0}}};
    size_t unknown_first[NKINDS][NLABELS][2] = {{{0}}}, old_wrong = 0, scenarios = 0;
    size_t label_wrong = 0, runs = 0, partitions_per = 4;
    for (int kind = 0; kind < NKINDS; kind++)
        for (int labels = 0; labels < NLABELS; labels++) {
            cloud c = make_cloud(kind, 2500, 100 + (uint64_t)(kind * 3 + labels));
            if (labels == LABELS_DETECTED)
                add_ridge(&c, 7 + (uint64_t)kind);
            world w;
            world_init(&w, &c, labels, 1000 + (uint64_t)labels);
            size_t sharp = 0;
            for (size_t i = 0; labels == LABELS_DETECTED && i < c.n; i++)
                sharp += w.edge[i];
            CHECK_MSG(labels != LABELS_DETECTED || sharp > 20, "%s: %zu detected sharp points",
                      kind_name[kind], sharp);
            uint64_t st = 17 * (uint64_t)(kind + 1) + (uint64_t)labels;
            for (size_t p = 0; p < partitions_per; p++) {
                int nb = 2 + (int)(unit(&st) * 15); /* 2..16 */
                random_partition(&w, nb, &st);
                w.lazy = (int)(p % 2); /* halo points decided on demand, as tiles do */
                for (int coloured = 0; coloured < 2; coloured++) {
                    size_t first = 0;
                    int rounds = solve(&w, coloured, 64, &first);
                    size_t diff = differences(&w);
                    CHECK_MSG(w.wrong == 0, "%s, labels %s, %d blocks, coloured %d: %zu certain "
                              "decisions differ from the one-block pass", kind_name[kind],
                              label_name[labels], nb, coloured, w.wrong);
                    CHECK_MSG(rounds >= 0 && diff == 0, "%s, labels %s, %d blocks, coloured %d: "
                              "%d rounds, %zu points differ", kind_name[kind], label_name[labels],
                              nb, coloured, rounds, diff);
                    if (rounds > max_rounds[kind][labels][coloured])
                        max_rounds[kind][labels][coloured] = rounds;
                    unknown_first[kind][labels][coloured] += first;
                    w.wrong = 0;
                    old_scheme(&w, coloured);
                    old_wrong += differences(&w) > 0;
                    scenarios++;
                }
            }
            label_wrong += w.label_wrong;
            runs += w.runs;
            world_free(&w);
            cloud_free(&c);
        }
    CHECK_MSG(label_wrong == 0, "%zu labels of non-blind points differ from the cloud's", label_wrong);
    size_t any_unknown = 0;
    printf("     rounds after the first pass (max over %zu partitions; UNKNOWN own points after "
           "the first pass, summed), independent | coloured:\n", partitions_per);
    for (int kind = 0; kind < NKINDS; kind++)
        for (int labels = 0; labels < NLABELS; labels++) {
            printf("       %-9s labels %-8s  %d (%4zu) | %d (%4zu)\n", kind_name[kind],
                   label_name[labels], max_rounds[kind][labels][0], unknown_first[kind][labels][0],
                   max_rounds[kind][labels][1], unknown_first[kind][labels][1]);
            any_unknown += unknown_first[kind][labels][0];
        }
    printf("     %zu block passes; the old per-tile scheme differs from the one-block pass in "
           "%zu of %zu cases\n", runs, old_wrong, scenarios);
    /* Otherwise the resolution loop was never exercised. */
    CHECK(any_unknown > 0);
}

/* A line of points 0.9 r apart whose priorities increase along it: the
 * one-block pass keeps every other point from the start, so whether a point
 * far along is kept depends on the start, far beyond any halo. */
TEST(poisson_certain_long_chain_beyond_the_halo)
{
    enum { N = 120 };
    cloud c = {N, malloc(3 * N * sizeof(double)), malloc(N * sizeof(uint64_t))};
    uint64_t seed = 99;
    /* Positions along the line in increasing priority of their gids. */
    for (size_t i = 0; i < N; i++) {
        c.gid[i] = 7000000 + i;
        c.xyz[3 * i] = 0.9 * (double)i;
        c.xyz[3 * i + 1] = c.xyz[3 * i + 2] = 0;
    }
    for (size_t i = 1; i < N; i++)
        for (size_t j = i; j > 0 && wpd_priority(seed, c.gid[j]) < wpd_priority(seed, c.gid[j - 1]); j--) {
            uint64_t t = c.gid[j];
            c.gid[j] = c.gid[j - 1];
            c.gid[j - 1] = t;
        }
    int increasing = 1;
    for (size_t i = 1; i < N; i++)
        increasing &= wpd_priority(seed, c.gid[i]) > wpd_priority(seed, c.gid[i - 1]);
    CHECK(increasing);

    world w;
    world_init(&w, &c, LABELS_NONE, seed);
    size_t kept_even = 0, kept_odd = 0;
    for (size_t i = 0; i < N; i++)
        *(i % 2 ? &kept_odd : &kept_even) += w.global[i];
    CHECK_MSG(kept_even == N / 2 && kept_odd == 0, "one-block pass keeps %zu even, %zu odd",
              kept_even, kept_odd);
    /* Three blocks A | B | C cut at x = 0.9 * 31.5 and 0.9 * 81.5: the
     * first halo point of B is point 29 and of C point 79 (odd), so a block
     * that starts the chain at its halo keeps the wrong parity. A and C
     * share a colour, B comes after them. */
    double cuts[2] = {0.9 * 31.5, 0.9 * 81.5};
    w.nb = 3;
    for (int b = 0; b < 3; b++) {
        w.b[b] = (box){{b == 0 ? -10 : cuts[b - 1], -10, -10}, {b == 2 ? 200 : cuts[b], 10, 10}};
        w.colour[b] = b == 1;
    }
    assign_owners(&w);

    /* Round 1 by hand, to see where the UNKNOWN points are: A decides
     * its points, B and C cannot (their chains start in blind points). */
    size_t unknown_a = 0, unknown_b = 0, unknown_c = 0;
    memset(w.dec, D_NONE, N);
    for (int b = 0; b < 3; b++)
        run_block(&w, b, 0, NULL, w.dec);
    for (size_t i = 0; i < N; i++) {
        unknown_a += w.owner[i] == 0 && w.dec[i] == D_UNKNOWN;
        unknown_b += w.owner[i] == 1 && w.dec[i] == D_UNKNOWN;
        unknown_c += w.owner[i] == 2 && w.dec[i] == D_UNKNOWN;
    }
    CHECK_MSG(unknown_a == 0 && unknown_b > 0 && unknown_c > 0,
              "round 1: UNKNOWN A %zu, B %zu, C %zu", unknown_a, unknown_b, unknown_c);
    size_t first = 0;
    int rounds = solve(&w, 0, 16, &first);
    CHECK_MSG(w.wrong == 0, "%zu certain decisions differ", w.wrong);
    CHECK_MSG(rounds >= 1 && differences(&w) == 0, "independent: %d rounds, %zu differ", rounds,
              differences(&w));
    size_t first_c = 0;
    int rounds_c = solve(&w, 1, 16, &first_c);
    CHECK_MSG(first_c > 0 && rounds_c >= 1 && differences(&w) == 0 && w.wrong == 0,
              "coloured: %zu unknown, %d rounds, %zu differ", first_c, rounds_c, differences(&w));
    printf("     chain: %zu UNKNOWN after round 1, settled after %d more round(s); coloured: %zu, "
           "%d\n", first, rounds, first_c, rounds_c);

    /* The old scheme gets this chain wrong, independent or coloured: the
     * test above can fail. */
    old_scheme(&w, 0);
    size_t old_ind = differences(&w);
    old_scheme(&w, 1);
    size_t old_col = differences(&w);
    CHECK_MSG(old_ind > 0 && old_col > 0, "old scheme: %zu / %zu points differ", old_ind, old_col);
    printf("     chain: the old per-tile scheme gets %zu (independent) and %zu (coloured) of %d "
           "points wrong\n", old_ind, old_col, N);
    world_free(&w);
    cloud_free(&c);
}

/* A uniform number in [0, 1) from an LCG state. */
static double uniform(uint64_t *state)
{
    *state = *state * 6364136223846793005ull + 1442695040888963407ull;
    return (double)(*state >> 11) / (double)(1ull << 53);
}

/* The two-valued pass on 2-4 threads (territories of grid rows, the
 * slots near their cuts deferred to the sequential pass) keeps exactly the
 * one-thread pass's samples, with and without sharp-feature points (half
 * radius), at radii that defer few and many slots. */
TEST(poisson_threads_keep_the_one_thread_samples)
{
    size_t n = 300000;
    double *xyz = malloc(3 * n * sizeof *xyz);
    uint64_t *gid = malloc(n * sizeof *gid);
    uint8_t *edge = malloc(n);
    uint64_t st = 5;
    for (size_t i = 0; i < n; i++) {
        double x = 200 * uniform(&st), y = 120 * uniform(&st);
        double z = i % 5 == 0 ? 10 * uniform(&st) : 2 * sin(x / 15) * cos(y / 11); /* noise */
        xyz[3 * i] = x, xyz[3 * i + 1] = y, xyz[3 * i + 2] = z;
        gid[i] = 7 * i + 3; /* distinct: the priorities are */
        edge[i] = fabs(x - 100) < 3;
    }
    uint32_t *one = malloc(n * 4), *many = malloc(n * 4);
    wpd_error err;
    for (int sharp = 0; sharp < 2; sharp++)
        for (double r = 0.6; r < 10; r *= 4)
            for (int threads = 2; threads <= 4; threads++) {
                wpd_poisson_input in = {xyz, gid, sharp ? edge : NULL, NULL, n, NULL, 0, r, 3, 1};
                long a = wpd_poisson_pass(&in, one, &err);
                in.threads = threads;
                long b = wpd_poisson_pass(&in, many, &err);
                CHECK_MSG(a > 0 && a == b && memcmp(one, many, (size_t)a * 4) == 0,
                          "r %g, sharp %d, %d threads: %ld vs %ld kept", r, sharp, threads, a, b);
            }
    free(xyz); free(gid); free(edge); free(one); free(many);
}
