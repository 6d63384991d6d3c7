/* laz_coder.c - byte source, arithmetic decoder, models and integer
 * decompressor of LAZ (contracts in laz_coder.h). */
#include "io/laz/laz_coder.h"
#include "common/fullio.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>


/* ---- byte source ---- */

int laz_in_init(laz_in *in, int fd, size_t cap)
{
    memset(in, 0, sizeof *in);
    in->fd = fd;
    in->cap = cap;
    if (!(in->buf = malloc(cap)))
        return -1;
    in->cur = in->end = in->buf;
    return 0;
}

void laz_in_free(laz_in *in)
{
    free(in->buf);
    in->buf = NULL;
}

void laz_in_seek(laz_in *in, uint64_t pos, uint64_t limit)
{
    /* Keep buffered bytes when pos lies inside them: sequential chunks
     * then cost no re-read. */
    uint64_t start = in->end_off - (uint64_t)(in->end - in->buf);
    if (pos >= start && pos <= in->end_off && in->end_off <= limit) {
        in->cur = in->buf + (pos - start);
    } else {
        in->cur = in->end = in->buf;
        in->end_off = pos;
    }
    in->limit = limit;
    in->overrun = 0;
}

uint8_t laz_in_refill(laz_in *in)
{
    uint64_t pos = in->end_off;
    if (pos >= in->limit || in->io_errno) {
        in->overrun++;
        return 0;
    }
    uint64_t left = in->limit - pos;
    size_t want = left < in->cap ? (size_t)left : in->cap;
    ssize_t n = wpd_pread_full(in->fd, in->buf, want, pos);
    if (n <= 0) {
        /* A short file is the caller's "truncated" case; keep errno apart. */
        if (n < 0)
            in->io_errno = errno ? errno : EIO;
        in->limit = pos;
        in->overrun++;
        in->cur = in->end = in->buf;
        return 0;
    }
    in->cur = in->buf;
    in->end = in->buf + n;
    in->end_off = pos + (uint64_t)n;
    return *in->cur++;
}

void laz_in_bytes(laz_in *in, uint8_t *dst, size_t n)
{
    while (n) { /* whole buffered runs at a time; the refill does the rest */
        size_t run = (size_t)(in->end - in->cur);
        if (!run) {
            *dst++ = laz_in_refill(in);
            n--;
            continue;
        }
        run = run < n ? run : n;
        memcpy(dst, in->cur, run);
        in->cur += run, dst += run, n -= run;
    }
}

void laz_in_memory(laz_in *in, const uint8_t *data, size_t n)
{
    memset(in, 0, sizeof *in);
    in->fd = -1;
    in->cur = data;
    in->end = data + n;
    in->end_off = in->limit = n;
}

/* ---- arithmetic decoder ---- */

void laz_dec_init(laz_dec *d, laz_in *in)
{
    d->in = in;
    d->length = 0xFFFFFFFFu;
    d->value = 0;
    for (int i = 0; i < 4; i++)
        d->value = (d->value << 8) | laz_in_byte(in);
}

/* Shifts in bytes until the interval is at least 2^24 again. length is
 * never 0 here (every step leaves it >= 32), so the loop ends. */
static inline void renorm(laz_dec *d)
{
    do {
        d->value = (d->value << 8) | laz_in_byte(d->in);
    } while ((d->length <<= 8) < LAZ_AC_MIN_LENGTH);
}

void laz_bit_init(laz_bit *m)
{
    m->bit_0_count = 1;
    m->bit_count = 2;
    m->bit_0_prob = 1u << (LAZ_BM_LENGTH_SHIFT - 1);
    m->update_cycle = m->bits_until_update = 4;
}

/* Rescales the probability of a 0 from the counts; counts are halved when
 * they pass the maximum, and updates get rarer as the model settles. */
void laz_bit_update(laz_bit *m)
{
    if ((m->bit_count += m->update_cycle) > LAZ_BM_MAX_COUNT) {
        m->bit_count = (m->bit_count + 1) >> 1;
        m->bit_0_count = (m->bit_0_count + 1) >> 1;
        if (m->bit_0_count == m->bit_count)
            ++m->bit_count;
    }
    uint32_t scale = 0x80000000u / m->bit_count;
    m->bit_0_prob = (m->bit_0_count * scale) >> (31 - LAZ_BM_LENGTH_SHIFT);
    m->update_cycle = (5 * m->update_cycle) >> 2;
    if (m->update_cycle > 64)
        m->update_cycle = 64;
    m->bits_until_update = m->update_cycle;
}

uint32_t laz_dec_bit(laz_dec *d, laz_bit *m)
{
    uint32_t x = m->bit_0_prob * (d->length >> LAZ_BM_LENGTH_SHIFT);
    uint32_t sym = d->value >= x;
    if (!sym) {
        d->length = x;
        ++m->bit_0_count;
    } else {
        d->value -= x;
        d->length -= x;
    }
    if (d->length < LAZ_AC_MIN_LENGTH)
        renorm(d);
    if (--m->bits_until_update == 0)
        laz_bit_update(m);
    return sym;
}

