/* clouds.h - random test clouds shared by the Poisson and sharp-label unit
 * tests: a noisy plane, a 3-D blob and a quantised slab (many equal
 * distances), at r = 1, plus axis-aligned boxes. */
#ifndef WPD_TEST_CLOUDS_H
#define WPD_TEST_CLOUDS_H

#include <math.h>
#include <stdint.h>
#include <stdlib.h>

#include "core/hash.h"

static inline double unit(uint64_t *state)
{
    *state = wpd_mix64(*state + 0x9e3779b97f4a7c15ULL);
    return (double)(*state >> 11) * 0x1p-53;
}

static inline double gauss(uint64_t *state)
{
    double u = unit(state), v = unit(state);
    return sqrt(-2 * log(u + 1e-300)) * cos(6.283185307179586 * v);
}

typedef struct cloud {
    size_t n;
    double *xyz;
    uint64_t *gid;
} cloud;

enum { PLANE, BLOB, QUANTISED, NKINDS };
static const char *kind_name[NKINDS] = {"plane", "blob", "quantised"};

/* Clouds at r = 1 dense enough for long chains of decisions (about 10
 * points per r-disc on the plane). QUANTISED puts coordinates on a 0.25
 * lattice: many equal distances, exact duplicates, and distances exactly
 * equal to the conflict distances 1, 0.75 and 0.5. */
static inline cloud make_cloud(int kind, size_t n, uint64_t seed)
{
    cloud c = {n, malloc(3 * n * sizeof(double)), malloc(n * sizeof(uint64_t))};
    uint64_t st = seed * 7919 + (uint64_t)kind;
    for (size_t i = 0; i < n; i++) {
        double *p = c.xyz + 3 * i;
        if (kind == PLANE) {
            p[0] = 16 * unit(&st);
            p[1] = 16 * unit(&st);
            p[2] = 0.1 * p[0] + 0.05 * gauss(&st);
        } else if (kind == BLOB) {
            for (int a = 0; a < 3; a++)
                p[a] = 2.5 * gauss(&st);
        } else {
            p[0] = 0.25 * floor(48 * unit(&st));
            p[1] = 0.25 * floor(48 * unit(&st));
            p[2] = 0.25 * floor(5 * unit(&st));
        }
        /* Large, distinct, not in point order. */
        c.gid[i] = 5000000000ULL + (wpd_mix64(seed) % 1000) + 3 * (uint64_t)((i * 7) % n);
    }
    return c;
}

static inline void cloud_free(cloud *c)
{
    free(c->xyz);
    free(c->gid);
}

typedef struct box {
    double lo[3], hi[3];
} box;

static inline double box_dist(const box *b, const double *p)
{
    double s = 0;
    for (int a = 0; a < 3; a++) {
        double d = p[a] < b->lo[a] ? b->lo[a] - p[a] : p[a] > b->hi[a] ? p[a] - b->hi[a] : 0;
        s += d * d;
    }
    return sqrt(s);
}

#endif
