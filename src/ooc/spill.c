/* spill.c - per-tile spill files (see spill.h).
 *
 * Files: "<dir>/tile-NNNNNN", one per tile that received points, a
 * sequence of chunks; a chunk holds one full write buffer (or the tail at
 * wpd_spill_finish): a 32-byte header, then the coordinate frame (gid, xyz,
 * halo; the codec below, zstd with checksum), then the record frame (the
 * records transposed to byte planes, zstd with checksum). A coordinate read
 * reads headers and coordinate frames only. The chunk index stays in
 * memory; each header repeats it, so damage is an error naming the file.
 *
 * Threads (options.threads): 0 compresses and writes on the appending
 * thread; k > 0 starts k compression threads: a full buffer is handed over
 * and the tile continues in a spare one (options.spares_per_thread a
 * thread). Memory while writing: (tiles that received points +
 * spares_per_thread k) * buffer_bytes, plus per
 * thread about 2.5 buffer_bytes of scratch and a zstd context. Halo flags
 * are stored as bits: any nonzero flag reads back as 1.
 *
 * Measured (bench/spill.sh; 2-core AMD EPYC VM, zstd 1.5.4). Each file cut
 * into 64 tiles by an x/y grid, points in input order, 256 KB chunks; MB/s
 * of raw bytes on one core, decompression includes the inverse transform.
 * Coordinate part 33 bytes a point (layouts: see bench/spill_bench.c):
 *
 *                          synthetic city 20 M      NC Raleigh 2.3 M
 *   layout       level    ratio  comp  decomp    ratio  comp  decomp
 *   rows            -3     2.60   522   1374      1.59   468   1504
 *   cols            -1     5.72   627   1570      2.75   425   1229
 *   cols, gid delta  3     8.56   728   2201      2.98   258   1209
 *   byte-shuffled   -3     3.42  1101   1931      1.64  1101   1888
 *   shuffled deltas -3     3.45   941   1545      1.60   854   1503
 *   shuffled xor    -3     3.39   887   1541      1.64  1023   1494
 *   grid codec      -7    13.48  1371   2650      4.29   924   2000
 *   grid codec      -3    15.45  1353   2605      4.55   843   1935
 *   grid codec      -1    16.68  1231   2671      4.71   797   1916
 *   grid codec       1    20.94  1113   2277      5.00   732   1699
 * Records (34 / 38 bytes):
 *   rows            -3     1.81   535   1861      3.02   888   3071
 *   transposed      -7     3.69  1553   2993      5.63  1761   2817
 *   transposed      -3     4.02  1369   2922      5.96  1595   2674
 *   transposed      -1     4.18  1233   2946      6.16  1550   2773
 *
 * Byte shuffling alone gains little on frame coordinates: their low
 * mantissa bytes are the rounding noise of X * scale + offset - origin.
 * The grid codec removes exactly that noise and is as fast as the fastest
 * generic layout. Level -3 by default: against -7, 6-15 % smaller for 1-12 %
 * more compression time; levels >= 1 cost 20-40 % more time for a few %.
 * (The synthetic scan lies on an exact grid; NC Raleigh is the realistic
 * figure.)
 *
 * End to end, 100 M points into 256 tiles, defaults (level -3, 256 KB
 * buffers, 2 compression threads beside the appending thread, 2 cores),
 * bench/spill.sh:
 *                           tiling wall  in append  disk   ratio  coords  +records
 *   synthetic 20 M x 5        4.1 s       2.9 s    1052 MB  6.37  1.0 s    1.9 s
 *   NC Raleigh x 44           4.8 s       3.4 s    1372 MB  5.17  1.1 s    2.3 s
 * (tiling wall includes reading the LAS input; coords / +records: one
 * read-back of every tile on 2 threads). Writing to the page cache costs
 * 0.5 - 2.7 ns a byte of kernel time on this VM, so the ratio matters even
 * when nothing reaches the disk.
 */
#include "ooc/spill.h"

#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <time.h>
#include <unistd.h>
#include <zstd.h>
#include <zstd_errors.h>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "common/tmpdir.h"

#define CHUNK_MAGIC 0x31505357u  /* "WSP1" little-endian */
#define MAX_OPEN_FILES 64        /* tile files kept open while writing */

static double now_seconds(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + ts.tv_nsec * 1e-9;
}

/* ======================================================================
 * Byte planes: a value of width w bytes is stored as w planes of n bytes
 * (plane b holds byte b of every value). Narrow planes of small integers
 * are mostly zero and compress to nearly nothing; the noisy low planes stay
 * apart from them.
 * ====================================================================== */

#if defined(__SSE2__)
/* Bit-reversed 4-bit index: after transpose16_regs, register i holds
 * column bitrev4[i] of the block. */
static const uint8_t bitrev4[16] = {0, 8, 4, 12, 2, 10, 6, 14, 1, 9, 5, 13, 3, 11, 7, 15};

/* Transposes the 16 x 16 byte block held as 16 rows in a: four rounds of
 * SSE2 unpacks. */
static inline __attribute__((always_inline)) void transpose16_regs(__m128i a[16])
{
    __m128i b[16];
    for (int i = 0; i < 8; i++) {
        b[i] = _mm_unpacklo_epi8(a[2 * i], a[2 * i + 1]);
        b[i + 8] = _mm_unpackhi_epi8(a[2 * i], a[2 * i + 1]);
    }
    for (int i = 0; i < 8; i++) {
        a[i] = _mm_unpacklo_epi16(b[2 * i], b[2 * i + 1]);
        a[i + 8] = _mm_unpackhi_epi16(b[2 * i], b[2 * i + 1]);
    }
    for (int i = 0; i < 8; i++) {
        b[i] = _mm_unpacklo_epi32(a[2 * i], a[2 * i + 1]);
        b[i + 8] = _mm_unpackhi_epi32(a[2 * i], a[2 * i + 1]);
    }
    for (int i = 0; i < 8; i++) {
        a[i] = _mm_unpacklo_epi64(b[2 * i], b[2 * i + 1]);
        a[i + 8] = _mm_unpackhi_epi64(b[2 * i], b[2 * i + 1]);
    }
}

/* Transposes the 16 x 16 byte block at src (rows sstride bytes apart) into
 * dst (rows dstride apart). */
static inline void transpose16(const uint8_t *src, size_t sstride, uint8_t *dst, size_t dstride)
{
    __m128i a[16];
    for (int i = 0; i < 16; i++)
        a[i] = _mm_loadu_si128((const __m128i *)(src + i * sstride));
    transpose16_regs(a);
    for (int i = 0; i < 16; i++)
        _mm_storeu_si128((__m128i *)(dst + bitrev4[i] * dstride), a[i]);
}
#endif

/* Planes 0 .. w-1 of v[n] into dst (plane b at dst + b n). With SSE2, 32
 * values at a time: their 256 bytes as 16 rows of two values, transposed,
 * give byte b of the even values in column b and of the odd ones in column
 * b + 8; interleaving the two restores value order. */
