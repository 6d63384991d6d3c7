/* laz_coder.h - the entropy decoding layer of LAZ (LASzip): a byte source
 * over a stretch of the file, the arithmetic (range) decoder with its
 * adaptive bit and symbol models, and the integer decompressor that codes
 * a corrector against a prediction in k-bit classes.
 *
 * Written from the description in the LAZ Specification 1.4 (rapidlasso)
 * and the LASzip paper (Isenburg 2013). The decoder must reproduce the
 * encoder's model arithmetic bit for bit, so the constants and update
 * rules below are those of the format, not tuning choices. Not for use
 * outside src/io.
 */
#ifndef WPD_LAZ_CODER_H
#define WPD_LAZ_CODER_H

#include <stddef.h>
#include <stdint.h>

/* Format constants (LAZ specification, "arithmetic coder"): the interval
 * is renormalised below 2^24; bit models keep probabilities in 13 bits and
 * symbol models their distributions in 15 bits. */
enum {
    LAZ_AC_MIN_LENGTH = 0x01000000u,
    LAZ_BM_LENGTH_SHIFT = 13,
    LAZ_BM_MAX_COUNT = 1u << LAZ_BM_LENGTH_SHIFT,
    LAZ_DM_LENGTH_SHIFT = 15,
    LAZ_DM_MAX_COUNT = 1u << LAZ_DM_LENGTH_SHIFT,
};

/* ---- byte source ---- */

/* Reads a file stretch [pos, limit) through a buffer. Bytes asked for at
 * or past limit come back as 0 and are counted in overrun: a valid stream
 * never needs them, so a caller that sees overrun knows the data is
 * truncated or corrupt (and decoding garbage stays bounded, never a hang). */
typedef struct laz_in {
    int fd;
    uint8_t *buf;
    size_t cap;
    const uint8_t *cur, *end;   /* unread part of buf */
    uint64_t end_off;           /* file offset of *end */
    uint64_t limit;
    uint64_t overrun;
    int io_errno;               /* first read error, 0 if none */
} laz_in;

/* Allocates the buffer (cap bytes). Returns 0, or -1 if out of memory. */
int laz_in_init(laz_in *in, int fd, size_t cap);
void laz_in_free(laz_in *in);
/* Positions the source at file offset pos with end limit; clears overrun. */
void laz_in_seek(laz_in *in, uint64_t pos, uint64_t limit);
/* File offset of the next byte the source will deliver. */
static inline uint64_t laz_in_tell(const laz_in *in)
{
    return in->end_off - (uint64_t)(in->end - in->cur);
}
/* Refills the buffer and returns the next byte (slow path of laz_in_byte). */
uint8_t laz_in_refill(laz_in *in);
static inline uint8_t laz_in_byte(laz_in *in)
{
    return in->cur < in->end ? *in->cur++ : laz_in_refill(in);
}
/* Copies n bytes into dst (zeros past the limit, counted as overrun). */
void laz_in_bytes(laz_in *in, uint8_t *dst, size_t n);
/* Makes in a source over n bytes in memory (not owned, not freed): the
 * layers of the layered compressor are decoded from a chunk buffer. The
 * offsets it reports (laz_in_tell) count from data. */
void laz_in_memory(laz_in *in, const uint8_t *data, size_t n);

/* ---- arithmetic decoder ---- */

typedef struct laz_dec {
    laz_in *in;
    uint32_t value, length;
} laz_dec;

/* Adaptive binary model. */
typedef struct laz_bit {
    uint32_t bit_0_count, bit_count, bit_0_prob, bits_until_update, update_cycle;
} laz_bit;

/* Adaptive model over symbols 0..n-1 (2 <= n <= 2048). The decoder table
 * (models of more than 16 symbols) speeds up the search for the symbol. */
typedef struct laz_sym {
    uint32_t *distribution, *count, *table;   /* one allocation, at distribution */
    uint32_t n, last, total, update_cycle, until_update, table_size, table_shift;
} laz_sym;

