#include "method/ladder.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/hash.h"

/* Keys pack 21 bits per axis of voxel indices relative to the origin. */
enum { KEY_BITS = 21 };
#define KEY_MASK ((1ull << KEY_BITS) - 1)

/* Each sample ladder's first edge and its sampling blocks' edge, against
 * the first edge of the ladder before it (the exact one, then the first
 * sample); one block in SAMPLE_SHARE of those the ladder before samples
 * is sampled. BLOCK_LEVELS: log2(BLOCK_COARSER), the coarsenings of the
 * ladder before after which its voxels no longer nest in blocks. */
#define SAMPLE_FINER 4
#define BLOCK_COARSER 4
#define BLOCK_LEVELS 2
#define SAMPLE_SHARE 16

static uint64_t pack(uint64_t ix, uint64_t iy, uint64_t iz)
{
    return ix | iy << KEY_BITS | iz << (2 * KEY_BITS);
}

static uint64_t key_of(const double p[3], double inv)
{
    return pack((uint64_t)(p[0] * inv) & KEY_MASK, (uint64_t)(p[1] * inv) & KEY_MASK,
                (uint64_t)(p[2] * inv) & KEY_MASK);
}

/* The key of the voxel twice as large that contains voxel key. */
static uint64_t coarser(uint64_t key)
{
    return pack((key & KEY_MASK) >> 1, ((key >> KEY_BITS) & KEY_MASK) >> 1,
                (key >> (2 * KEY_BITS)) >> 1);
}

/* Replaces set by the set of its voxels' parents. */
static int coarsen(wpd_voxel_set *set)
{
    wpd_voxel_set next;
    size_t cap = 1024;
    while (cap < set->count)
        cap <<= 1;
    if (wpd_voxel_set_init(&next, cap) < 0)
        return -1;
    for (size_t i = 0; i < set->cap; i++)
        if (set->slot[i] != WPD_VOXEL_KEY_EMPTY && wpd_voxel_set_put(&next, coarser(set->slot[i]))) {
            wpd_voxel_set_free(&next);
            return -1;
        }
    wpd_voxel_set_free(set);
    *set = next;
    return 0;
}

/* Forgets the recent keys (the set's keys changed scale). */
static void forget_recent(wpd_ladder_scale *s)
{
    s->last = WPD_VOXEL_KEY_EMPTY;
    if (s->recent) /* a scale unpacked for a merge has none */
        memset(s->recent, 0xff, WPD_LADDER_RECENT * sizeof *s->recent);
}

static int scale_init(wpd_ladder_scale *s, double edge)
{
    s->edge = edge;
    s->inv = 1.0 / edge;
    s->level = 0;
    s->recent = malloc(WPD_LADDER_RECENT * sizeof *s->recent);
    if (!s->recent)
        return -1;
    forget_recent(s);
    return wpd_voxel_set_init(&s->set, 4096);
}

/* One scale coarser: every key and the edge. */
static int coarsen_scale(wpd_ladder_scale *s)
{
    if (coarsen(&s->set))
        return -1;
    s->edge *= 2;
    s->inv = 1.0 / s->edge;
    s->level++;
    forget_recent(s);
    return 0;
}

/* Coarsens until the keys fit the cap. */
static int fit_cap(wpd_ladder_scale *s, size_t cap)
{
    while (s->set.count > cap)
        if (coarsen_scale(s))
            return -1;
    return 0;
}

static int scale_put(wpd_ladder_scale *s, const double p[3], size_t cap)
{
    uint64_t key = key_of(p, s->inv);
    if (key == s->last) /* the commonest repeat, before any hashing (scan 5-9 % faster) */
        return 0;
    s->last = key;
    uint64_t *seen = s->recent + (wpd_mix64(key) >> (64 - WPD_LADDER_RECENT_BITS));
    if (*seen == key)
        return 0;
    if (wpd_voxel_set_put(&s->set, key))
        return -1;
    *seen = key; /* only once in the set */
    return fit_cap(s, cap);
}

static int scale_merge(wpd_ladder_scale *into, wpd_ladder_scale *from, size_t cap)
{
    while (into->level < from->level)
        if (coarsen_scale(into))
            return -1;
    while (from->level < into->level)
        if (coarsen_scale(from))
            return -1;
    for (size_t i = 0; i < from->set.cap; i++) {
        uint64_t key = from->set.slot[i];
        if (key == WPD_VOXEL_KEY_EMPTY)
            continue;
        /* into may have coarsened during the merge: bring key along */
        for (int d = from->level; d < into->level; d++)
            key = coarser(key);
        if (wpd_voxel_set_put(&into->set, key) || fit_cap(into, cap))
            return -1;
    }
    forget_recent(into);
    return 0;
}

/* Counts of s at its edge, then twice, four times ... (at most max, and
 * down to one voxel); consumes the set. Returns how many, or -1 (memory). */
static int scale_counts(wpd_ladder_scale *s, double *edge, uint64_t *m, int max)
{
    int n = 0;
    double e = s->edge;
    while (n < max) {
        edge[n] = e;
        m[n++] = s->set.count;
        if (s->set.count <= 1)
            break;
        if (coarsen(&s->set))
            return -1;
        e *= 2;
    }
    return n;
}

