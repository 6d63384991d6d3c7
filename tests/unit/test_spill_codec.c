/* test_spill_codec.c - the spill's coordinate codec (src/spill/codec.h) and
 * byte planes (src/spill/planes.h) on their own, without files: bit-exact
 * round trips on every kind of coordinate the spill meets, and damaged
 * blocks (every truncation, every single-byte change), which must decode to
 * an error or, where the change is undetectable by design (a value plane),
 * to some values, never crash or touch memory outside the arrays (run under
 * `make test-asan` to be sure of the latter). */
#include "harness.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "spill/codec.h"
#include "spill/planes.h"

/* ---- helpers ---- */

static uint64_t rng_next(uint64_t *s)
{
    *s ^= *s << 13;
    *s ^= *s >> 7;
    *s ^= *s << 17;
    return *s;
}

/* Columns of n points, in exactly sized allocations so that ASan sees any
 * access past them. */
typedef struct cols {
    size_t n;
    uint64_t *gid;
    double *xyz;
    uint8_t *halo;
} cols;

static cols cols_new(size_t n)
{
    cols c = {n, malloc(8 * n + 1), malloc(24 * n + 1), malloc(n + 1)};
    return c;
}

static void cols_free(cols *c)
{
    free(c->gid);
    free(c->xyz);
    free(c->halo);
}

/* Increasing gids with small gaps, every 5th point a halo point. */
static void fill_ids(cols *c, uint64_t *seed)
{
    uint64_t g = 1u << 20;
    for (size_t i = 0; i < c->n; i++) {
        c->gid[i] = g += 1 + rng_next(seed) % 3;
        c->halo[i] = rng_next(seed) % 5 == 0;
    }
}

/* LAS-like frame coordinates: integers X on a walk, X * scale + offset,
 * minus the origin if frame (else absolute). */
static void fill_las(cols *c, double scale, const double off[3], int frame, uint64_t *seed)
{
    int32_t X[3] = {0, 0, 0};
    for (size_t i = 0; i < c->n; i++)
        for (int k = 0; k < 3; k++) {
            X[k] += (int32_t)(rng_next(seed) % 201) - 100;
            double v = X[k] * scale + off[k];
            c->xyz[3 * i + k] = frame ? v - (off[k] - 1000.0) : v;
        }
}

/* Encodes c, checks the count, decodes into fresh columns; 0 if every bit
 * came back (halo as 0/1), the encoded size in *size. */
static int round_trip(const cols *c, size_t *size, int *failures_)
{
    size_t n = c->n;
    uint8_t *block = malloc(wpd_coords_bound(n));
    uint64_t *scratch = malloc(16 * n + 8);
    cols d = cols_new(n);
    size_t bytes = wpd_coords_encode(c->gid, c->xyz, c->halo, n, block, scratch);
    CHECK(bytes >= WPD_COORDS_HEAD_BYTES && bytes <= wpd_coords_bound(n));
    wpd_error err;
    size_t count = 12345;
    CHECK_MSG(wpd_coords_count(block, bytes, &count, &err) == 0 && count == n, "%s", err.msg);
    int rc = wpd_coords_decode(block, bytes, n, d.gid, d.xyz, d.halo, scratch, &err);
    CHECK_MSG(rc == 0, "%s", err.msg);
    int same = rc == 0 && (n == 0 || (!memcmp(d.gid, c->gid, 8 * n) &&
                                      !memcmp(d.xyz, c->xyz, 24 * n)));
    for (size_t i = 0; same && i < n; i++)
        same = d.halo[i] == (c->halo[i] != 0);
    *size = bytes;
    cols_free(&d);
    free(block);
    free(scratch);
    return same ? 0 : -1;
}

/* ---- round trips ---- */

TEST(codec_las_grid_round_trip)
{
    static const double offs[2][3] = {{500000.0, 4500000.0, 100.0},
                                      {639187.0, 221748.0, 323.0}};
    static const double scales[2] = {0.01, 0.001};
    uint64_t seed = 0x2545f4914f6cdd1dull;
    for (int si = 0; si < 2; si++)
        for (int oi = 0; oi < 2; oi++)
            for (int frame = 0; frame < 2; frame++) {
                cols c = cols_new(5000);
                fill_ids(&c, &seed);
                fill_las(&c, scales[si], offs[oi], frame, &seed);
                size_t size;
                CHECK_MSG(round_trip(&c, &size, failures_) == 0,
                          "scale %g offset %d frame %d", scales[si], oi, frame);
                /* The grid path: index deltas of 1 byte, residuals of at
                 * most 1 (absolute values beyond 2^22 m may need 2):
                 * far below the 33 raw bytes a point. */
                CHECK_MSG(size < 12 * c.n, "scale %g offset %d frame %d: %zu bytes",
                          scales[si], oi, frame, size);
                cols_free(&c);
            }
}

