/* synth_math.h - `wpd synth`'s randomness and fast math: the stateless
 * feature hash that places the scene, the splitmix64 stream the scan draws
 * from, triangular noise, and small helpers (clamping, a sine table).
 *
 * Header-only (static inline): every one of these runs once or more per
 * pulse, and the output must be a function of (points, seed) only, which
 * these guarantee by holding no state of their own.
 */
#ifndef WPD_SYNTH_MATH_H
#define WPD_SYNTH_MATH_H

#include <stdint.h>

/* splitmix64's finaliser: a bijective 64-bit mix. */
static inline uint64_t mix64(uint64_t z)
{
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
}

/* Stateless hash of a scene feature: (seed, kind of feature, cell a b c). */
static inline uint64_t feature_hash(uint64_t seed, uint64_t kind, int64_t a, int64_t b, int64_t c)
{
    uint64_t h = mix64(seed ^ (kind * 0x9e3779b97f4a7c15ULL));
    h = mix64(h ^ (uint64_t)a);
    h = mix64(h ^ ((uint64_t)b * 0xd6e8feb86659fd93ULL));
    return mix64(h ^ ((uint64_t)c * 0xa0761d6478bd642fULL));
}

/* The k-th uniform [0, 1) drawn from a feature hash. */
static inline double hash_unit(uint64_t h, unsigned k)
{
    return (double)(mix64(h + k * 0x9e3779b97f4a7c15ULL) >> 11) * 0x1.0p-53;
}

/* The scan's random stream: splitmix64 (a Weyl sequence through mix64;
 * passes BigCrush), a third of the cost of xoshiro256** per draw. */
typedef struct rng { uint64_t state; } rng;

/* Starts the stream of r from seed (any value). */
static inline void rng_seed(rng *r, uint64_t seed)
{
    r->state = mix64(seed ^ 0x5eed5eed5eed5eedULL);
}

/* The next 64 random bits of r. */
static inline uint64_t rng_next(rng *r)
{
    r->state += 0x9e3779b97f4a7c15ULL;
    return mix64(r->state);
}

/* The next uniform [0, 1) of r (53 bits). */
static inline double rng_unit(rng *r) { return (double)(rng_next(r) >> 11) * 0x1.0p-53; }

/* Triangular noise in (-1, 1), standard deviation 0.41, from 32 random bits
 * (the sum of two 16-bit uniforms): two noise values per draw. */
static inline double tri_noise(uint32_t bits)
{
    return ((double)(bits & 0xffff) + (double)(bits >> 16)) * (1.0 / 65536) - 1.0;
}

/* ------------------------------------------------------------ fast math */

static inline double min2(double a, double b) { return a < b ? a : b; }
static inline double max2(double a, double b) { return a > b ? a : b; }

/* sin(2 pi t) for t >= 0 by linear interpolation in a table of one cycle:
 * error < 5e-6, so under 0.1 mm on the terrain's 8 m wave. The terrain is
 * evaluated for every pulse; this costs a fifth of a polynomial. */
#define SINE_STEPS 1024

/* tab holds SINE_STEPS + 1 values sin(2 pi i / SINE_STEPS) (scene.sine). */
static inline double sin_table(const double *tab, double t)
{
    double u = t * SINE_STEPS;
    int64_t i = (int64_t)u;
    double f = u - (double)i;
    const double *p = tab + (i & (SINE_STEPS - 1));
    return p[0] + f * (p[1] - p[0]);
}

/* v limited to [lo, hi] (lo <= hi). */
static inline double clampd(double v, double lo, double hi) { return v < lo ? lo : v > hi ? hi : v; }

#endif