static void planes_put(uint8_t *restrict dst, const uint64_t *restrict v, size_t n, unsigned w)
{
    size_t i = 0;
#if defined(__SSE2__)
    for (; w && i + 32 <= n; i += 32) {
        __m128i a[16], col[16];
        for (int r = 0; r < 16; r++)
            a[r] = _mm_loadu_si128((const __m128i *)(v + i + 2 * r));
        transpose16_regs(a);
        for (int k = 0; k < 16; k++)
            col[bitrev4[k]] = a[k];
        for (unsigned b = 0; b < w; b++) {
            _mm_storeu_si128((__m128i *)(dst + b * n + i), _mm_unpacklo_epi8(col[b], col[b + 8]));
            _mm_storeu_si128((__m128i *)(dst + b * n + i + 16),
                             _mm_unpackhi_epi8(col[b], col[b + 8]));
        }
    }
#endif
    for (unsigned b = 0; b < w; b++)
        for (size_t k = i; k < n; k++)
            dst[b * n + k] = (uint8_t)(v[k] >> (8 * b));
}

#if defined(__SSE2__)
/* 16 values from w planes (16 bytes each, n apart) into v: three rounds of
 * unpacks interleave byte pairs, then 16-bit pairs, then 32-bit halves.
 * Inlined per width, so the rounds on all-zero planes fold away. */
static inline __attribute__((always_inline)) void planes_get16(uint64_t *v, const uint8_t *src,
                                                               size_t n, unsigned w)
{
    __m128i p[8], a[8], b[8];
    for (unsigned k = 0; k < 8; k++)
        p[k] = k < w ? _mm_loadu_si128((const __m128i *)(src + k * n)) : _mm_setzero_si128();
    for (int k = 0; k < 4; k++) { /* bytes 2k, 2k+1 of values 0-7 and 8-15 */
        a[k] = _mm_unpacklo_epi8(p[2 * k], p[2 * k + 1]);
        a[k + 4] = _mm_unpackhi_epi8(p[2 * k], p[2 * k + 1]);
    }
    for (int h = 0; h < 8; h += 4) { /* bytes 0-3 and 4-7 of 4 values */
        b[h] = _mm_unpacklo_epi16(a[h], a[h + 1]);
        b[h + 1] = _mm_unpackhi_epi16(a[h], a[h + 1]);
        b[h + 2] = _mm_unpacklo_epi16(a[h + 2], a[h + 3]);
        b[h + 3] = _mm_unpackhi_epi16(a[h + 2], a[h + 3]);
    }
    for (int h = 0; h < 8; h += 4) { /* whole values, two per register */
        uint64_t *o = v + 2 * h;
        _mm_storeu_si128((__m128i *)o, _mm_unpacklo_epi32(b[h], b[h + 2]));
        _mm_storeu_si128((__m128i *)(o + 2), _mm_unpackhi_epi32(b[h], b[h + 2]));
        _mm_storeu_si128((__m128i *)(o + 4), _mm_unpacklo_epi32(b[h + 1], b[h + 3]));
        _mm_storeu_si128((__m128i *)(o + 6), _mm_unpackhi_epi32(b[h + 1], b[h + 3]));
    }
}

static inline __attribute__((always_inline)) size_t planes_get_w(uint64_t *v, const uint8_t *src,
                                                                 size_t n, unsigned w)
{
    size_t i = 0;
    for (; i + 16 <= n; i += 16)
        planes_get16(v + i, src + i, n, w);
    return i;
}
#endif

/* Inverse of planes_put: v[n] from w planes, the missing high bytes 0. */
static void planes_get(uint64_t *restrict v, const uint8_t *restrict src, size_t n, unsigned w)
{
    size_t i = 0;
#if defined(__SSE2__)
    switch (w) {
    case 1: i = planes_get_w(v, src, n, 1); break;
    case 2: i = planes_get_w(v, src, n, 2); break;
    case 4: i = planes_get_w(v, src, n, 4); break;
    case 8: i = planes_get_w(v, src, n, 8); break;
    default: break;
    }
#endif
    for (size_t k = i; k < n; k++) {
        uint64_t x = 0;
        for (unsigned b = 0; b < w; b++)
            x |= (uint64_t)src[b * n + k] << (8 * b);
        v[k] = x;
    }
}

/* Transposes the rows x cols byte matrix src (row-major) into dst (cols x
 * rows). Blocks of 16 x 16 with SSE2; the last block of each direction
 * overlaps its neighbour instead of leaving a ragged edge (it rewrites the
 * same bytes). */
static void transpose_bytes(uint8_t *restrict dst, const uint8_t *restrict src, size_t rows,
                            size_t cols)
{
#if defined(__SSE2__)
    if (rows >= 16 && cols >= 16) {
        for (size_t i = 0; i < rows; i += 16) {
            size_t r = i + 16 <= rows ? i : rows - 16;
            for (size_t j = 0; j < cols; j += 16) {
                size_t c = j + 16 <= cols ? j : cols - 16;
                transpose16(src + r * cols + c, cols, dst + c * rows + r, rows);
            }
        }
        return;
    }
#endif
    for (size_t c = 0; c < cols; c++, dst += rows) {
        const uint8_t *s = src + c;
        for (size_t i = 0; i < rows; i++)
            dst[i] = s[i * cols];
    }
}

/* Records of w bytes -> w planes (byte b of every record together), so that
 * each field's bytes sit next to the same byte of the neighbours' field. */
static void transpose(uint8_t *restrict dst, const uint8_t *restrict src, size_t n, size_t w)
{
    transpose_bytes(dst, src, n, w);
}

static void untranspose(uint8_t *restrict dst, const uint8_t *restrict src, size_t n, size_t w)
{
    transpose_bytes(dst, src, w, n);
}

/* Bytes needed for the unsigned value m (0 for 0): the plane width. */
static unsigned width_of(uint64_t m)
{
    return m == 0 ? 0 : m < (1u << 8) ? 1 : m < (1u << 16) ? 2 : m < (1ull << 32) ? 4 : 8;
}

static uint64_t zigzag(int64_t x)
{
    return ((uint64_t)x << 1) ^ (uint64_t)(x >> 63);
}

static int64_t unzigzag(uint64_t u)
{
    return (int64_t)((u >> 1) ^ (0 - (u & 1)));
}

/* ======================================================================
 * Coordinate codec.
 *
 * Frame coordinates of a LAS file are (X * scale + offset) - origin: every
 * value is a multiple of the absolute coordinates' ulp g (2^-33 for
 * coordinates near 600 000) and lies within half a g of a multiple of the
 * scale s (0.01). So per chunk and axis:
 *   K = v / g             an exact integer (< 2^62)
 *   q = round(K / S)      S = s / g: the point's index on the LAS grid
 *   r = K - round(q * S)  the rounding residual: -1, 0 or 1 (a few units
 *                         when K exceeds the 53 bits of a double)
 * and we store q as differences from the previous point (small: points of
 * a tile arrive in scan order) and r, each in the fewest bytes that hold
 * the chunk's largest value, as byte planes. Decoding recomputes round(q*S)
 * with the same instructions, so the transform is lossless for any value:
 * a wrong guess of s only makes r larger. Without a decimal grid (PLY
 * floats) S is 1 and q = K (FIXED); values that are not finite, -0, or span
 * more than 61 bits between their highest and lowest set bit are stored as
 * raw doubles in 8 planes (RAW). The binary grid g is guessed from a sample
 * and every value is checked to rebuild exactly; only if one does not is it
 * computed from all values.
 * ====================================================================== */

enum { AXIS_RAW = 0, AXIS_FIXED = 1, AXIS_GRID = 2 };

typedef struct axis_head {
    uint8_t mode, wq, wr, pad;
    int32_t gexp;            /* g = 2^gexp */
    double S;                /* grid step in units of g (GRID) */
    int64_t q0;              /* q of the first point */
} axis_head;