/* Starts decoding: reads the 4 bytes that open an arithmetic stream. */
void laz_dec_init(laz_dec *d, laz_in *in);

void laz_bit_init(laz_bit *m);
/* Allocates model m of n symbols and resets it. Returns 0, or -1 if out of
 * memory or n is out of range. */
int laz_sym_create(laz_sym *m, uint32_t n);
/* Resets the statistics of a created model to the uniform start state. */
void laz_sym_reset(laz_sym *m);
void laz_sym_free(laz_sym *m);

/* The model updates after a run of coded bits or symbols: shared by the
 * decoder and the encoder (laz_encoder.c), which must adapt identically. */
void laz_bit_update(laz_bit *m);
void laz_sym_update(laz_sym *m);

uint32_t laz_dec_bit(laz_dec *d, laz_bit *m);
uint32_t laz_dec_symbol(laz_dec *d, laz_sym *m);
/* Raw (unmodelled) bits: n in 1..32. */
uint32_t laz_dec_bits(laz_dec *d, unsigned n);
uint32_t laz_dec_u32(laz_dec *d);

/* ---- integer decompressor ---- */

/* Decodes integers as prediction + corrector. The corrector's magnitude
 * class k (its bit length) is coded with a per-context symbol model; the
 * value within the class with a model per k (the high bits_high bits
 * modelled, the rest raw). k of the last value is kept: the item coders
 * use it as context for the next coordinate. */
typedef struct laz_ic {
    uint32_t contexts, bits_high, corr_bits, corr_range;
    int32_t corr_min;
    uint32_t k;
    laz_sym *m_bits;        /* [contexts] */
    laz_bit m_corr0;        /* class k = 0: corrector 0 or 1 */
    laz_sym *m_corr;        /* [corr_bits + 1], index 0 unused */
    uint32_t epoch;         /* laz_ic_reset count: models reset on first use */
    uint32_t *stamp;        /* [contexts + corr_bits + 1]: epoch of each model's reset */
} laz_ic;

/* Creates a decompressor for values of bits bits (1..32) with contexts
 * contexts (bits_high 8, no range, as every LAZ item uses). Returns 0 or -1
 * if out of memory; the models are then in their start state. */
int laz_ic_create(laz_ic *ic, uint32_t bits, uint32_t contexts);
/* Returns every model to its start state (lazily: see laz_coder.c). */
void laz_ic_reset(laz_ic *ic);
void laz_ic_free(laz_ic *ic);
/* Model m (stamp index i: the contexts' models first, then the correctors'
 * at contexts + k) of ic, reset first if not used since laz_ic_reset. */
static inline laz_sym *laz_ic_model(laz_ic *ic, laz_sym *m, uint32_t i)
{
    if (ic->stamp[i] != ic->epoch) {
        laz_sym_reset(m);
        ic->stamp[i] = ic->epoch;
    }
    return m;
}

/* A symbol model made on first use and reset on first use after its
 * owner's epoch moved on (a chunk or context start): the layered items
 * have many models selected by previous values, most never used. */
typedef struct laz_lazy_sym {
    laz_sym m;
    uint32_t stamp;
} laz_lazy_sym;

/* The model of l (n symbols), made or reset as needed; NULL if it cannot
 * be allocated. */
static inline laz_sym *laz_lazy_model(laz_lazy_sym *l, uint32_t n, uint32_t epoch)
{
    if (!l->m.distribution) {
        if (laz_sym_create(&l->m, n))
            return NULL;
        l->stamp = epoch;
    } else if (l->stamp != epoch) {
        laz_sym_reset(&l->m);
        l->stamp = epoch;
    }
    return &l->m;
}

/* Decodes the value predicted as pred in context ctx (< contexts). */
int32_t laz_ic_decode(laz_ic *ic, laz_dec *d, int32_t pred, uint32_t ctx);

#endif
