/* poisson_state.h - the state of one Poisson pass, shared by the two- and
 * three-valued rules (poisson.c, poisson_certain.c); internal to wpd/. */
#ifndef WPD_POISSON_STATE_H
#define WPD_POISSON_STATE_H

#include <stdint.h>
#include <stdlib.h>

#include "core/grid.h"
#include "method/poisson.h"

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
enum { UNDECIDED = 0, REMOVED = 1, ACCEPTED = 2, UNKNOWN = 3, STATUS_MASK = 3 };
#define BAND_MASK ((NBANDS - 1) << 2)
#define BAND_OF(st) (((st) & BAND_MASK) >> 2)
/* Bit 7 of the state: a slot whose label is not known yet that a kept
 * point removes if its radius is r (it lies between the two conflict
 * distances). Its label is asked only when the pass reaches it, or when a
 * slot it may block is tried: most such slots are removed for certain
 * before that, by a kept point nearer to them. */
#define TENTATIVE 0x80u

/* The two-valued pass on several threads (poisson.c, greedy_parallel) marks the
 * slots it leaves to the sequential pass DEFERRED, the UNKNOWN status (the
 * two-valued pass has no other use for it); try_accept answers DEFER_ME
 * when its slot waits for one of them. */
enum { DEFERRED = UNKNOWN };
#define DEFER_ME (UINT32_MAX - 2)

/* Per-slot label flags (the half array of the two-valued pass, the kind
 * array of the three-valued one): HALF a sharp-feature point, UNSURE its
 * label not computed yet (poisson.h, labels on demand). */
enum { LABEL_HALF = 1, LABEL_UNSURE = 8 };

typedef struct pass_state {
    const wpd_grid *g;
    uint8_t *half;        /* per slot: LABEL_* (the three-valued pass: kind), or NULL */
    const uint64_t *prio; /* per slot */
    uint8_t *state;       /* per slot */
    double r;
    uint32_t *stack;
    size_t stack_cap;
    uint32_t *hits;       /* slots collected by try_accept */
    size_t hit_cap;
    int any_half;         /* three-valued pass: some slot has a sharp label (else
                             every dependency distance is the full one) */
    uint32_t *maybe;      /* collected slots a kept point makes TENTATIVE */
    size_t maybe_cap;
    wpd_labeller label;   /* computes an UNSURE label */
    void *label_ctx;
} pass_state;

static inline void set_removed(uint8_t *st)
{
    *st = (uint8_t)((*st & BAND_MASK) | REMOVED);
}

/* The sharp label of slot s, asked of the labeller the first time; a
 * TENTATIVE slot is then removed (radius r) or left undecided. */
static inline int label_of(pass_state *ps, uint32_t s)
{
    uint8_t k = ps->half[s];
    if (!(k & LABEL_UNSURE))
        return k & LABEL_HALF;
    int edge = ps->label(ps->label_ctx, ps->g->id[s]) != 0;
    ps->half[s] = (uint8_t)((k & ~LABEL_UNSURE) | (edge ? LABEL_HALF : 0));
    if (ps->state[s] & TENTATIVE) {
        ps->state[s] &= (uint8_t)~TENTATIVE;
        if (!edge)
            set_removed(&ps->state[s]);
    }
    return edge;
}