typedef struct coord_head {
    uint32_t n;
    uint8_t wg;              /* width of the gid differences */
    uint8_t wh, pad[2];      /* 1: halo flags follow as bits; 0: all 0 */
    uint64_t gid0;
    axis_head axis[3];
} coord_head;

static size_t halo_bytes(size_t n)
{
    return (n + 7) / 8;
}

/* Halo flags as bits, 8 to a byte (bit k of byte j: point 8 j + k); any
 * nonzero flag is 1. Eight at a time: the flags' bytes become 0/1, and one
 * multiplication gathers the eight low bits into the top byte. */
static void halo_pack(uint8_t *bits, const uint8_t *halo, size_t n)
{
    const uint64_t low7 = 0x7f7f7f7f7f7f7f7full, high = 0x8080808080808080ull;
    size_t i = 0;
    for (; i + 8 <= n; i += 8) {
        uint64_t x;
        memcpy(&x, halo + i, 8);
        uint64_t nz = ((((x & low7) + low7) | x) & high) >> 7;
        bits[i / 8] = (uint8_t)((nz * 0x0102040810204080ull) >> 56);
    }
    if (i < n) {
        uint8_t last = 0;
        for (size_t k = i; k < n; k++)
            last |= (uint8_t)((halo[k] != 0) << (k - i));
        bits[i / 8] = last;
    }
}

/* Inverse of halo_pack: each byte spread to eight 0/1 bytes. */
static void halo_unpack(uint8_t *halo, const uint8_t *bits, size_t n)
{
    const uint64_t low7 = 0x7f7f7f7f7f7f7f7full, high = 0x8080808080808080ull;
    size_t i = 0;
    for (; i + 8 <= n; i += 8) {
        uint64_t x = (bits[i / 8] * 0x0101010101010101ull) & 0x8040201008040201ull;
        x = ((((x & low7) + low7) | x) & high) >> 7;
        memcpy(halo + i, &x, 8);
    }
    for (size_t k = i; k < n; k++)
        halo[k] = (bits[i / 8] >> (k - i)) & 1;
}

/* Largest raw coordinate block for n points (all axes RAW: 8 planes). */
static size_t coord_bound(size_t n)
{
    return sizeof(coord_head) + n * (8 + 3 * 8 + 1);
}

/* Round to nearest (ties to even) for |x| < 2^51 without a libm call;
 * beyond that merely repeatable, which is all the codec needs: encoder and
 * decoder compute the same expression. */
static inline double round_near(double x)
{
    const double magic = 6755399441055744.0; /* 1.5 * 2^52 */
    return (x + magic) - magic;
}

/* The grid prediction of K for grid index q, as a double (|K| < 2^62 and
 * S <= 2^60 keep it below 2^63 when encoding; the decoder checks). One
 * multiply, one rounding: -std=c11 keeps the compiler from contracting it
 * differently at the two call sites (no FMA). */
static inline double grid_predict(double q, double S)
{
    return round_near(q * S);
}

/* Smallest and largest set-bit exponents over every step-th of the n
 * values v[0], v[3], ... Returns -1 for a non-finite value; zeros are
 * skipped (lo > hi if all are zero). */
static int axis_bits(const double *v, size_t n, size_t step, int *lo_out, int *hi_out)
{
    int lo = INT_MAX, hi = INT_MIN;
    for (size_t i = 0; i < n; i += step) {
        uint64_t bits;
        memcpy(&bits, &v[3 * i], 8);
        int e = (int)((bits >> 52) & 0x7ff);
        uint64_t m = bits & ((1ull << 52) - 1);
        if (e == 0x7ff)
            return -1;
        if (e == 0 && m == 0)
            continue;
        int e0 = e ? e - 1075 : -1074;
        if (e)
            m |= 1ull << 52;
        int l = e0 + __builtin_ctzll(m), h = e0 + 63 - __builtin_clzll(m);
        lo = l < lo ? l : lo;
        hi = h > hi ? h : hi;
    }
    *lo_out = lo;
    *hi_out = hi;
    return 0;
}

/* v / g if that is below 2^62 in magnitude (for an exact conversion to
 * int64), else 0 with *ok cleared; branch-free. */
static inline double scaled(double v, double scale, int *ok)
{
    double K = v * scale;
    int in = fabs(K) < 0x1p62; /* false for NaN */
    *ok &= in;
    return in ? K : 0;
}

/* The coarsest decimal grid s = 10^j (as S = s / g) that a sample of the
 * values lies on, up to a residual far smaller than S (on a wrong grid the
 * residuals spread over +-S/2); 1 (FIXED) if none does. */
static double axis_grid_step(const double *v, size_t n, double scale)
{
    enum { SAMPLES = 16 };
    double s = 1e6;
    for (int j = 6; j >= -9; j--, s /= 10) {
        double S = s * scale; /* s / g */
        if (S < 2 || S > 0x1p60)
            continue;
        double inv = 1 / S;
        int64_t tol = S < 16 ? 1 : S < 512 ? (int64_t)(S / 8) : 64;
        int ok = 1;
        for (size_t k = 0; k < SAMPLES && ok; k++) {
            double K = scaled(v[3 * (k * n / SAMPLES)], scale, &ok);
            int64_t r = (int64_t)K - (int64_t)grid_predict(round_near(K * inv), S);
            ok &= r >= -tol && r <= tol;
        }
        if (ok)
            return S;
    }
    return 1;
}

/* 1 if K g is v bit for bit, as decode_axis computes it: this catches
 * values off the grid, -0, and underflow when the grid was guessed. */
static inline int rebuilds(int64_t K, double g, double v)
{
    double back = (double)K * g;
    uint64_t a, b;
    memcpy(&a, &back, 8);
    memcpy(&b, &v, 8);
    return a == b;
}

/* Encodes the n values v[0], v[3], ... on the binary grid g = 2^gexp (see
 * above) into h and out. Returns the bytes written, or 0 if a value is
 * not a multiple of g below 2^62 g (the caller then tries another way). */
static size_t encode_axis_on(const double *v, size_t n, int gexp, axis_head *h, uint8_t *out,
                             uint64_t *dq, uint64_t *rr)
{
    double scale = ldexp(1, -gexp), g = ldexp(1, gexp); /* exact */
    double S = axis_grid_step(v, n, scale);
    uint64_t dor = 0, ror = 0;
    int ok = 1;
    memset(h, 0, sizeof *h);
    h->gexp = gexp;
    if (S == 1) {
        h->mode = AXIS_FIXED;
        int64_t prev = h->q0 = (int64_t)scaled(v[0], scale, &ok);
        for (size_t i = 0; i < n; i++) {
            double Kd = scaled(v[3 * i], scale, &ok);
            int64_t K = (int64_t)Kd;
            ok &= rebuilds(K, g, v[3 * i]);
            dor |= dq[i] = zigzag(K - prev);
            prev = K;
        }
    } else {
        h->mode = AXIS_GRID;
        h->S = S;
        double inv = 1 / S;
        int64_t prev = h->q0 = (int64_t)round_near(scaled(v[0], scale, &ok) * inv);
        for (size_t i = 0; i < n; i++) {
            double Kd = scaled(v[3 * i], scale, &ok), qd = round_near(Kd * inv);
            int64_t K = (int64_t)Kd, q = (int64_t)qd;
            ok &= rebuilds(K, g, v[3 * i]);
            dor |= dq[i] = zigzag(q - prev);
            ror |= rr[i] = zigzag(K - (int64_t)grid_predict(qd, S));
            prev = q;
        }
    }
    if (!ok)
        return 0;
    h->wq = width_of(dor);
    h->wr = width_of(ror);
    planes_put(out, dq, n, h->wq);
    planes_put(out + h->wq * n, rr, n, h->wr);
    return (size_t)(h->wq + h->wr) * n + 1; /* + 1: never 0; the caller subtracts it */
}

