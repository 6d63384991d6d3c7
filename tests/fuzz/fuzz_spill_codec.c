/* fuzz_spill_codec.c - libFuzzer target for the spill's coordinate codec
 * (src/spill/codec.h). Built by `make fuzz` / `make fuzz-smoke`.
 *
 * Byte 0 picks what the rest is:
 *   even  a coordinate block: wpd_coords_count, then wpd_coords_decode into
 *         arrays of exactly the counted size (ASan sees any access past
 *         them). Must not crash; decoding with a wrong count must fail.
 *   odd   columns: 8 bytes of "base", then 27 bytes a point (a 2-byte gid
 *         step, signed, so gids may fall; a halo byte; 24 coordinate
 *         bytes). Bits 1-2 of byte 0 choose how the coordinate bytes
 *         become doubles (raw bits, a LAS grid X * scale + base, floats,
 *         or per axis by the halo byte), bits 3-4 the LAS scale. The
 *         columns are encoded and decoded: anything but the same bits
 *         (halo: 0/1) aborts. With bit 5 one byte of the block is then
 *         changed (where and how: base bytes) and decoded again, which
 *         must not crash.
 * A raw block rarely passes the header checks; the odd inputs feed the
 * decoder well-formed blocks with one fault, the way a damaged spill file
 * would look after a missed checksum.
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "spill/codec.h"

#define MAX_POINTS 4096
#define POINT_BYTES 27

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

/* Decoded columns in exactly sized allocations. */
typedef struct cols {
    uint64_t *gid, *scratch;
    double *xyz;
    uint8_t *halo;
} cols;

static int cols_alloc(cols *c, size_t n)
{
    c->gid = malloc(n ? 8 * n : 1);
    c->scratch = malloc(n ? 16 * n : 1);
    c->xyz = malloc(n ? 24 * n : 1);
    c->halo = malloc(n ? n : 1);
    return c->gid && c->scratch && c->xyz && c->halo ? 0 : -1;
}

static void cols_free(cols *c)
{
    free(c->gid);
    free(c->scratch);
    free(c->xyz);
    free(c->halo);
}

static void broken(const char *why)
{
    fprintf(stderr, "fuzz_spill_codec: %s\n", why);
    abort();
}

/* Even inputs: the bytes are a block. */
static void decode_block(const uint8_t *in, size_t size)
{
    size_t n;
    wpd_error err;
    if (wpd_coords_count(in, size, &n, &err) || n > MAX_POINTS)
        return; /* constant columns claim any count at no cost: bound it */
    cols c;
    if (cols_alloc(&c, n + 1) == 0) {
        (void)wpd_coords_decode(in, size, n, c.gid, c.xyz, c.halo, c.scratch, &err);
        if (wpd_coords_decode(in, size, n + 1, c.gid, c.xyz, c.halo, c.scratch, &err) == 0)
            broken("a block decodes with a count other than its own");
    }
    cols_free(&c);
}

/* Coordinate a (0-2) of a point from its 8 bytes p, in style. */
static double coordinate(int style, const uint8_t *p, double scale, double base)
{
    int32_t X;
    float f;
    double v;
    memcpy(&X, p, 4);
    memcpy(&f, p + 4, 4);
    memcpy(&v, p, 8);
    switch (style) {
    case 1: return X * scale + base; /* as a LAS reader computes it */
    case 2: return f;
    default: return v;
    }
}

/* Odd inputs: columns from the bytes, n points. */
static void make_columns(const uint8_t *data, size_t n, cols *c)
{
    static const double scales[4] = {0.01, 0.001, 0.1, 0.00025};
    uint8_t ctl = data[0];
    int style = (ctl >> 1) & 3;
    double base, scale = scales[(ctl >> 3) & 3];
    memcpy(&base, data + 1, 8);
    if (!isfinite(base) || fabs(base) > 1e9)
        base = 0;
    uint64_t g;
    memcpy(&g, data + 1, 8);
    const uint8_t *p = data + 9;
    for (size_t i = 0; i < n; i++, p += POINT_BYTES) {
        int16_t step;
        memcpy(&step, p, 2);
        c->gid[i] = g += (uint64_t)(int64_t)step;
        c->halo[i] = p[2];
        for (int a = 0; a < 3; a++) {
            int s = style == 3 ? (p[2] >> (2 * a)) % 3 : style;
            c->xyz[3 * i + a] = coordinate(s, p + 3 + 8 * a, scale, base);
        }
    }
}

/* Decodes blk with byte pos changed by mask: must return, nothing else. */
static void decode_damaged(uint8_t *blk, size_t bytes, size_t n, size_t pos, uint8_t mask)
{
    cols d;
    wpd_error err;
    blk[pos % bytes] ^= mask;
    if (cols_alloc(&d, n) == 0)
        (void)wpd_coords_decode(blk, bytes, n, d.gid, d.xyz, d.halo, d.scratch, &err);
    cols_free(&d);
}

static void round_trip(const uint8_t *data, size_t size)
{
    if (size < 9)
        return;
    size_t n = (size - 9) / POINT_BYTES;
    n = n > MAX_POINTS ? MAX_POINTS : n;
    cols c = {0}, d = {0};
    uint8_t *blk = malloc(wpd_coords_bound(n));
    if (blk && cols_alloc(&c, n) == 0 && cols_alloc(&d, n) == 0) {
        make_columns(data, n, &c);
        size_t bytes = wpd_coords_encode(c.gid, c.xyz, c.halo, n, blk, c.scratch);
        wpd_error err;
        if (!bytes || wpd_coords_decode(blk, bytes, n, d.gid, d.xyz, d.halo, d.scratch, &err))
            broken(bytes ? err.msg : "encoding failed");
        if (n && (memcmp(c.gid, d.gid, 8 * n) || memcmp(c.xyz, d.xyz, 24 * n)))
            broken("round trip changed gids or coordinates");
        for (size_t i = 0; i < n; i++)
            if (d.halo[i] != (c.halo[i] != 0))
                broken("round trip changed a halo flag");
        if (data[0] & 0x20)
            decode_damaged(blk, bytes, n, (size_t)data[1] | (size_t)data[2] << 8,
                           data[3] ? data[3] : 1);
    }
    free(blk);
    cols_free(&c);
    cols_free(&d);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size < 1)
        return 0;
    if (data[0] & 1)
        round_trip(data, size);
    else
        decode_block(data + 1, size - 1);
    return 0;
}