TEST(codec_ply_floats_round_trip)
{
    uint64_t seed = 77;
    cols c = cols_new(3000);
    fill_ids(&c, &seed);
    for (size_t i = 0; i < 3 * c.n; i++) {
        double u = (double)(rng_next(&seed) >> 11) / 9007199254740992.0;
        c.xyz[i] = (double)(float)(u * 1000.0 - 200.0);
    }
    size_t size;
    CHECK(round_trip(&c, &size, failures_) == 0);
    CHECK_MSG(size < 33 * c.n, "%zu bytes", size);
    /* doubles on no grid at all (random mantissas) */
    for (size_t i = 0; i < 3 * c.n; i++)
        c.xyz[i] = (double)(rng_next(&seed) >> 11) / 9007199254740992.0 * 1e6;
    CHECK(round_trip(&c, &size, failures_) == 0);
    cols_free(&c);
}

TEST(codec_non_finite_round_trip)
{
    uint64_t nan_payload = 0x7ff8dead0000beefull, snan = 0x7ff0000000000001ull;
    double specials[10] = {NAN, -NAN, INFINITY, -INFINITY, -0.0, 0.0, 5e-324, -1e-310,
                           1.7976931348623157e308, 0};
    memcpy(&specials[9], &nan_payload, 8);
    uint64_t seed = 99;
    cols c = cols_new(1000);
    fill_ids(&c, &seed);
    for (size_t i = 0; i < c.n; i++) {
        c.xyz[3 * i] = (double)i * 0.01;                    /* grid */
        c.xyz[3 * i + 1] = specials[rng_next(&seed) % 10];  /* raw */
        c.xyz[3 * i + 2] = i % 100 ? (double)i : specials[i / 100 % 10];
    }
    memcpy(&c.xyz[4], &snan, 8);
    size_t size;
    CHECK(round_trip(&c, &size, failures_) == 0);
    /* any bit pattern at all */
    for (size_t i = 0; i < c.n; i++)
        for (int k = 0; k < 3; k++) {
            uint64_t u = rng_next(&seed);
            memcpy(&c.xyz[3 * i + k], &u, 8);
        }
    CHECK(round_trip(&c, &size, failures_) == 0);
    cols_free(&c);
}

TEST(codec_zero_and_one_point)
{
    cols c = cols_new(0);
    size_t size;
    CHECK(round_trip(&c, &size, failures_) == 0);
    CHECK(size == WPD_COORDS_HEAD_BYTES);
    cols_free(&c);
    static const double one[4][3] = {{1.25, -3.5, 0}, {NAN, INFINITY, -0.0},
                                     {500000.01, 4500000.02, 123.45}, {5e-324, 1e308, -7}};
    for (int k = 0; k < 4; k++) {
        c = cols_new(1);
        c.gid[0] = k == 1 ? UINT64_MAX : (uint64_t)k * 1000003;
        c.halo[0] = (uint8_t)(k * 100);
        memcpy(c.xyz, one[k], 24);
        CHECK_MSG(round_trip(&c, &size, failures_) == 0, "point %d", k);
        cols_free(&c);
    }
}

TEST(codec_constant_axis_and_any_gids)
{
    uint64_t seed = 4242;
    cols c = cols_new(777);
    for (size_t i = 0; i < c.n; i++) {
        c.gid[i] = rng_next(&seed);                  /* any order: deltas wrap */
        c.halo[i] = (uint8_t)rng_next(&seed);        /* any nonzero byte is 1 */
        c.xyz[3 * i] = 100.0 + (double)(i % 50) * 0.01;
        c.xyz[3 * i + 1] = 4500000.37;               /* constant */
        c.xyz[3 * i + 2] = 0;                        /* constant zero */
    }
    size_t size;
    CHECK(round_trip(&c, &size, failures_) == 0);
    for (size_t i = 0; i < c.n; i++) /* halo all 0, gids all equal */
        c.halo[i] = 0, c.gid[i] = 7;
    CHECK(round_trip(&c, &size, failures_) == 0);
    cols_free(&c);
}