/* Encodes axis a of xyz[3n] into out; dq, rr: scratch of n values each.
 * The binary grid is first guessed from a sample of the values and only
 * computed from all of them if a value is off it. Returns the bytes
 * written. */
static size_t encode_axis(const double *xyz, size_t n, int a, axis_head *h, uint8_t *out,
                          uint64_t *dq, uint64_t *rr)
{
    const double *v = xyz + a;
    for (size_t step = n > 256 ? n / 64 : 1;; step = 1) {
        int lo, hi;
        if (axis_bits(v, n, step, &lo, &hi))
            break; /* not finite */
        if (lo > hi)
            lo = hi = 0; /* all zero */
        if (hi - lo <= 61 && lo >= -1000 && lo <= 1000) {
            size_t bytes = encode_axis_on(v, n, lo, h, out, dq, rr);
            if (bytes)
                return bytes - 1;
        }
        if (step == 1)
            break;
    }
    memset(h, 0, sizeof *h);
    h->mode = AXIS_RAW;
    for (size_t i = 0; i < n; i++)
        memcpy(&dq[i], &v[3 * i], 8);
    planes_put(out, dq, n, 8);
    return 8 * n;
}

/* 1 if the head of an axis block is one encode_axis can write. */
static int axis_valid(const axis_head *h)
{
    int wq_ok = h->wq == 0 || h->wq == 1 || h->wq == 2 || h->wq == 4 || h->wq == 8;
    int wr_ok = h->wr == 0 || h->wr == 1 || h->wr == 2 || h->wr == 4 || h->wr == 8;
    if (h->mode == AXIS_RAW)
        return h->wq == 0 && h->wr == 0;
    if (!wq_ok || !wr_ok || h->gexp < -1000 || h->gexp > 1000)
        return 0;
    if (h->mode == AXIS_FIXED)
        return h->wr == 0;
    return h->mode == AXIS_GRID && h->S >= 2 && h->S <= 0x1p60;
}

/* Bytes the body of a valid axis block takes for n points. */
static size_t axis_bytes(const axis_head *h, size_t n)
{
    return h->mode == AXIS_RAW ? 8 * n : (size_t)(h->wq + h->wr) * n;
}

/* Inverse of encode_axis into axis a of xyz[3n]. Returns 0, or -1 if a
 * decoded value is out of range (corrupt data). */
static int decode_axis(const axis_head *h, const uint8_t *in, size_t n, int a, double *xyz,
                       uint64_t *dq, uint64_t *rr)
{
    double *v = xyz + a;
    if (h->mode == AXIS_RAW) {
        planes_get(dq, in, n, 8);
        for (size_t i = 0; i < n; i++)
            memcpy(&v[3 * i], &dq[i], 8);
        return 0;
    }
    double g = ldexp(1, h->gexp);
    planes_get(dq, in, n, h->wq);
    uint64_t q = (uint64_t)h->q0; /* unsigned: corrupt data wraps, never overflows */
    if (h->mode == AXIS_FIXED) {
        for (size_t i = 0; i < n; i++) {
            q += (uint64_t)unzigzag(dq[i]);
            v[3 * i] = (double)(int64_t)q * g;
        }
        return 0;
    }
    planes_get(rr, in + h->wq * n, n, h->wr);
    const double S = h->S; /* locals: stores to v cannot change them */
    int bad = 0;
    for (size_t i = 0; i < n; i++) {
        q += (uint64_t)unzigzag(dq[i]);
        double p = grid_predict((double)(int64_t)q, S);
        int in = p >= -0x1p63 && p < 0x1p63; /* else the conversion is undefined */
        bad |= !in;
        uint64_t K = (uint64_t)(int64_t)(in ? p : 0) + (uint64_t)unzigzag(rr[i]);
        v[3 * i] = (double)(int64_t)K * g;
    }
    return bad ? -1 : 0;
}

/* Encodes n points (gid, xyz, halo) into out (coord_bound(n) bytes); dq
 * and rr: scratch of n values each. Returns the bytes written. */
static size_t encode_coords(const uint64_t *gid, const double *xyz, const uint8_t *halo,
                            size_t n, uint8_t *out, uint64_t *dq, uint64_t *rr)
{
    coord_head h;
    memset(&h, 0, sizeof h);
    h.n = (uint32_t)n;
    h.gid0 = n ? gid[0] : 0;
    uint64_t dor = 0;
    for (size_t i = 0; i < n; i++)
        dor |= dq[i] = gid[i] - (i ? gid[i - 1] : gid[0]);
    h.wg = width_of(dor);
    uint8_t *p = out + sizeof h;
    planes_put(p, dq, n, h.wg);
    p += h.wg * n;
    for (int a = 0; a < 3; a++)
        p += n ? encode_axis(xyz, n, a, &h.axis[a], p, dq, rr) : 0;
    uint8_t hor = 0;
    for (size_t i = 0; i < n; i++)
        hor |= halo[i];
    h.wh = hor != 0;
    if (h.wh) {
        halo_pack(p, halo, n);
        p += halo_bytes(n);
    }
    memcpy(out, &h, sizeof h);
    return (size_t)(p - out);
}

/* Inverse of encode_coords: size bytes at in must hold exactly n points.
 * Returns 0, or -1 if the block is inconsistent. */
static int decode_coords(const uint8_t *in, size_t size, size_t n, uint64_t *gid, double *xyz,
                         uint8_t *halo, uint64_t *dq, uint64_t *rr)
{
    coord_head h;
    if (size < sizeof h)
        return -1;
    memcpy(&h, in, sizeof h);
    if (h.n != n || (h.wg != 0 && h.wg != 1 && h.wg != 2 && h.wg != 4 && h.wg != 8) || h.wh > 1)
        return -1;
    size_t need = sizeof h + h.wg * n + (h.wh ? halo_bytes(n) : 0);
    for (int a = 0; a < 3 && n; a++) {
        if (!axis_valid(&h.axis[a]))
            return -1;
        need += axis_bytes(&h.axis[a], n);
    }
    if (need != size)
        return -1;
    const uint8_t *p = in + sizeof h;
    planes_get(dq, p, n, h.wg);
    p += h.wg * n;
    uint64_t g = h.gid0;
    for (size_t i = 0; i < n; i++)
        gid[i] = g += dq[i];
    for (int a = 0; a < 3 && n; a++) {
        if (decode_axis(&h.axis[a], p, n, a, xyz, dq, rr))
            return -1;
        p += axis_bytes(&h.axis[a], n);
    }
    if (h.wh)
        halo_unpack(halo, p, n);
    else
        memset(halo, 0, n);
    return 0;
}

/* ======================================================================
 * The spill: tiles, their buffers, the compression threads, the files.
 * ====================================================================== */

/* On disk a chunk is this header, the coordinate frame (coord_z bytes,
 * zstd with checksum) and the record frame (rec_z bytes). The header
 * repeats the in-memory index so that a damaged file is recognised. */
