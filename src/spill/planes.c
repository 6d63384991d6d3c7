/* planes.c - byte planes (see planes.h).
 *
 * Why records are stored as planes (bench/spill.sh; bench/spill_bench.c
 * "layouts"; 2-core AMD EPYC VM, zstd 1.5.4, each file cut into 64 tiles,
 * 256 KB chunks, MB/s of raw bytes on one core, decompression includes the
 * inverse transform). Records of 34 / 38 bytes:
 *
 *                          synthetic city 20 M      NC Raleigh 2.3 M
 *   layout       level    ratio  comp  decomp    ratio  comp  decomp
 *   rows            -3     1.81   535   1861      3.02   888   3071
 *   transposed      -7     3.69  1553   2993      5.63  1761   2817
 *   transposed      -3     4.02  1369   2922      5.96  1595   2674
 *   transposed      -1     4.18  1233   2946      6.16  1550   2773
 *
 * With SSE2 the transposes run on 16 x 16 byte blocks held in registers;
 * the scalar loops finish the tails (and are the whole path elsewhere).
 */
#include "spill/planes.h"

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

unsigned wpd_plane_width(uint64_t m)
{
    return m == 0 ? 0 : m < (1u << 8) ? 1 : m < (1u << 16) ? 2 : m < (1ull << 32) ? 4 : 8;
}

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

/* With SSE2, 32
 * values at a time: their 256 bytes as 16 rows of two values, transposed,
 * give byte b of the even values in column b and of the odd ones in column
 * b + 8; interleaving the two restores value order. */
void wpd_planes_put(uint8_t *restrict dst, const uint64_t *restrict v, size_t n, unsigned w)
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

/* Widths other than 1, 2, 4, 8 (never written by the codec) take the
 * scalar loop only. */
void wpd_planes_get(uint64_t *restrict v, const uint8_t *restrict src, size_t n, unsigned w)
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


void wpd_planes_from_records(uint8_t *restrict dst, const uint8_t *restrict rec, size_t n,
                             size_t w)
{
    transpose_bytes(dst, rec, n, w);
}

void wpd_planes_to_records(uint8_t *restrict rec, const uint8_t *restrict planes, size_t n,
                           size_t w)
{
    transpose_bytes(rec, planes, w, n);
}
