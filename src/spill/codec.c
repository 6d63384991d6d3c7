/* codec.c - the coordinate codec of the spill (see codec.h).
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
 *
 * Why this codec (bench/spill.sh; bench/spill_bench.c "layouts"; 2-core
 * AMD EPYC VM, zstd 1.5.4). Each file cut into 64 tiles by an x/y grid,
 * points in input order, 256 KB chunks; MB/s of raw bytes on one core,
 * decompression includes the inverse transform. Coordinate part 33 bytes a
 * point (layouts: see bench/spill_bench.c):
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
 *
 * Byte shuffling alone gains little on frame coordinates: their low
 * mantissa bytes are the rounding noise of X * scale + offset - origin.
 * The grid codec removes exactly that noise and is as fast as the fastest
 * generic layout. (The synthetic scan lies on an exact grid; NC Raleigh is
 * the realistic figure.)
 */
#include "spill/codec.h"

#include <limits.h>
#include <math.h>
#include <string.h>

#include "spill/planes.h"

static uint64_t zigzag(int64_t x)
{
    return ((uint64_t)x << 1) ^ (uint64_t)(x >> 63);
}

static int64_t unzigzag(uint64_t u)
{
    return (int64_t)((u >> 1) ^ (0 - (u & 1)));
}


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

/* The block header is the on-disk format: its size is part of the contract
 * (codec.h) and must not change with the compiler's padding. */
_Static_assert(sizeof(coord_head) == WPD_COORDS_HEAD_BYTES, "coordinate block header");

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

/* Round to nearest (ties to even) for |x| < 2^51 without a libm call.
 * Beyond that the result is merely repeatable and need not even be an
 * integer (x = -(2^51 + 0.5) stays as it is): callers that store it
 * convert it to int64 and use that value from then on. */
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
 * above) into h and out. Returns the bytes written plus 1, or 0 if a value
 * is not a multiple of g below 2^62 g or the encoding would take more than
 * 8 bytes a value (the caller then tries another way). */
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
            /* Predict from the stored integer q, not qd: the decoder
             * only has q, and qd need not be an integer (below). */
            ror |= rr[i] = zigzag(K - (int64_t)grid_predict((double)q, S));
            prev = q;
        }
    }
    if (!ok)
        return 0;
    h->wq = wpd_plane_width(dor);
    h->wr = wpd_plane_width(ror);
    /* Values off the guessed decimal grid (a chunk mixing inputs of two
     * scales, or adversarial data) can need wide residuals: above 8 bytes a
     * point raw doubles are smaller, and wpd_coords_bound counts on 8. */
    if (h->wq + h->wr > 8)
        return 0;
    wpd_planes_put(out, dq, n, h->wq);
    wpd_planes_put(out + h->wq * n, rr, n, h->wr);
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
    wpd_planes_put(out, dq, n, 8);
    return 8 * n;
}

static int width_valid(unsigned w)
{
    return w == 0 || w == 1 || w == 2 || w == 4 || w == 8;
}

/* 1 if the head of an axis block is one encode_axis can write, the fields
 * it leaves 0 included: the stricter the check, the more damage is found
 * (the block has no checksum of its own). */
static int axis_valid(const axis_head *h)
{
    if (h->pad)
        return 0;
    if (h->mode == AXIS_RAW)
        return h->wq == 0 && h->wr == 0 && h->gexp == 0 && h->S == 0 && h->q0 == 0;
    if (!width_valid(h->wq) || !width_valid(h->wr) || h->gexp < -1000 || h->gexp > 1000)
        return 0;
    if (h->mode == AXIS_FIXED)
        return h->wr == 0 && h->S == 0;
    return h->mode == AXIS_GRID && h->wq + h->wr <= 8 && h->S >= 2 &&
           h->S <= 0x1p60; /* false for NaN */
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
        wpd_planes_get(dq, in, n, 8);
        for (size_t i = 0; i < n; i++)
            memcpy(&v[3 * i], &dq[i], 8);
        return 0;
    }
    double g = ldexp(1, h->gexp);
    wpd_planes_get(dq, in, n, h->wq);
    uint64_t q = (uint64_t)h->q0; /* unsigned: corrupt data wraps, never overflows */
    if (h->mode == AXIS_FIXED) {
        for (size_t i = 0; i < n; i++) {
            q += (uint64_t)unzigzag(dq[i]);
            v[3 * i] = (double)(int64_t)q * g;
        }
        return 0;
    }
    wpd_planes_get(rr, in + h->wq * n, n, h->wr);
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

size_t wpd_coords_bound(size_t n)
{
    return sizeof(coord_head) + n * (8 + 3 * 8 + 1);
}