/* Recomputes the cumulative distribution (15-bit fixed point) from the
 * counts and, for large models, the table mapping the top bits of a
 * scaled value to the first candidate symbol. */
void laz_sym_update(laz_sym *m)
{
    if ((m->total += m->update_cycle) > LAZ_DM_MAX_COUNT) {
        m->total = 0;
        for (uint32_t n = 0; n < m->n; n++)
            m->total += (m->count[n] = (m->count[n] + 1) >> 1);
    }
    uint32_t sum = 0, s = 0;
    uint32_t scale = 0x80000000u / m->total;
    for (uint32_t k = 0; k < m->n; k++) {
        m->distribution[k] = (scale * sum) >> (31 - LAZ_DM_LENGTH_SHIFT);
        sum += m->count[k];
        if (m->table_size) {
            uint32_t w = m->distribution[k] >> m->table_shift;
            while (s < w)
                m->table[++s] = k - 1;
        }
    }
    if (m->table_size) {
        m->table[0] = 0;
        while (s <= m->table_size)
            m->table[++s] = m->n - 1;
    }
    m->update_cycle = (5 * m->update_cycle) >> 2;
    uint32_t max_cycle = (m->n + 6) << 3;
    if (m->update_cycle > max_cycle)
        m->update_cycle = max_cycle;
    m->until_update = m->update_cycle;
}

/* Allocates model m of n symbols without setting its statistics. */
static int sym_alloc(laz_sym *m, uint32_t n)
{
    memset(m, 0, sizeof *m);
    if (n < 2 || n > 2048)
        return -1;
    m->n = n;
    m->last = n - 1;
    if (n > 16) {
        /* The table only speeds up the search: the symbol is fixed by the
         * distribution. One entry per symbol (at least 32) leaves most
         * brackets a single symbol wide; a quarter of that, LASzip's size,
         * left bisections whose branches the CPU mispredicts (8-15 % of
         * the decode time, docs/benchmarks.md). */
        uint32_t bits = 5;
        while (n > (1u << bits))
            ++bits;
        m->table_size = 1u << bits;
        m->table_shift = LAZ_DM_LENGTH_SHIFT - bits;
    }
    size_t words = 2 * (size_t)n + (m->table_size ? m->table_size + 2 : 0);
    if (!(m->distribution = malloc(words * sizeof(uint32_t))))
        return -1;
    m->count = m->distribution + n;
    m->table = m->table_size ? m->count + n : NULL;
    return 0;
}

int laz_sym_create(laz_sym *m, uint32_t n)
{
    if (sym_alloc(m, n))
        return -1;
    laz_sym_reset(m);
    return 0;
}

void laz_sym_reset(laz_sym *m)
{
    for (uint32_t k = 0; k < m->n; k++)
        m->count[k] = 1;
    m->total = 0;
    m->update_cycle = m->n;
    laz_sym_update(m);
    m->until_update = m->update_cycle = (m->n + 6) >> 1;
}

void laz_sym_free(laz_sym *m)
{
    free(m->distribution);
    memset(m, 0, sizeof *m);
}

uint32_t laz_dec_symbol(laz_dec *d, laz_sym *m)
{
    uint32_t sym, x, y = d->length;
    if (m->table) {
        uint32_t dv = d->value / (d->length >>= LAZ_DM_LENGTH_SHIFT);
        uint32_t t = dv >> m->table_shift;
        /* dv < 2^15 while value < length, which every step of a valid
         * stream keeps; raw bits of a corrupt one can break it (a quotient
         * of 2^n in dec_raw), so t is bounded: garbage out, caught by the
         * chunk's end checks, never a read outside the table. */
        if (t > m->table_size)
            t = m->table_size;
        sym = m->table[t];
        uint32_t n = m->table[t + 1] + 1;
        while (n > sym + 1) { /* bisection inside the table's bracket */
            uint32_t k = (sym + n) >> 1;
            if (m->distribution[k] > dv)
                n = k;
            else
                sym = k;
        }
        x = m->distribution[sym] * d->length;
        if (sym != m->last)
            y = m->distribution[sym + 1] * d->length;
    } else {
        uint32_t n = m->n, k = n >> 1;
        x = sym = 0;
        d->length >>= LAZ_DM_LENGTH_SHIFT;
        do {
            uint32_t z = d->length * m->distribution[k];
            if (z > d->value) {
                n = k;
                y = z;
            } else {
                sym = k;
                x = z;
            }
        } while ((k = (sym + n) >> 1) != sym);
    }
    d->value -= x;
    d->length = y - x;
    if (d->length < LAZ_AC_MIN_LENGTH)
        renorm(d);
    ++m->count[sym];
    if (--m->until_update == 0)
        laz_sym_update(m);
    return sym;
}