int wpd_ladder_init(wpd_ladder *l, const double extent[3], uint64_t npoints, size_t cap,
                    double wanted)
{
    memset(l, 0, sizeof *l);
    l->cap = cap < 1024 ? 1024 : cap;
    /* Starting finer than needed only costs cache misses (2^16 voxels along
     * the NC Raleigh scan cost 1.3 s); never finer than 2^16 along the
     * longest axis, so indices fit their 21 bits (the samples' 2^18 and
     * 2^20). */
    double longest = fmax(extent[0], fmax(extent[1], extent[2]));
    double face = fmax(extent[0] * extent[1], fmax(extent[0] * extent[2], extent[1] * extent[2]));
    double keys = fmin((double)l->cap / 2, (double)npoints);
    double edge = fmax(longest / 65536.0, sqrt(face / fmax(keys, 1)));
    if (!(edge > 0))
        edge = 1.0;
    l->last_block = WPD_VOXEL_KEY_EMPTY;
    l->sampling = wpd_ladder_samples(cap, wanted);
    if (scale_init(&l->all, edge)) {
        wpd_ladder_free(l);
        return -1;
    }
    for (int j = 0; j < l->sampling; j++) {
        l->block_inv[j] = 1.0 / (edge * BLOCK_COARSER);
        edge /= SAMPLE_FINER;
        if (scale_init(&l->sample[j], edge)) {
            wpd_ladder_free(l);
            return -1;
        }
    }
    return 0;
}

/* How many sample ladders count p: the first samples one block in
 * SAMPLE_SHARE, the second one in SAMPLE_SHARE of the first's blocks'
 * sub-blocks. Every edge is the first one times a power of two, so the
 * voxels of each ladder nest in the next one's blocks up to the block's
 * edge (the ladder's first BLOCK_LEVELS coarsenings). */
static int sample_depth(wpd_ladder *l, const double p[3])
{
    uint64_t block = key_of(p, l->block_inv[0]);
    if (block != l->last_block) {
        l->last_block = block;
        l->last_depth = wpd_mix64(block) % SAMPLE_SHARE == 0;
    }
    if (l->last_depth == 0 || l->sampling < 2)
        return l->last_depth;
    /* A different hash for the sub-blocks: not the first level's again. */
    uint64_t sub = key_of(p, l->block_inv[1]);
    return wpd_mix64(sub ^ 0x5bd1e9955bd1e995ull) % SAMPLE_SHARE == 0 ? 2 : 1;
}

int wpd_ladder_put(wpd_ladder *l, const double p[3])
{
    if (scale_put(&l->all, p, l->cap))
        return -1;
    int depth = l->sampling ? sample_depth(l, p) : 0;
    for (int j = 0; j < depth && j < l->sampling; j++)
        if (scale_put(&l->sample[j], p, l->cap))
            return -1;
    return 0;
}

int wpd_ladder_merge(wpd_ladder *into, wpd_ladder *from)
{
    into->last_block = WPD_VOXEL_KEY_EMPTY;
    if (scale_merge(&into->all, &from->all, into->cap))
        return -1;
    for (int j = 0; j < into->sampling; j++)
        if (scale_merge(&into->sample[j], &from->sample[j], into->cap))
            return -1;
    return 0;
}

/* A sample ladder's estimates of the scales finer than the finest known
 * one (edge *fine_edge, count *fine_m, from a ladder coarsened fine_level
 * times): its counts there, scaled by the ratio of the known count to its
 * own at that edge, into edge[0..] and m[0..] (at most room). Returns how
 * many (0: it cannot tell: see wpd_ladder_finish), and moves the finest
 * known scale to its finest; -1 (memory). */
static int sample_estimates(wpd_ladder_scale *s, int fine_level, double *fine_edge,
                            double *fine_m, double *edge, uint64_t *m, int room)
{
    double se[WPD_MAX_SCALES];
    uint64_t sm[WPD_MAX_SCALES];
    int ns = scale_counts(s, se, sm, WPD_MAX_SCALES);
    if (ns < 0)
        return -1;
    /* The sample's scale equal to the finest known one (edges double
     * exactly from first edges a power of two apart). */
    int at = 0;
    while (at < ns && se[at] < *fine_edge)
        at++;
    /* The ratio of the two counts at that scale estimates the share of
     * voxels sampled only where those voxels nest in blocks: a voxel of
     * several blocks counts as sampled when any of them is (with 8 blocks
     * a voxel, 0.40 of the voxels against 1/16). */
    if (fine_level > BLOCK_LEVELS || at >= ns || se[at] != *fine_edge ||
        sm[at] < WPD_LADDER_SAMPLE_MIN)
        return 0;
    int k = at < room ? at : room;
    double ratio = *fine_m / (double)sm[at];
    for (int i = 0; i < k; i++) {
        edge[i] = se[at - k + i];
        m[i] = (uint64_t)llround((double)sm[at - k + i] * ratio);
    }
    if (k > 0) {
        *fine_edge = se[at - k];
        *fine_m = (double)sm[at - k] * ratio;
    }
    return k;
}

