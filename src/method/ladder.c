#include "method/ladder.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/hash.h"

/* Keys pack 21 bits per axis of voxel indices relative to the origin. */
enum { KEY_BITS = 21 };
#define KEY_MASK ((1ull << KEY_BITS) - 1)

/* The sample ladder's first edge and the sampling blocks' edge, against
 * the exact ladder's first edge; one block in SAMPLE_SHARE is sampled.
 * BLOCK_LEVELS: log2(BLOCK_COARSER), the coarsenings of the exact ladder
 * after which its voxels no longer nest in blocks. */
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
     * longest axis, so indices fit their 21 bits (the sample's 2^18). */
    double longest = fmax(extent[0], fmax(extent[1], extent[2]));
    double face = fmax(extent[0] * extent[1], fmax(extent[0] * extent[2], extent[1] * extent[2]));
    double keys = fmin((double)l->cap / 2, (double)npoints);
    double edge = fmax(longest / 65536.0, sqrt(face / fmax(keys, 1)));
    if (!(edge > 0))
        edge = 1.0;
    l->block_inv = 1.0 / (edge * BLOCK_COARSER);
    l->last_block = WPD_VOXEL_KEY_EMPTY;
    l->sampling = wpd_ladder_samples(cap, wanted);
    if (scale_init(&l->all, edge) ||
        (l->sampling && scale_init(&l->sample, edge / SAMPLE_FINER))) {
        wpd_ladder_free(l);
        return -1;
    }
    return 0;
}

/* Whether p lies in a sampled block. Every edge is the first one times a
 * power of two, so the voxels of both sets nest in blocks up to the
 * block's edge (the exact ladder's first BLOCK_LEVELS coarsenings). */
static int sampled(wpd_ladder *l, const double p[3])
{
    uint64_t block = key_of(p, l->block_inv);
    if (block != l->last_block) {
        l->last_block = block;
        l->last_sampled = wpd_mix64(block) % SAMPLE_SHARE == 0;
    }
    return l->last_sampled;
}

int wpd_ladder_put(wpd_ladder *l, const double p[3])
{
    if (scale_put(&l->all, p, l->cap))
        return -1;
    return l->sampling && sampled(l, p) ? scale_put(&l->sample, p, l->cap) : 0;
}

int wpd_ladder_merge(wpd_ladder *into, wpd_ladder *from)
{
    into->last_block = WPD_VOXEL_KEY_EMPTY;
    return scale_merge(&into->all, &from->all, into->cap) ||
                   (into->sampling && scale_merge(&into->sample, &from->sample, into->cap))
               ? -1
               : 0;
}

int wpd_ladder_finish(wpd_ladder *l, double *edge, uint64_t *m, int *nscales, int *nestimated)
{
    double se[WPD_MAX_SCALES];
    uint64_t sm[WPD_MAX_SCALES];
    *nscales = *nestimated = 0;
    int ns = l->sampling ? scale_counts(&l->sample, se, sm, WPD_MAX_SCALES) : 0;
    if (ns < 0)
        return -1;
    /* The sample's scale equal to the finest exact one (edges double
     * exactly from first edges a power of two apart). */
    int at = 0;
    while (at < ns && se[at] < l->all.edge)
        at++;
    /* The ratio of the two counts at the finest exact scale estimates the
     * share of voxels sampled only where those voxels nest in blocks: a
     * voxel of several blocks counts as sampled when any of them is (with
     * 8 blocks a voxel, 0.40 of the voxels against 1/16). */
    int room = 0;
    if (l->all.level <= BLOCK_LEVELS && at < ns && se[at] == l->all.edge &&
        sm[at] >= WPD_LADDER_SAMPLE_MIN)
        room = at < WPD_MAX_SCALES / 4 ? at : WPD_MAX_SCALES / 4;
    int nall = scale_counts(&l->all, edge + room, m + room, WPD_MAX_SCALES - room);
    if (nall < 0)
        return -1;
    double ratio = room ? (double)m[room] / (double)sm[at] : 0;
    for (int i = 0; i < room; i++) {
        edge[i] = se[at - room + i];
        m[i] = (uint64_t)llround((double)sm[at - room + i] * ratio);
    }
    *nscales = room + nall;
    *nestimated = room;
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
    size_t words = 2 + l->all.set.count + (l->sampling ? 2 + l->sample.set.count : 0);
    uint64_t *out = malloc(words * sizeof *out);
    if (!out)
        return -1;
    size_t used = scale_pack(&l->all, out);
    if (l->sampling)
        used += scale_pack(&l->sample, out + used);
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
    if (rc == 0 && into->sampling)
        rc = scale_merge_packed(&into->sample, words, nwords, &at, into->cap);
    if (rc == 0 && at != nwords)
        rc = -1;
    free(words);
    return rc;
}

void wpd_ladder_free(wpd_ladder *l)
{
    wpd_voxel_set_free(&l->all.set);
    wpd_voxel_set_free(&l->sample.set);
    free(l->all.recent);
    free(l->sample.recent);
    l->all.recent = l->sample.recent = NULL;
}
