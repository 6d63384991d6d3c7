/* hash.h - integer mixing shared by the WPD core.
 *
 * All randomness in the resampler comes from these functions of (seed,
 * global index), never from a generator with state, so that the result does
 * not depend on how a cloud was split into blocks or on thread scheduling.
 */
#ifndef WPD_CORE_HASH_H
#define WPD_CORE_HASH_H

#include <stdint.h>

/* The splitmix64 finaliser: a bijection on 64-bit integers with good
 * avalanche, so distinct inputs always give distinct outputs. */
static inline uint64_t wpd_mix64(uint64_t x)
{
    x ^= x >> 30;
    x *= 0xbf58476d1ce4e5b9ULL;
    x ^= x >> 27;
    x *= 0x94d049bb133111ebULL;
    x ^= x >> 31;
    return x;
}

/* Visiting priority of the point with global index gid under seed: smaller
 * is visited first. For a fixed seed it is a bijection of gid, so two points
 * never tie. */
static inline uint64_t wpd_priority(uint64_t seed, uint64_t gid)
{
    return wpd_mix64(gid ^ wpd_mix64(seed + 0x9e3779b97f4a7c15ULL));
}

#endif