typedef struct chunk_head {
    uint32_t magic, tile, seq, n;
    uint32_t coord_raw, coord_z, rec_z, pad;
} chunk_head;

typedef struct chunk_ref {
    uint64_t off;
    uint32_t n, coord_raw, coord_z, rec_z;
} chunk_ref;

/* Write buffer of one tile: columns for cap points in one allocation. */
typedef struct wbuf {
    uint64_t *gid;
    double *xyz;
    uint8_t *rec;
    uint8_t *halo;
    struct wbuf *next; /* free list */
} wbuf;

typedef struct tile {
    wbuf *buf;             /* NULL until the first append */
    size_t fill;           /* points in buf */
    uint64_t count;        /* points appended */
    chunk_ref *chunks;     /* [nchunks], in append order */
    uint32_t nchunks, chunks_cap;
    uint64_t file_size;
    int fd_slot;           /* index into open_files, or -1 */
} tile;

/* Scratch of one compressing thread. */
typedef struct codec {
    ZSTD_CCtx *cctx;
    uint8_t *raw;          /* coordinate block, then transposed records */
    uint8_t *out;          /* chunk as written */
    uint64_t *dq, *rr;
} codec;

typedef struct job {
    int tile;
    uint32_t seq;
    size_t n;
    wbuf *buf;
} job;

struct wpd_spill {
    char dir[1024];
    int ntiles;
    uint32_t rs;
    wpd_spill_options opt;
    size_t cap;            /* points per chunk */
    tile *tiles;
    int finished;

    pthread_mutex_t mu;    /* everything below */
    pthread_cond_t cv_job, cv_free, cv_idle;
    pthread_t *workers;
    int nworkers, stop;
    job *queue;            /* ring of qcap jobs */
    size_t qhead, qlen, qcap;
    wbuf *free_list;
    int spares, max_spares, in_flight;
    codec sync_codec;      /* compression on the caller's thread */
    struct { int tile, fd, pins; uint64_t used; } open_files[MAX_OPEN_FILES];
    uint64_t clock;
    int failed;            /* read without the lock through __atomic */
    wpd_error error;       /* the first failure */
    wpd_spill_stats stats;
};

static size_t rec_bytes(const wpd_spill *s, size_t n)
{
    return n * s->rs;
}

static void tile_path(const wpd_spill *s, int t, char *out, size_t len)
{
    snprintf(out, len, "%s/tile-%06d", s->dir, t);
}

/* Records the first failure (caller holds the lock). */
static void set_failed_locked(wpd_spill *s, const wpd_error *e)
{
    if (!s->failed) {
        s->error = *e;
        __atomic_store_n(&s->failed, 1, __ATOMIC_RELEASE);
    }
}

static int report_failure(const wpd_spill *s, wpd_error *err)
{
    if (err)
        *err = s->error;
    return -1;
}

static wbuf *wbuf_new(const wpd_spill *s)
{
    size_t cap = s->cap;
    wbuf *b = malloc(sizeof *b + cap * (8 + 24 + 1) + rec_bytes(s, cap));
    if (!b)
        return NULL;
    b->gid = (uint64_t *)(b + 1);
    b->xyz = (double *)(b->gid + cap);
    b->rec = (uint8_t *)(b->xyz + 3 * cap);
    b->halo = b->rec + rec_bytes(s, cap);
    b->next = NULL;
    return b;
}

static size_t chunk_bound(const wpd_spill *s)
{
    return sizeof(chunk_head) + ZSTD_compressBound(coord_bound(s->cap)) +
           ZSTD_compressBound(rec_bytes(s, s->cap));
}

static void codec_free(codec *c)
{
    ZSTD_freeCCtx(c->cctx);
    free(c->raw);
    free(c->out);
    free(c->dq);
    memset(c, 0, sizeof *c);
}

static int codec_init(const wpd_spill *s, codec *c)
{
    size_t raw = coord_bound(s->cap);
    if (rec_bytes(s, s->cap) > raw)
        raw = rec_bytes(s, s->cap);
    c->cctx = ZSTD_createCCtx();
    c->raw = malloc(raw);
    c->out = malloc(chunk_bound(s));
    c->dq = malloc(2 * s->cap * sizeof *c->dq);
    c->rr = c->dq ? c->dq + s->cap : NULL;
    if (!c->cctx || !c->raw || !c->out || !c->dq ||
        ZSTD_isError(ZSTD_CCtx_setParameter(c->cctx, ZSTD_c_compressionLevel, s->opt.level)) ||
        ZSTD_isError(ZSTD_CCtx_setParameter(c->cctx, ZSTD_c_checksumFlag, 1))) {
        codec_free(c);
        return -1;
    }
    return 0;
}

/* Writes len bytes at off; a short write without errno set is disk full. */
static int write_full(int fd, const uint8_t *p, size_t len, uint64_t off)
{
    while (len) {
        ssize_t w = pwrite(fd, p, len, (off_t)off);
        if (w < 0 && errno == EINTR)
            continue;
        if (w <= 0) {
            if (w == 0)
                errno = ENOSPC;
            return -1;
        }
        p += w, len -= (size_t)w, off += (uint64_t)w;
    }
    return 0;
}

/* An open descriptor for writing tile t, pinned (not closed by another
 * thread until unpinned): cached, or opened in the least recently used
 * unpinned slot (at most MAX_OPEN_FILES stay open). *slot is -1 for a
 * descriptor outside the cache (every slot pinned), which the caller
 * closes. Lock held. Returns -1 if the file cannot be opened. */
static int tile_fd_locked(wpd_spill *s, int t, int *slot_out)
{
    tile *T = &s->tiles[t];
    if (T->fd_slot >= 0) {
        s->open_files[T->fd_slot].used = ++s->clock;
        s->open_files[T->fd_slot].pins++;
        *slot_out = T->fd_slot;
        return s->open_files[T->fd_slot].fd;
    }
    int slot = -1;
    for (int k = 0; k < MAX_OPEN_FILES; k++) {
        if (s->open_files[k].pins)
            continue;
        if (s->open_files[k].fd < 0) {
            slot = k;
            break;
        }
        if (slot < 0 || s->open_files[k].used < s->open_files[slot].used)
            slot = k;
    }
    if (slot >= 0 && s->open_files[slot].fd >= 0) {
        close(s->open_files[slot].fd);
        s->tiles[s->open_files[slot].tile].fd_slot = -1;
        s->open_files[slot].fd = -1;
    }
    char path[1100];
    tile_path(s, t, path, sizeof path);
    int fd = open(path, O_WRONLY | O_CREAT | O_CLOEXEC, 0600);
    *slot_out = fd >= 0 ? slot : -1;
    if (fd < 0 || slot < 0)
        return fd;
    s->open_files[slot].fd = fd;
    s->open_files[slot].tile = t;
    s->open_files[slot].used = ++s->clock;
    s->open_files[slot].pins = 1;
    T->fd_slot = slot;
    return fd;
}

/* Appends a compressed chunk to its tile's file and enters it in the
 * index at its sequence number. The file range is reserved under the lock;
 * the write itself runs without it (page-cache writes can take long). */