/* Found by fuzz_spill_codec: the 16 values the decimal grid is guessed
 * from lie on 0.01, the others are random doubles of the same range, so
 * residuals need 8 bytes on top of the grid index; with random gids the
 * encoder wrote past wpd_coords_bound(n). Such an axis must go raw. */
TEST(codec_off_grid_values_stay_within_bound)
{
    enum { N = 1000 };
    uint64_t seed = 8;
    cols c = cols_new(N);
    for (size_t i = 0; i < N; i++) {
        c.gid[i] = rng_next(&seed);
        c.halo[i] = 1;
        for (int k = 0; k < 3; k++)
            c.xyz[3 * i + k] = 1.0 + (double)(rng_next(&seed) >> 12) / 4503599627370496.0;
    }
    for (size_t k = 0; k < 16; k++) /* the grid guess's samples */
        for (int a = 0; a < 3; a++)
            c.xyz[3 * (k * N / 16) + a] = 1.0 + (double)(k * 7 % 100) * 0.01;
    size_t size;
    CHECK(round_trip(&c, &size, failures_) == 0);
    CHECK_MSG(size <= wpd_coords_bound(N), "%zu bytes, bound %zu", size, wpd_coords_bound(N));
    cols_free(&c);
}

/* Found by fuzz_spill_codec: -3152519737938368.5 on the decimal grid 1
 * has grid index K / 2 = -(2^51 + ...) + 0.5, which the fast rounding
 * leaves unrounded; the encoder predicted from that value but stored its
 * truncation, and the point came back 0.5 off. Values around 2^51-2^53
 * with a half, both signs, must round-trip. */
TEST(codec_grid_index_beyond_2_51)
{
    cols c = cols_new(64);
    uint64_t seed = 3;
    fill_ids(&c, &seed);
    for (size_t i = 0; i < c.n; i++)
        for (int k = 0; k < 3; k++) {
            double m = (double)(1ull << (51 + (i + k) % 3)) + (double)(rng_next(&seed) % 1000);
            c.xyz[3 * i + k] = ((i + k) % 2 ? -1 : 1) * (m + 0.5);
        }
    size_t size;
    CHECK(round_trip(&c, &size, failures_) == 0);
    cols_free(&c);
    c = cols_new(1);
    c.gid[0] = 5;
    c.halo[0] = 0;
    c.xyz[0] = c.xyz[2] = 1.0;
    c.xyz[1] = -3152519737938368.5;
    CHECK(round_trip(&c, &size, failures_) == 0);
    cols_free(&c);
}

TEST(codec_too_many_points_is_refused)
{
    /* checked before any column is touched */
    size_t n = (size_t)WPD_COORDS_MAX_POINTS + 1;
    CHECK(wpd_coords_encode(NULL, NULL, NULL, n, NULL, NULL) == 0);
}

TEST(planes_round_trip)
{
    uint64_t seed = 5;
    for (size_t n = 0; n < 80; n += 7) {
        uint64_t v[80], back[80];
        uint8_t planes[8 * 80];
        for (unsigned w = 0; w <= 8; w++) {
            uint64_t mask = w == 8 ? UINT64_MAX : (1ull << (8 * w)) - 1;
            for (size_t i = 0; i < n; i++)
                v[i] = rng_next(&seed) & mask;
            wpd_planes_put(planes, v, n, w);
            wpd_planes_get(back, planes, n, w);
            CHECK_MSG(n == 0 || !memcmp(v, back, 8 * n), "n %zu w %u", n, w);
        }
        for (size_t rs = 1; rs <= 40; rs += 13) {
            uint8_t rec[80 * 40], pl[80 * 40], out[80 * 40];
            for (size_t i = 0; i < n * rs; i++)
                rec[i] = (uint8_t)rng_next(&seed);
            wpd_planes_from_records(pl, rec, n, rs);
            CHECK(n < 2 || pl[1] == rec[rs]); /* plane 0 holds byte 0 of each */
            wpd_planes_to_records(out, pl, n, rs);
            CHECK_MSG(!memcmp(rec, out, n * rs), "n %zu records of %zu", n, rs);
        }
    }
    CHECK(wpd_plane_width(0) == 0 && wpd_plane_width(255) == 1 && wpd_plane_width(256) == 2 &&
          wpd_plane_width(70000) == 4 && wpd_plane_width(1ull << 32) == 8);
}