/* Settles slot s's TENTATIVE mark, if any (its label decides). */
static inline void settle_tentative(pass_state *ps, uint32_t s)
{
    if (ps->state[s] & TENTATIVE)
        label_of(ps, s);
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

/* Per-slot kind of the three-valued pass, in place of the sharp flag: */
enum { KIND_HALF = LABEL_HALF, KIND_BLIND = 2, KIND_LAZY = 4, KIND_UNSURE = LABEL_UNSURE,
       KIND_RADIUS = KIND_HALF | KIND_BLIND };
/* A slot's kind & KIND_RADIUS is nonzero exactly when its smallest radius m
 * is r/2, so remove_around (the fixed points) reads it as the "half" flag;
 * its largest radius R is r/2 only for kind & KIND_RADIUS == KIND_HALF.
 * KIND_LAZY: decided only on demand (not wanted by the caller; blind slots
 * are lazy too, and never decided). A lazy slot of smaller priority that a
 * slot depends on is decided first, whatever its band; one nobody depends
 * on stays undecided and is reported UNKNOWN. In a tile this spares a
 * neighbourhood scan for most halo points. KIND_UNSURE: a label not
 * computed yet (never on a blind slot, whose label is not used). */

/* Labels on demand, and why the decisions are those of the labels given.
 * A slot whose label is UNSURE is asked for it (label_of) where a decision
 * depends on it: when the slot is tried (its own radius), and when it
 * lies between the two conflict distances from a slot tried (radius r/2
 * out of conflict, r in it) and could block it. Between them from a slot
 * accepted it is marked TENTATIVE instead: with the label given it would be
 * REMOVED (radius r) or left undecided (r/2). Every rule then reads a
 * TENTATIVE slot as either: farther than the r/2 conflict distance from a
 * slot tried, it is removed or out of conflict whatever its label (SKIP);
 * nearer, it is removed for good by an accepted slot (in conflict with
 * r/2, removed already with r), and asked for its label only where it
 * could block. A slot the pass reaches in band order is asked first
 * (settle_tentative). So each slot has, at every step, the state the pass
 * given every label has, or TENTATIVE where that one has REMOVED or
 * undecided by the label; each scan returns the same first blocker and
 * makes the same decisions, in the same order. The three-valued pass
 * leaves lazy slots nobody depended on TENTATIVE, reported UNKNOWN (they
 * are not wanted: UNKNOWN claims nothing). */

/* Doubles a scratch array; returns 0, or -1 (the array unchanged) if out of
 * memory. */
static inline int grow(uint32_t **buf, size_t *cap)
{
    uint32_t *grown = realloc(*buf, 2 * *cap * sizeof *grown);
    if (!grown)
        return -1;
    *buf = grown;
    *cap *= 2;
    return 0;
}

/* Where slot s of state st lies from a point within the outer conflict
 * distance but not within half2 (the conflict distance with a radius r/2):
 * SKIP (not in conflict, or removed already), IN (in conflict) or MAYBE (in
 * conflict only when its radius, not known yet, turns out to be r). A
 * TENTATIVE slot (label unknown) there is removed or out of conflict either
 * way. blind_is_r: a blind slot (three-valued pass, KIND_BLIND = 2) counts
 * at radius r. */
enum { SKIP, IN, MAYBE };
static inline int beyond_half(const pass_state *ps, uint32_t s, uint8_t st, int blind_is_r)
{
    uint8_t k = ps->half[s];
    if (k & LABEL_UNSURE)
        return st & TENTATIVE ? SKIP : MAYBE;
    return (k & LABEL_HALF) && !(blind_is_r && (k & 2)) ? SKIP : IN;
}

/* Records slot s in buf[*n] (growing it). Returns 0 or -1. */
static inline int collect_slot(uint32_t **buf, size_t *cap, size_t *n, uint32_t s)
{
    if (*n == *cap && grow(buf, cap) < 0)
        return -1;
    (*buf)[(*n)++] = s;
    return 0;
}

/* Whether a slot of smaller priority, in conflict with the slot being
 * tried where `maybe` says so, blocks it: its label is asked where that
 * decides (a MAYBE slot is in conflict with radius r; a TENTATIVE one is
 * removed with radius r, in conflict with r/2). */
static inline int blocks(pass_state *ps, uint32_t s, int maybe, uint8_t st)
{
    if (maybe)
        return !label_of(ps, s);
    if (st & TENTATIVE)
        return label_of(ps, s);
    return 1;
}

/* The three-valued rules (poisson_certain.c): as try_accept (poisson.c),
 * for a non-blind slot t. */
uint32_t wpd_poisson_try_decide(pass_state *ps, uint32_t t);

#endif