static void write_chunk(wpd_spill *s, const job *j, const uint8_t *data, const chunk_ref *ref)
{
    tile *T = &s->tiles[j->tile];
    size_t len = sizeof(chunk_head) + ref->coord_z + ref->rec_z;
    pthread_mutex_lock(&s->mu);
    if (s->failed) {
        pthread_mutex_unlock(&s->mu);
        return;
    }
    int slot, fd = tile_fd_locked(s, j->tile, &slot);
    uint64_t off = T->file_size;
    T->file_size += len;
    pthread_mutex_unlock(&s->mu);

    double t0 = now_seconds();
    int failed = fd < 0 || write_full(fd, data, len, off);
    int saved = errno;
    double t1 = now_seconds();

    pthread_mutex_lock(&s->mu);
    if (slot >= 0)
        s->open_files[slot].pins--;
    else if (fd >= 0)
        close(fd);
    if (failed) {
        wpd_error e;
        char path[1100];
        tile_path(s, j->tile, path, sizeof path);
        errno = saved;
        wpd_fail_errno(&e, "%s: cannot %s spill file", path, fd < 0 ? "create" : "write");
        set_failed_locked(s, &e);
    } else {
        T->chunks[j->seq] = *ref;
        T->chunks[j->seq].off = off;
        s->stats.write_seconds += t1 - t0;
        s->stats.disk_bytes += len;
        s->stats.raw_bytes += j->n * (33 + (uint64_t)s->rs);
    }
    pthread_mutex_unlock(&s->mu);
}

/* Compresses the job's points with codec c and writes them. */
static void run_job(wpd_spill *s, codec *c, const job *j)
{
    if (__atomic_load_n(&s->failed, __ATOMIC_ACQUIRE))
        return;
    double t0 = now_seconds();
    const wbuf *b = j->buf;
    size_t craw = encode_coords(b->gid, b->xyz, b->halo, j->n, c->raw, c->dq, c->rr);
    uint8_t *p = c->out + sizeof(chunk_head);
    size_t cap = chunk_bound(s) - sizeof(chunk_head);
    size_t cz = ZSTD_compress2(c->cctx, p, cap, c->raw, craw);
    size_t rz = 0;
    if (!ZSTD_isError(cz) && s->rs) {
        transpose(c->raw, b->rec, j->n, s->rs);
        rz = ZSTD_compress2(c->cctx, p + cz, cap - cz, c->raw, rec_bytes(s, j->n));
    }
    double t1 = now_seconds();
    chunk_head h = {CHUNK_MAGIC, (uint32_t)j->tile, j->seq, (uint32_t)j->n,
                    (uint32_t)craw, (uint32_t)cz, (uint32_t)rz, 0};
    memcpy(c->out, &h, sizeof h);
    chunk_ref ref = {0, h.n, h.coord_raw, h.coord_z, h.rec_z};
    pthread_mutex_lock(&s->mu);
    s->stats.compress_seconds += t1 - t0;
    if (ZSTD_isError(cz) || ZSTD_isError(rz)) {
        wpd_error e;
        size_t why = ZSTD_isError(cz) ? cz : rz;
        /* zstd allocates its workspace on the first compression. */
        wpd_fail(&e, ZSTD_getErrorCode(why) == ZSTD_error_memory_allocation ? WPD_E_MEMORY
                                                                           : WPD_E_IO,
                 "%s: zstd compression failed: %s", s->dir, ZSTD_getErrorName(why));
        set_failed_locked(s, &e);
    }
    pthread_mutex_unlock(&s->mu);
    if (!ZSTD_isError(cz) && !ZSTD_isError(rz))
        write_chunk(s, j, c->out, &ref);
}

static void *worker_main(void *arg)
{
    wpd_spill *s = arg;
    codec c;
    int ok = codec_init(s, &c) == 0;
    pthread_mutex_lock(&s->mu);
    if (!ok) {
        wpd_error e;
        wpd_fail(&e, WPD_E_MEMORY, "%s: out of memory for a spill compression thread", s->dir);
        set_failed_locked(s, &e);
    }
    for (;;) {
        while (!s->qlen && !s->stop)
            pthread_cond_wait(&s->cv_job, &s->mu);
        if (!s->qlen)
            break;
        job j = s->queue[s->qhead];
        s->qhead = (s->qhead + 1) % s->qcap;
        s->qlen--;
        pthread_mutex_unlock(&s->mu);
        if (ok)
            run_job(s, &c, &j);
        pthread_mutex_lock(&s->mu);
        j.buf->next = s->free_list;
        s->free_list = j.buf;
        s->in_flight--;
        pthread_cond_signal(&s->cv_free);
        if (!s->in_flight)
            pthread_cond_broadcast(&s->cv_idle);
    }
    pthread_mutex_unlock(&s->mu);
    if (ok)
        codec_free(&c);
    return NULL;
}

/* Reserves the next chunk number of tile t. Lock held. */
static int reserve_chunk_locked(wpd_spill *s, int t, uint32_t *seq)
{
    tile *T = &s->tiles[t];
    if (T->nchunks == T->chunks_cap) {
        uint32_t cap = T->chunks_cap ? 2 * T->chunks_cap : 16;
        chunk_ref *c = realloc(T->chunks, cap * sizeof *c);
        if (!c)
            return -1;
        T->chunks = c;
        T->chunks_cap = cap;
    }
    *seq = T->nchunks++;
    return 0;
}

/* Hands tile t's buffered points to compression. With compression
 * threads the tile gets a free buffer back (refill: 1) or none (at the
 * end); on the caller's thread the buffer is kept. Returns 0 or -1. */
static int submit(wpd_spill *s, int t, int refill, wpd_error *err)
{
    tile *T = &s->tiles[t];
    job j = {t, 0, T->fill, T->buf};
    pthread_mutex_lock(&s->mu);
    if (reserve_chunk_locked(s, t, &j.seq)) {
        pthread_mutex_unlock(&s->mu);
        return wpd_fail(err, WPD_E_MEMORY, "%s: out of memory for the spill index", s->dir);
    }
    if (!s->nworkers) {
        pthread_mutex_unlock(&s->mu);
        run_job(s, &s->sync_codec, &j);
        T->fill = 0;
        return s->failed ? report_failure(s, err) : 0;
    }
    s->queue[(s->qhead + s->qlen++) % s->qcap] = j;
    s->in_flight++;
    pthread_cond_signal(&s->cv_job);
    T->buf = NULL;
    T->fill = 0;
    while (refill && !T->buf) {
        if (s->free_list) {
            T->buf = s->free_list;
            s->free_list = T->buf->next;
        } else if (s->spares < s->max_spares) {
            s->spares++;
            pthread_mutex_unlock(&s->mu);
            T->buf = wbuf_new(s);
            pthread_mutex_lock(&s->mu);
            if (!T->buf) {
                pthread_mutex_unlock(&s->mu);
                return wpd_fail(err, WPD_E_MEMORY, "%s: out of memory for spill buffers", s->dir);
            }
        } else {
            pthread_cond_wait(&s->cv_free, &s->mu);
        }
    }
    int failed = s->failed;
    pthread_mutex_unlock(&s->mu);
    return failed ? report_failure(s, err) : 0;
}

/* Stops the compression threads after the queued jobs. */
static void stop_workers(wpd_spill *s)
{
    pthread_mutex_lock(&s->mu);
    s->stop = 1;
    pthread_cond_broadcast(&s->cv_job);
    pthread_mutex_unlock(&s->mu);
    for (int k = 0; k < s->nworkers; k++)
        pthread_join(s->workers[k], NULL);
    s->nworkers = 0;
}