/* Global indices as differences from the previous one (wrapping: any
 * order encodes) into p; dq: scratch of n values. Returns the bytes
 * written. */
static size_t encode_gids(const uint64_t *gid, size_t n, coord_head *h, uint8_t *p,
                          uint64_t *dq)
{
    uint64_t dor = 0;
    h->gid0 = n ? gid[0] : 0;
    for (size_t i = 0; i < n; i++)
        dor |= dq[i] = gid[i] - (i ? gid[i - 1] : gid[0]);
    h->wg = (uint8_t)wpd_plane_width(dor);
    wpd_planes_put(p, dq, n, h->wg);
    return h->wg * n;
}

size_t wpd_coords_encode(const uint64_t *gid, const double *xyz, const uint8_t *halo, size_t n,
                         uint8_t *out, uint64_t *scratch)
{
    if (n > WPD_COORDS_MAX_POINTS)
        return 0;
    uint64_t *dq = scratch, *rr = scratch + n;
    coord_head h;
    memset(&h, 0, sizeof h);
    h.n = (uint32_t)n;
    uint8_t *p = out + sizeof h;
    p += encode_gids(gid, n, &h, p, dq);
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

/* Reads and checks the header of the block of size bytes at in into h:
 * every field one the encoder can write, and size exactly the bytes the
 * header implies (so that no later read leaves the block). Returns 0 or
 * -1 (err set). */
static int read_head(const uint8_t *in, size_t size, coord_head *h, wpd_error *err)
{
    if (size < sizeof *h)
        return wpd_fail(err, WPD_E_INPUT, "coordinate block truncated: %zu bytes, its header "
                        "alone takes %zu", size, sizeof *h);
    memcpy(h, in, sizeof *h);
    size_t n = h->n;
    if (!width_valid(h->wg) || h->wh > 1 || h->pad[0] || h->pad[1] || (n == 0 && h->gid0))
        return wpd_fail(err, WPD_E_INPUT, "coordinate block: bad header (index width %u, "
                        "halo %u)", h->wg, h->wh);
    /* n < 2^32 and widths <= 8: no sum below can overflow a 64-bit size_t. */
    size_t need = sizeof *h + h->wg * n + (h->wh ? halo_bytes(n) : 0);
    for (int a = 0; a < 3; a++) {
        if (!axis_valid(&h->axis[a]))
            return wpd_fail(err, WPD_E_INPUT, "coordinate block: bad header of axis %c "
                            "(mode %u, widths %u %u)", "xyz"[a], h->axis[a].mode,
                            h->axis[a].wq, h->axis[a].wr);
        need += axis_bytes(&h->axis[a], n);
    }
    if (need != size)
        return wpd_fail(err, WPD_E_INPUT, "coordinate block %s: %zu bytes, its header "
                        "says %zu", size < need ? "truncated" : "too long", size, need);
    return 0;
}

int wpd_coords_count(const uint8_t *in, size_t size, size_t *n, wpd_error *err)
{
    coord_head h;
    if (read_head(in, size, &h, err))
        return -1;
    *n = h.n;
    return 0;
}

/* Checks that the bits past the last point in the last halo byte are 0,
 * as the encoder leaves them: one more way to notice damage. */
static int halo_tail_clear(const uint8_t *bits, size_t n)
{
    return n % 8 == 0 || (bits[n / 8] >> (n % 8)) == 0;
}

int wpd_coords_decode(const uint8_t *in, size_t size, size_t n, uint64_t *gid, double *xyz,
                      uint8_t *halo, uint64_t *scratch, wpd_error *err)
{
    coord_head h;
    if (read_head(in, size, &h, err))
        return -1;
    if (h.n != n)
        return wpd_fail(err, WPD_E_INPUT, "coordinate block holds %u points, expected %zu",
                        h.n, n);
    uint64_t *dq = scratch, *rr = scratch + n;
    const uint8_t *p = in + sizeof h;
    wpd_planes_get(dq, p, n, h.wg);
    p += h.wg * n;
    uint64_t g = h.gid0;
    for (size_t i = 0; i < n; i++)
        gid[i] = g += dq[i];
    for (int a = 0; a < 3; a++) {
        if (decode_axis(&h.axis[a], p, n, a, xyz, dq, rr))
            return wpd_fail(err, WPD_E_INPUT, "coordinate block: axis %c decodes out of "
                            "range", "xyz"[a]);
        p += axis_bytes(&h.axis[a], n);
    }
    if (h.wh && !halo_tail_clear(p, n))
        return wpd_fail(err, WPD_E_INPUT, "coordinate block: halo bits past the last point");
    if (h.wh)
        halo_unpack(halo, p, n);
    else
        memset(halo, 0, n);
    return 0;
}