/* ---- damaged blocks ---- */

/* A small block through every path: LAS grid x, float y, raw z (some
 * NaN), halo bits with a ragged last byte. */
static size_t small_block(uint8_t *block, cols *c)
{
    uint64_t seed = 31337;
    fill_ids(c, &seed);
    for (size_t i = 0; i < c->n; i++) {
        c->xyz[3 * i] = 1000.0 + (double)(rng_next(&seed) % 5000) * 0.01;
        c->xyz[3 * i + 1] = (double)(float)((double)(rng_next(&seed) % 100000) / 7.0);
        c->xyz[3 * i + 2] = i % 9 ? (double)i * 0.5 : NAN;
    }
    uint64_t scratch[2 * 64];
    if (c->n > 64)
        return 0;
    return wpd_coords_encode(c->gid, c->xyz, c->halo, c->n, block, scratch);
}

TEST(codec_every_truncation_is_an_error)
{
    enum { N = 37 };
    cols c = cols_new(N), d = cols_new(N);
    uint8_t block[2048];
    size_t size = small_block(block, &c);
    CHECK(size > WPD_COORDS_HEAD_BYTES && size <= sizeof block);
    uint64_t scratch[2 * N];
    wpd_error err;
    for (size_t len = 0; len < size; len++) {
        /* a copy of exactly len bytes: ASan catches a read past it */
        uint8_t *cut = malloc(len ? len : 1);
        memcpy(cut, block, len);
        size_t count;
        CHECK_MSG(wpd_coords_decode(cut, len, N, d.gid, d.xyz, d.halo, scratch, &err) == -1,
                  "%zu of %zu bytes decode", len, size);
        CHECK_MSG(err.code == WPD_E_INPUT && !strncmp(err.msg, "coordinate block", 16), "%s",
                  err.msg);
        CHECK(wpd_coords_count(cut, len, &count, &err) == -1);
        free(cut);
    }
    /* one byte too many, and the wrong count */
    block[size] = 0;
    CHECK(wpd_coords_decode(block, size + 1, N, d.gid, d.xyz, d.halo, scratch, &err) == -1);
    CHECK(wpd_coords_decode(block, size, N - 1, d.gid, d.xyz, d.halo, scratch, &err) == -1);
    CHECK(wpd_coords_decode(block, size, N, d.gid, d.xyz, d.halo, scratch, &err) == 0);
    cols_free(&c);
    cols_free(&d);
}

TEST(codec_byte_flips_never_crash)
{
    enum { N = 37 };
    static const uint8_t masks[] = {0x01, 0x10, 0x80, 0xff};
    cols c = cols_new(N), d = cols_new(N);
    uint8_t block[2048];
    size_t size = small_block(block, &c);
    uint64_t *scratch = malloc(2 * N * sizeof *scratch);
    uint8_t *copy = malloc(size);
    size_t errors = 0, undetected = 0, header_undetected = 0;
    for (size_t pos = 0; pos < size; pos++)
        for (size_t m = 0; m < sizeof masks; m++) {
            memcpy(copy, block, size);
            copy[pos] ^= masks[m];
            wpd_error err;
            int rc = wpd_coords_decode(copy, size, N, d.gid, d.xyz, d.halo, scratch, &err);
            if (rc) {
                CHECK_MSG(err.code == WPD_E_INPUT, "%s", err.msg);
                errors++;
            } else {
                undetected++;
                header_undetected += pos < WPD_COORDS_HEAD_BYTES;
            }
        }
    /* Every flip ran to an answer. The header is checked field by field:
     * only the first gid, an axis's first grid index, the low bits of its
     * binary exponent and its grid step (within range) change values
     * without a trace (the zstd checksum guards them in a spill). */
    CHECK(errors > 0 && undetected > 0);
    CHECK_MSG(header_undetected < 4 * 40, "%zu undetected header flips", header_undetected);
    if (getenv("WPD_TEST_VERBOSE"))
        printf("  %zu-byte block: %zu flips rejected, %zu undetected (%zu in the header)\n",
               size, errors, undetected, header_undetected);
    free(copy);
    free(scratch);
    cols_free(&c);
    cols_free(&d);
}