/* Frees every write buffer and scratch, closes the files. */
static void release_writing(wpd_spill *s)
{
    for (int t = 0; t < s->ntiles; t++) {
        free(s->tiles[t].buf);
        s->tiles[t].buf = NULL;
    }
    while (s->free_list) {
        wbuf *b = s->free_list;
        s->free_list = b->next;
        free(b);
    }
    for (int k = 0; k < MAX_OPEN_FILES; k++)
        if (s->open_files[k].fd >= 0) {
            close(s->open_files[k].fd);
            s->tiles[s->open_files[k].tile].fd_slot = -1;
            s->open_files[k].fd = -1;
        }
    codec_free(&s->sync_codec);
    free(s->queue);
    s->queue = NULL;
}

void wpd_spill_default_options(wpd_spill_options *o)
{
    o->level = -3;
    o->buffer_bytes = 256 << 10;
    o->threads = 2;
    o->spares_per_thread = WPD_SPILL_SPARES_PER_THREAD;
}

wpd_spill *wpd_spill_create(const char *base_dir, int ntiles, uint32_t record_size,
                            const wpd_spill_options *opt, wpd_error *err)
{
    if (ntiles < 1 || ntiles > (1 << 22) || record_size > (1u << 20)) {
        wpd_fail(err, WPD_E_USAGE, "%s: cannot spill %d tiles of %u-byte records", base_dir,
                 ntiles, record_size);
        return NULL;
    }
    wpd_spill *s = calloc(1, sizeof *s);
    if (!s || !(s->tiles = calloc((size_t)ntiles, sizeof *s->tiles))) {
        free(s);
        wpd_fail(err, WPD_E_MEMORY, "%s: out of memory for %d spill tiles", base_dir, ntiles);
        return NULL;
    }
    if (opt)
        s->opt = *opt;
    else
        wpd_spill_default_options(&s->opt);
    if (s->opt.level < ZSTD_minCLevel())
        s->opt.level = ZSTD_minCLevel();
    if (s->opt.level > ZSTD_maxCLevel())
        s->opt.level = ZSTD_maxCLevel();
    s->ntiles = ntiles;
    s->rs = record_size;
    /* Chunk sizes are stored in 32 bits: keep a chunk well below 2^31. */
    size_t per_point = 33 + record_size, bytes = s->opt.buffer_bytes;
    bytes = bytes < (4u << 10) ? (4u << 10) : bytes > (256u << 20) ? (256u << 20) : bytes;
    s->cap = bytes / per_point ? bytes / per_point : 1;
    for (int t = 0; t < ntiles; t++)
        s->tiles[t].fd_slot = -1;
    for (int k = 0; k < MAX_OPEN_FILES; k++)
        s->open_files[k].fd = -1;
    pthread_mutex_init(&s->mu, NULL);
    pthread_cond_init(&s->cv_job, NULL);
    pthread_cond_init(&s->cv_free, NULL);
    pthread_cond_init(&s->cv_idle, NULL);
    if (wpd_tmpdir_create(base_dir, "wpd-spill", s->dir, sizeof s->dir, err)) {
        s->dir[0] = '\0';
        wpd_spill_destroy(s);
        return NULL;
    }
    int want = s->opt.threads < 0 ? 0 : s->opt.threads > 64 ? 64 : s->opt.threads;
    if (want) {
        int spares = s->opt.spares_per_thread < 1 ? 1 : s->opt.spares_per_thread;
        s->qcap = (size_t)ntiles + (size_t)want * (size_t)spares + 1;
        s->queue = malloc(s->qcap * sizeof *s->queue);
        s->workers = malloc((size_t)want * sizeof *s->workers);
        s->max_spares = want * spares;
        for (int k = 0; s->queue && s->workers && k < want; k++)
            if (pthread_create(&s->workers[k], NULL, worker_main, s) == 0)
                s->nworkers++;
    }
    if (!s->nworkers && codec_init(s, &s->sync_codec)) {
        wpd_fail(err, WPD_E_MEMORY, "%s: out of memory for spill compression", s->dir);
        wpd_spill_destroy(s);
        return NULL;
    }
    return s;
}

int wpd_spill_append(wpd_spill *s, int t, const uint64_t *gid, const double *xyz,
                     const uint8_t *halo, const uint8_t *records, size_t n, wpd_error *err)
{
    if (t < 0 || t >= s->ntiles || s->finished)
        return wpd_fail(err, WPD_E_USAGE, "%s: append to tile %d of %d%s", s->dir, t,
                        s->ntiles, s->finished ? " after the spill was finished" : "");
    if (__atomic_load_n(&s->failed, __ATOMIC_ACQUIRE))
        return report_failure(s, err);
    tile *T = &s->tiles[t];
    while (n) {
        if (!T->buf && !(T->buf = wbuf_new(s)))
            return wpd_fail(err, WPD_E_MEMORY, "%s: out of memory for spill buffers", s->dir);
        wbuf *b = T->buf;
        size_t k = s->cap - T->fill < n ? s->cap - T->fill : n;
        memcpy(b->gid + T->fill, gid, k * 8);
        memcpy(b->xyz + 3 * T->fill, xyz, k * 24);
        if (halo)
            memcpy(b->halo + T->fill, halo, k);
        else
            memset(b->halo + T->fill, 0, k);
        if (s->rs)
            memcpy(b->rec + rec_bytes(s, T->fill), records, rec_bytes(s, k));
        T->fill += k;
        T->count += k;
        gid += k, xyz += 3 * k, n -= k;
        halo = halo ? halo + k : NULL;
        records = s->rs ? records + rec_bytes(s, k) : records;
        if (T->fill == s->cap && submit(s, t, 1, err))
            return -1;
    }
    return 0;
}

int wpd_spill_finish(wpd_spill *s, wpd_error *err)
{
    if (s->finished)
        return s->failed ? report_failure(s, err) : 0;
    for (int t = 0; t < s->ntiles && !__atomic_load_n(&s->failed, __ATOMIC_ACQUIRE); t++) {
        wpd_error e;
        if (s->tiles[t].fill && submit(s, t, 0, &e)) {
            /* A failure of submit itself (no memory for the index) must
             * fail the spill too, or the return below would say success. */
            pthread_mutex_lock(&s->mu);
            set_failed_locked(s, &e);
            pthread_mutex_unlock(&s->mu);
            break;
        }
    }
    pthread_mutex_lock(&s->mu);
    while (s->in_flight)
        pthread_cond_wait(&s->cv_idle, &s->mu);
    pthread_mutex_unlock(&s->mu);
    stop_workers(s);
    release_writing(s);
    uint64_t points = 0;
    for (int t = 0; t < s->ntiles; t++)
        points += s->tiles[t].count;
    s->stats.points = points;
    s->finished = 1;
    return s->failed ? report_failure(s, err) : 0;
}

uint64_t wpd_spill_count(const wpd_spill *s, int t)
{
    return t >= 0 && t < s->ntiles ? s->tiles[t].count : 0;
}

void wpd_spill_get_stats(const wpd_spill *s, wpd_spill_stats *st)
{
    pthread_mutex_lock((pthread_mutex_t *)&s->mu);
    *st = s->stats;
    pthread_mutex_unlock((pthread_mutex_t *)&s->mu);
    uint64_t points = 0;
    for (int t = 0; t < s->ntiles; t++)
        points += s->tiles[t].count;
    st->points = points;
}