/* Up to 16 raw bits in one step (the interval keeps >= 2^8 of precision). */
static uint32_t dec_raw(laz_dec *d, unsigned n)
{
    uint32_t sym = d->value / (d->length >>= n);
    d->value -= d->length * sym;
    if (d->length < LAZ_AC_MIN_LENGTH)
        renorm(d);
    return sym;
}

uint32_t laz_dec_bits(laz_dec *d, unsigned n)
{
    if (n > 19) { /* too many for one step: low 16 bits first */
        uint32_t lower = dec_raw(d, 16);
        uint32_t upper = laz_dec_bits(d, n - 16);
        return (upper << 16) | lower;
    }
    return dec_raw(d, n);
}

uint32_t laz_dec_u32(laz_dec *d)
{
    uint32_t lower = dec_raw(d, 16);
    uint32_t upper = dec_raw(d, 16);
    return (upper << 16) | lower;
}

/* ---- integer decompressor ---- */

/* The models of a decompressor are many (a 32-bit one has 33 + 32 of up
 * to 256 symbols) and most are never used in a chunk: each is reset when
 * first used after laz_ic_reset (stamp != epoch), the same as resetting
 * all at the chunk start, at a fraction of the cost. stamp holds the
 * contexts' models first, then the correctors' (index contexts + k). */
int laz_ic_create(laz_ic *ic, uint32_t bits, uint32_t contexts)
{
    memset(ic, 0, sizeof *ic);
    ic->contexts = contexts;
    ic->bits_high = 8;
    if (bits && bits < 32) {
        ic->corr_bits = bits;
        ic->corr_range = 1u << bits;
        ic->corr_min = -(int32_t)(ic->corr_range / 2);
    } else {
        ic->corr_bits = 32;
        ic->corr_range = 0;
        ic->corr_min = INT32_MIN;
    }
    ic->epoch = 1;
    ic->m_bits = calloc(contexts, sizeof *ic->m_bits);
    ic->m_corr = calloc(ic->corr_bits + 1, sizeof *ic->m_corr);
    ic->stamp = calloc(contexts + ic->corr_bits + 1, sizeof *ic->stamp);
    if (!ic->m_bits || !ic->m_corr || !ic->stamp)
        return -1;
    for (uint32_t i = 0; i < contexts; i++)
        if (sym_alloc(&ic->m_bits[i], ic->corr_bits + 1))
            return -1;
    for (uint32_t i = 1; i <= ic->corr_bits; i++) {
        uint32_t b = i <= ic->bits_high ? i : ic->bits_high;
        if (sym_alloc(&ic->m_corr[i], 1u << b))
            return -1;
    }
    laz_bit_init(&ic->m_corr0);
    return 0;
}

void laz_ic_reset(laz_ic *ic)
{
    ic->epoch++;
    laz_bit_init(&ic->m_corr0);
    ic->k = 0;
}

void laz_ic_free(laz_ic *ic)
{
    if (ic->m_bits)
        for (uint32_t i = 0; i < ic->contexts; i++)
            laz_sym_free(&ic->m_bits[i]);
    if (ic->m_corr)
        for (uint32_t i = 1; i <= ic->corr_bits; i++)
            laz_sym_free(&ic->m_corr[i]);
    free(ic->m_bits);
    free(ic->m_corr);
    free(ic->stamp);
    memset(ic, 0, sizeof *ic);
}

/* The corrector: class k, then its value among the 2^(k-1) negative and
 * 2^(k-1) positive correctors of bit length k. */
static int32_t read_corrector(laz_ic *ic, laz_dec *d, uint32_t ctx)
{
    uint32_t k = ic->k = laz_dec_symbol(d, laz_ic_model(ic, &ic->m_bits[ctx], ctx));
    if (!k)
        return (int32_t)laz_dec_bit(d, &ic->m_corr0);
    if (k >= 32)
        return ic->corr_min;
    uint32_t c = laz_dec_symbol(d, laz_ic_model(ic, &ic->m_corr[k], ic->contexts + k));
    if (k > ic->bits_high) { /* the low bits raw */
        unsigned low = k - ic->bits_high;
        c = (c << low) | laz_dec_bits(d, low);
    }
    /* Unsigned: a corrupt stream may give c past its class; wrap, no UB. */
    if (c >= (1u << (k - 1)))
        return (int32_t)(c + 1u);
    return (int32_t)(c - ((1u << k) - 1u));
}

int32_t laz_ic_decode(laz_ic *ic, laz_dec *d, int32_t pred, uint32_t ctx)
{
    uint32_t real = (uint32_t)pred + (uint32_t)read_corrector(ic, d, ctx);
    if (ic->corr_range) { /* fold back into [0, corr_range) as the encoder did */
        if ((int32_t)real < 0)
            real += ic->corr_range;
        else if (real >= ic->corr_range)
            real -= ic->corr_range;
    }
    return (int32_t)real;
}