int wpd_ladder_finish(wpd_ladder *l, double *edge, uint64_t *m, int *nscales, int *nestimated)
{
    *nscales = *nestimated = 0;
    double ae[WPD_MAX_SCALES];
    uint64_t am[WPD_MAX_SCALES];
    int level = l->all.level;
    int nall = scale_counts(&l->all, ae, am, WPD_MAX_SCALES);
    if (nall < 0)
        return -1;
    /* Each sample's estimates, finest last; then they go first. */
    double fe = nall ? ae[0] : 0, fm = nall ? (double)am[0] : 0;
    double ee[WPD_LADDER_SAMPLES][WPD_MAX_SCALES];
    uint64_t em[WPD_LADDER_SAMPLES][WPD_MAX_SCALES];
    int ne[WPD_LADDER_SAMPLES] = {0}, est = 0;
    for (int j = 0; j < l->sampling; j++) {
        int k = nall ? sample_estimates(&l->sample[j], level, &fe, &fm, ee[j], em[j],
                                        WPD_MAX_SCALES / 4)
                     : 0;
        if (k < 0)
            return -1;
        if (k == 0)
            break;
        ne[j] = k;
        est += k;
        level = l->sample[j].level;
    }
    for (int j = l->sampling - 1; j >= 0; j--)
        for (int i = 0; i < ne[j]; i++, (*nscales)++)
            edge[*nscales] = ee[j][i], m[*nscales] = em[j][i];
    for (int i = 0; i < nall && *nscales < WPD_MAX_SCALES; i++, (*nscales)++)
        edge[*nscales] = ae[i], m[*nscales] = am[i];
    *nestimated = est;
    return 0;
}

/* A scale packed: its level, its key count, its keys. */
static size_t scale_pack(const wpd_ladder_scale *s, uint64_t *out)
{
    size_t n = 0;
    out[n++] = (uint64_t)s->level;
    out[n++] = (uint64_t)s->set.count;
    for (size_t i = 0; i < s->set.cap; i++)
        if (s->set.slot[i] != WPD_VOXEL_KEY_EMPTY)
            out[n++] = s->set.slot[i];
    return n;
}

int wpd_ladder_pack(const wpd_ladder *l, uint8_t **buf, size_t *n)
{
    size_t words = 2 + l->all.set.count;
    for (int j = 0; j < l->sampling; j++)
        words += 2 + l->sample[j].set.count;
    uint64_t *out = malloc(words * sizeof *out);
    if (!out)
        return -1;
    size_t used = scale_pack(&l->all, out);
    for (int j = 0; j < l->sampling; j++)
        used += scale_pack(&l->sample[j], out + used);
    *buf = (uint8_t *)out;
    *n = used * sizeof *out;
    return 0;
}

/* Merges the scale packed at words[*at ..] into `into`. */
static int scale_merge_packed(wpd_ladder_scale *into, const uint64_t *words, size_t nwords,
                              size_t *at, size_t cap)
{
    if (nwords - *at < 2 || words[*at] > 64 || words[*at + 1] > nwords - *at - 2)
        return -1;
    wpd_ladder_scale from = {.level = (int)words[*at]};
    size_t count = (size_t)words[*at + 1], slots = 1024;
    while (slots < 2 * count)
        slots <<= 1;
    if (wpd_voxel_set_init(&from.set, slots))
        return -1;
    from.edge = ldexp(into->edge, from.level - into->level);
    from.inv = 1.0 / from.edge;
    const uint64_t *key = words + *at + 2;
    int rc = 0;
    for (size_t i = 0; i < count && rc == 0; i++)
        rc = key[i] == WPD_VOXEL_KEY_EMPTY || wpd_voxel_set_put(&from.set, key[i]) ? -1 : 0;
    if (rc == 0)
        rc = scale_merge(into, &from, cap);
    wpd_voxel_set_free(&from.set);
    *at += 2 + count;
    return rc;
}

int wpd_ladder_merge_packed(wpd_ladder *into, const uint8_t *buf, size_t n)
{
    if (n % sizeof(uint64_t))
        return -1;
    size_t nwords = n / sizeof(uint64_t), at = 0;
    uint64_t *words = malloc(n ? n : 1);
    if (!words)
        return -1;
    memcpy(words, buf, n); /* aligned */
    into->last_block = WPD_VOXEL_KEY_EMPTY;
    int rc = scale_merge_packed(&into->all, words, nwords, &at, into->cap);
    for (int j = 0; rc == 0 && j < into->sampling; j++)
        rc = scale_merge_packed(&into->sample[j], words, nwords, &at, into->cap);
    if (rc == 0 && at != nwords)
        rc = -1;
    free(words);
    return rc;
}

void wpd_ladder_free(wpd_ladder *l)
{
    wpd_voxel_set_free(&l->all.set);
    free(l->all.recent);
    l->all.recent = NULL;
    for (int j = 0; j < WPD_LADDER_SAMPLES; j++) {
        wpd_voxel_set_free(&l->sample[j].set);
        free(l->sample[j].recent);
        l->sample[j].recent = NULL;
    }
}