void wpd_spill_destroy(wpd_spill *s)
{
    if (!s)
        return;
    stop_workers(s);
    release_writing(s);
    if (s->dir[0])
        wpd_tmpdir_remove(s->dir);
    for (int t = 0; t < s->ntiles; t++)
        free(s->tiles[t].chunks);
    free(s->tiles);
    free(s->workers);
    pthread_mutex_destroy(&s->mu);
    pthread_cond_destroy(&s->cv_job);
    pthread_cond_destroy(&s->cv_free);
    pthread_cond_destroy(&s->cv_idle);
    free(s);
}

/* ======================================================================
 * Reading a tile back.
 * ====================================================================== */

/* Reads len bytes at off; fewer (end of file) is -1 with errno 0. */
static int read_full(int fd, uint8_t *p, size_t len, uint64_t off)
{
    while (len) {
        ssize_t r = pread(fd, p, len, (off_t)off);
        if (r < 0 && errno == EINTR)
            continue;
        if (r <= 0) {
            if (r == 0)
                errno = 0;
            return -1;
        }
        p += r, len -= (size_t)r, off += (uint64_t)r;
    }
    return 0;
}

/* An output array (never NULL for 0 bytes, so that callers can tell it
 * from a failure). */
static void *alloc_out(size_t bytes)
{
    void *p = malloc(bytes ? bytes : 1);
    if (p && bytes >= (8u << 20)) {
        uintptr_t a = ((uintptr_t)p + 4095) & ~(uintptr_t)4095;
        madvise((void *)a, bytes - (a - (uintptr_t)p), MADV_HUGEPAGE);
    }
    return p;
}

void wpd_tile_data_free(wpd_tile_data *d)
{
    if (!d)
        return;
    free(d->gid);
    free(d->xyz);
    free(d->halo);
    free(d->records);
    memset(d, 0, sizeof *d);
}

typedef struct read_scratch {
    uint8_t *file, *coords, *recs;
    uint64_t *dq;
    ZSTD_DCtx *dctx;
} read_scratch;

static void read_scratch_free(read_scratch *r)
{
    free(r->file);
    free(r->coords);
    free(r->recs);
    free(r->dq);
    ZSTD_freeDCtx(r->dctx);
}

/* Reads and decodes chunk k of tile t into out at point pos. */
static int read_chunk(const wpd_spill *s, int t, uint32_t k, int fd, const char *path,
                      int with_records, read_scratch *r, wpd_tile_data *out, uint64_t pos,
                      wpd_error *err)
{
    const chunk_ref *c = &s->tiles[t].chunks[k];
    size_t len = sizeof(chunk_head) + c->coord_z + (with_records ? c->rec_z : 0);
    if (read_full(fd, r->file, len, c->off)) {
        if (errno)
            return wpd_fail_errno(err, "%s: cannot read spill chunk %u", path, k);
        return wpd_fail(err, WPD_E_IO, "%s: spill file truncated: chunk %u at byte %llu "
                        "needs %zu bytes", path, k, (unsigned long long)c->off, len);
    }
    chunk_head h;
    memcpy(&h, r->file, sizeof h);
    if (h.magic != CHUNK_MAGIC || h.tile != (uint32_t)t || h.seq != k || h.n != c->n ||
        h.coord_raw != c->coord_raw || h.coord_z != c->coord_z || h.rec_z != c->rec_z)
        return wpd_fail(err, WPD_E_IO, "%s: corrupt spill chunk %u at byte %llu: header does "
                        "not match what was written", path, k, (unsigned long long)c->off);
    const uint8_t *z = r->file + sizeof h;
    size_t got = ZSTD_decompressDCtx(r->dctx, r->coords, c->coord_raw, z, c->coord_z);
    if (ZSTD_isError(got) || got != c->coord_raw ||
        decode_coords(r->coords, c->coord_raw, c->n, out->gid + pos, out->xyz + 3 * pos,
                      out->halo + pos, r->dq, r->dq + s->cap))
        return wpd_fail(err, WPD_E_IO, "%s: corrupt spill chunk %u at byte %llu: coordinates "
                        "do not decode (%s)", path, k, (unsigned long long)c->off,
                        ZSTD_isError(got) ? ZSTD_getErrorName(got) : "bad block");
    if (!with_records || !s->rs)
        return 0;
    size_t want = rec_bytes(s, c->n);
    got = ZSTD_decompressDCtx(r->dctx, r->recs, want, z + c->coord_z, c->rec_z);
    if (ZSTD_isError(got) || got != want)
        return wpd_fail(err, WPD_E_IO, "%s: corrupt spill chunk %u at byte %llu: records do "
                        "not decode (%s)", path, k, (unsigned long long)c->off,
                        ZSTD_isError(got) ? ZSTD_getErrorName(got) : "wrong size");
    untranspose(out->records + rec_bytes(s, pos), r->recs, c->n, s->rs);
    return 0;
}

int wpd_spill_read(const wpd_spill *s, int t, int with_records, wpd_tile_data *out,
                   wpd_error *err)
{
    memset(out, 0, sizeof *out);
    if (t < 0 || t >= s->ntiles || !s->finished)
        return wpd_fail(err, WPD_E_USAGE, "%s: read of tile %d of %d%s", s->dir, t, s->ntiles,
                        s->finished ? "" : " before the spill was finished");
    if (s->failed)
        return report_failure(s, err);
    const tile *T = &s->tiles[t];
    size_t n = T->count, max_len = 0, max_raw = 0, max_n = 0;
    uint64_t sum = 0;
    for (uint32_t k = 0; k < T->nchunks; k++) {
        const chunk_ref *c = &T->chunks[k];
        size_t len = sizeof(chunk_head) + c->coord_z + (with_records ? c->rec_z : 0);
        max_len = len > max_len ? len : max_len;
        max_raw = c->coord_raw > max_raw ? c->coord_raw : max_raw;
        max_n = c->n > max_n ? c->n : max_n;
        sum += c->n;
    }
    char path[1100];
    tile_path(s, t, path, sizeof path);
    if (sum != n)
        return wpd_fail(err, WPD_E_IO, "%s: spill index holds %llu of %zu points", path,
                        (unsigned long long)sum, n);
    out->n = n;
    out->gid = alloc_out(n * 8);
    out->xyz = alloc_out(n * 24);
    out->halo = alloc_out(n);
    out->records = with_records ? alloc_out(rec_bytes(s, n)) : NULL;
    read_scratch r = {malloc(max_len ? max_len : 1), malloc(max_raw ? max_raw : 1),
                      with_records ? malloc(rec_bytes(s, max_n) + 1) : NULL,
                      malloc(2 * s->cap * sizeof(uint64_t)), ZSTD_createDCtx()};
    int rc = 0;
    if (!out->gid || !out->xyz || !out->halo || (with_records && !out->records) || !r.file ||
        !r.coords || (with_records && !r.recs) || !r.dq || !r.dctx) {
        rc = wpd_fail(err, WPD_E_MEMORY, "%s: out of memory reading %zu spilled points", path, n);
    } else if (T->nchunks) {
        int fd = open(path, O_RDONLY | O_CLOEXEC);
        if (fd < 0)
            rc = wpd_fail_errno(err, "%s: cannot open spill file", path);
        uint64_t pos = 0;
        for (uint32_t k = 0; fd >= 0 && k < T->nchunks && !rc; k++) {
            rc = read_chunk(s, t, k, fd, path, with_records, &r, out, pos, err);
            pos += T->chunks[k].n;
        }
        if (fd >= 0)
            close(fd);
    }
    read_scratch_free(&r);
    if (rc)
        wpd_tile_data_free(out);
    return rc;
}
