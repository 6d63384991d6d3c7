/* test_laz_write.c - the LAZ writer: the arithmetic encoder and integer
 * compressor against our decoder (every value back, every byte read, none
 * more), and records written as .laz through the public writer read back
 * through the public reader to exactly the records of the .las written
 * from the same points, for point formats 0-3 with and without extra
 * bytes, over several chunks. laz2las.js (an independent decoder) checks
 * the same files in tests/e2e/test_laz_write.py. A chunk LASzip wrote
 * holds the layered items' scanner channel rule both ways (LASzip itself
 * is compared on many files in tests/e2e/test_laz_laszip.py). */
#include "harness.h"
#include "las_files.h"

#include "io/laz/laz.h"
#include "io/laz/laz_encoder.h"
#include "io/laz/laz_items.h"
#include "io/laz/laz_layered.h"
#include "io/reader.h"

#include <fcntl.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static uint32_t next_random(uint64_t *s)
{
    *s ^= *s << 13;
    *s ^= *s >> 7;
    *s ^= *s << 17;
    return (uint32_t)(*s >> 11);
}

/* ------------------------------------------------------ the coder */

enum { OP_BIT, OP_SYM5, OP_SYM256, OP_SYM2048, OP_RAW, OP_U32, OP_IC16, OP_IC32, OP_KINDS };

typedef struct coded {
    int kind;
    uint32_t value, bits;     /* bits: raw bit count; ic: the context */
    int32_t pred;
} coded;

typedef struct models {
    laz_bit bit;
    laz_sym s5, s256, s2048;
    laz_ic ic16, ic32;
} models;

static int models_create(models *m)
{
    laz_bit_init(&m->bit);
    return laz_sym_create(&m->s5, 5) || laz_sym_create(&m->s256, 256) ||
           laz_sym_create(&m->s2048, 2048) || laz_ic_create(&m->ic16, 16, 4) ||
           laz_ic_create(&m->ic32, 32, 3);
}

static void models_free(models *m)
{
    laz_sym_free(&m->s5), laz_sym_free(&m->s256), laz_sym_free(&m->s2048);
    laz_ic_free(&m->ic16), laz_ic_free(&m->ic32);
}

/* A skewed value (small ones common: long runs of likely symbols make the
 * carries and 0xFF runs the encoder must handle) below n. */
static uint32_t skewed(uint64_t *s, uint32_t n)
{
    uint32_t r = next_random(s);
    return (r & 3) ? (r >> 2) % (n < 4 ? n : 4) : (r >> 2) % n;
}

/* An operation and its operands: extreme correctors included (INT32_MIN
 * apart, the one 32-bit class). */
static coded make_op(uint64_t *s)
{
    coded c = {.kind = (int)(next_random(s) % OP_KINDS)};
    static const int32_t extremes[] = {INT32_MIN, INT32_MAX, 0, 1, -1, 255, -256};
    switch (c.kind) {
    case OP_BIT: c.value = skewed(s, 2); break;
    case OP_SYM5: c.value = skewed(s, 5); break;
    case OP_SYM256: c.value = skewed(s, 256); break;
    case OP_SYM2048: c.value = skewed(s, 2048); break;
    case OP_RAW:
        c.bits = 1 + next_random(s) % 32;
        c.value = (next_random(s) << 16 ^ next_random(s)) & (c.bits < 32 ? (1u << c.bits) - 1 : ~0u);
        break;
    case OP_U32: c.value = next_random(s) << 16 ^ next_random(s); break;
    case OP_IC16:
        c.pred = (int32_t)(next_random(s) & 0xFFFF), c.value = next_random(s) & 0xFFFF;
        c.bits = next_random(s) % 4;
        break;
    default:
        c.pred = (int32_t)next_random(s);
        c.value = (uint32_t)c.pred + (next_random(s) % 3 ? skewed(s, 1000)
                                      : (uint32_t)extremes[next_random(s) % 7]);
        c.bits = next_random(s) % 3;
        break;
    }
    return c;
}

static void encode_op(laz_enc *e, models *m, const coded *c)
{
    switch (c->kind) {
    case OP_BIT: laz_enc_bit(e, &m->bit, c->value); break;
    case OP_SYM5: laz_enc_symbol(e, &m->s5, c->value); break;
    case OP_SYM256: laz_enc_symbol(e, &m->s256, c->value); break;
    case OP_SYM2048: laz_enc_symbol(e, &m->s2048, c->value); break;
    case OP_RAW: laz_enc_bits(e, c->value, c->bits); break;
    case OP_U32: laz_enc_u32(e, c->value); break;
    case OP_IC16: laz_ic_encode(&m->ic16, e, c->pred, (int32_t)c->value, c->bits); break;
    default: laz_ic_encode(&m->ic32, e, c->pred, (int32_t)c->value, c->bits); break;
    }
}

static uint32_t decode_op(laz_dec *d, models *m, const coded *c)
{
    switch (c->kind) {
    case OP_BIT: return laz_dec_bit(d, &m->bit);
    case OP_SYM5: return laz_dec_symbol(d, &m->s5);
    case OP_SYM256: return laz_dec_symbol(d, &m->s256);
    case OP_SYM2048: return laz_dec_symbol(d, &m->s2048);
    case OP_RAW: return laz_dec_bits(d, c->bits);
    case OP_U32: return laz_dec_u32(d);
    case OP_IC16: return (uint32_t)laz_ic_decode(&m->ic16, d, c->pred, c->bits);
    default: return (uint32_t)laz_ic_decode(&m->ic32, d, c->pred, c->bits);
    }
}

/* Decodes the stream in buf (len bytes, via a file as the reader does)
 * against ops; returns the number of mismatches, or -1. */
static long decode_all(const uint8_t *buf, size_t len, const coded *ops, size_t n,
                       int *exact_end)
{
    char path[1024];
    cf_tmp_path(path, sizeof path, "coder.bin");
    if (cf_write_file(path, buf, len))
        return -1;
    int fd = open(path, O_RDONLY);
    models m;
    laz_in in;
    long bad = -1;
    if (fd >= 0 && !models_create(&m) && !laz_in_init(&in, fd, 4096)) {
        laz_dec d;
        laz_in_seek(&in, 0, len);
        laz_dec_init(&d, &in);
        bad = 0;
        for (size_t i = 0; i < n; i++)
            bad += decode_op(&d, &m, &ops[i]) != ops[i].value;
        *exact_end = !in.overrun && laz_in_tell(&in) == len;
        laz_in_free(&in);
        models_free(&m);
    }
    if (fd >= 0)
        close(fd);
    return bad;
}

TEST(laz_encoder_round_trips_through_the_decoder)
{
    /* Lengths from empty (only the closing bytes) to many renormalisations. */
    static const size_t lengths[] = {0, 1, 2, 17, 1000, 300000};
    uint64_t seed = 0x9E3779B97F4A7C15ull;
    for (size_t t = 0; t < sizeof lengths / sizeof *lengths; t++) {
        size_t n = lengths[t];
        coded *ops = malloc((n ? n : 1) * sizeof *ops);
        models m;
        CHECK(ops && !models_create(&m));
        if (!ops)
            return;
        laz_out out = {0};
        laz_enc e;
        laz_enc_init(&e, &out);
        for (size_t i = 0; i < n; i++) {
            ops[i] = make_op(&seed);
            encode_op(&e, &m, &ops[i]);
        }
        laz_enc_done(&e);
        CHECK(!out.oom && out.len >= 4);
        int exact_end = 0;
        long bad = decode_all(out.buf, out.len, ops, n, &exact_end);
        CHECK_MSG(bad == 0, "%zu ops: %ld decoded differently", n, bad);
        CHECK_MSG(exact_end, "%zu ops: the decoder did not end on the stream's last byte", n);
        laz_out_free(&out);
        models_free(&m);
        free(ops);
    }
}

/* ------------------------------------------------------ the writer */

/* Varies every field of the records of p (point format pdrf) so that
 * every coding path runs: returns changing or not, intensities, classes,
 * scan angles, point sources, GPS times that step, repeat, jump to
 * another flight line and back, grey and coloured RGB, extra bytes. */
static void vary_records(cf_cloud *p, int pdrf, uint64_t seed)
{
    double t_line[2] = {1e5, 3.4e8};
    for (size_t i = 0; i < p->n; i++) {
        uint8_t *r = p->records + i * p->record_size;
        uint32_t v = next_random(&seed);
        p->xyz[3 * i] = 1000 + (double)(i % 5000) * 0.37 + (v % 100) * 0.01;
        p->xyz[3 * i + 1] = 2000 + (double)(i / 5000) * 0.5 - (v % 7) * 0.01;
        p->xyz[3 * i + 2] = (v % 3 ? 7.0 : 7.0 + (v % 4000) * 0.01);
        unsigned nret = 1 + v % 3, ret = 1 + (v >> 3) % nret;
        if (v % 5 == 0) /* the same return byte as the last point */
            ret = nret = 1;
        r[14] = (uint8_t)(ret | nret << 3 | ((v >> 9) & 1) << 6);
        uint16_t intensity = (uint16_t)(v % 11 ? 300 + (v >> 4) % 50 : v >> 8);
        memcpy(r + 12, &intensity, 2);
        r[15] = (uint8_t)(v % 9 ? 2 : 6);
        r[16] = (uint8_t)(v % 13 ? 0 : (int8_t)((int)(v >> 5) % 90 - 45));
        r[17] = (uint8_t)(v % 17 ? 0 : v >> 20);
        uint16_t source = (uint16_t)(i / 20000 + (v % 101 ? 0 : 7));
        memcpy(r + 18, &source, 2);
        size_t at = 20;
        if (pdrf == 1 || pdrf == 3) {
            int line = (i / 1000) % 2 && v % 3;
            if (v % 4)
                t_line[line] += v % 7 ? 1e-5 : 2.5 * (v % 1000);
            double t = v % 4999 ? t_line[line] : -t_line[line] * 1e200;
            memcpy(r + at, &t, 8);
            at += 8;
        }
        if (pdrf == 2 || pdrf == 3) {
            uint16_t rgb[3] = {(uint16_t)(v & 0xFFFF), (uint16_t)(v & 0xFFFF), (uint16_t)(v & 0xFFFF)};
            if (v % 3) /* coloured, else grey */
                rgb[1] = (uint16_t)(rgb[0] + (v >> 16) % 300), rgb[2] = (uint16_t)(v >> 5);
            memcpy(r + at, rgb, 6);
            at += 6;
        }
        for (; at < p->record_size; at++)
            r[at] = (uint8_t)(i % 2 ? (uint32_t)r[at - 1] + 1 : v >> (at % 24));
    }
}

/* The fields after X Y Z of point formats 6-8, varied for the layered
 * coder: scanner channels that switch (a channel's first point in a chunk
 * starts its context from another's), up to 15 returns and odd return
 * pairs, flags, classes, scan angles, sources, GPS times that repeat,
 * step and jump per channel, RGB and NIR, extra bytes. */
static void vary_records14(cf_cloud *p, int pdrf, uint64_t seed)
{
    double t_channel[4] = {1e5, 2e5, 3.4e8, -7.0};
    for (size_t i = 0; i < p->n; i++) {
        uint8_t *r = p->records + i * p->record_size;
        uint32_t v = next_random(&seed);
        unsigned ch = (unsigned)(i / 300 + (v % 7 == 0 ? v >> 3 : 0)) & 3;
        unsigned nret = v % 11 ? 1 + v % 4 : (v >> 4) % 16, ret = v % 13 ? 1 + (v >> 3) % (nret ? nret : 1) : (v >> 8) % 16;
        r[14] = (uint8_t)(ret | nret << 4);
        uint16_t intensity = (uint16_t)(v % 11 ? 300 + (v >> 4) % 50 : v >> 8);
        memcpy(r + 12, &intensity, 2);
        r[15] = (uint8_t)((v % 19 ? 0 : (v >> 5) & 15) | ch << 4 | ((v >> 9) & 1) << 6 |
                          (v % 23 ? 0 : 1) << 7);
        r[16] = (uint8_t)(v % 9 ? 2 : 6 + (v >> 12) % 30);
        r[17] = (uint8_t)(v % 17 ? 0 : v >> 20);
        int16_t angle = (int16_t)(v % 13 ? 0 : (int)(v >> 5) % 30000 - 15000);
        memcpy(r + 18, &angle, 2);
        uint16_t source = (uint16_t)(i / 20000 + (v % 101 ? 0 : 7));
        memcpy(r + 20, &source, 2);
        if (v % 4)
            t_channel[ch] += v % 7 ? 1e-5 : 2.5 * (v % 1000);
        double t = v % 4999 ? t_channel[ch] : -t_channel[ch] * 1e200;
        memcpy(r + 22, &t, 8);
        size_t at = 30;
        if (pdrf >= 7) {
            uint16_t c[4] = {(uint16_t)v, (uint16_t)v, (uint16_t)v, (uint16_t)(v >> 7)};
            if (v % 3)
                c[1] = (uint16_t)(c[0] + (v >> 16) % 300), c[2] = (uint16_t)(v >> 5);
            memcpy(r + at, c, pdrf == 8 ? 8 : 6);
            at += pdrf == 8 ? 8 : 6;
        }
        for (; at < p->record_size; at++)
            r[at] = (uint8_t)(i % 2 ? (uint32_t)r[at - 1] + 1 : v >> (at % 24));
    }
}

/* Writes p as name (.las or .laz) with h and reads it back into got. */
static int write_read(const char *name, const wpd_header *h, const cf_cloud *p, cf_cloud *got,
                      wpd_error *err)
{
    char path[1024];
    cf_tmp_path(path, sizeof path, name);
    if (lt_write_points(path, h, p, 7777, err))
        return -1;
    wpd_reader *r = wpd_reader_open(path, err);
    if (!r)
        return -1;
    int rc = cf_read_all(r, got, 4096, err);
    if (rc == 0 && !wpd_reader_header(r)->las.laz.compressed != !strstr(name, ".laz"))
        rc = -1;
    wpd_reader_close(r);
    return rc;
}

/* Point format pdrf with extra extra bytes, n points. */
static void check_format(int *failures_, uint8_t pdrf, uint16_t extra, uint32_t n)
{
    static const uint16_t standard[] = {20, 28, 26, 34, 0, 0, 30, 36, 38};
    lt_synth s = {pdrf >= 6 ? 4 : 2, pdrf, (uint16_t)(standard[pdrf] + extra), n, 1};
    uint8_t *buf = calloc(1, 4096 + (size_t)n * s.record_length);
    char path[1024], las[64], laz[64];
    cf_tmp_path(path, sizeof path, "base.las");
    CHECK(buf && cf_write_file(path, buf, lt_build_las(buf, &s)) == 0);
    free(buf);
    wpd_error err = {0};
    wpd_reader *r = wpd_reader_open(path, &err);
    CHECK_MSG(r, "%s", err.msg);
    if (!r)
        return;
    cf_cloud p, a = {0}, b = {0};
    CHECK(cf_read_all(r, &p, 65536, &err) == 0);
    if (pdrf >= 6) {
        vary_records(&p, 0, 0x1234567u + pdrf); /* X Y Z */
        vary_records14(&p, pdrf, 0x7654321u + pdrf);
    } else {
        vary_records(&p, pdrf, 0x1234567u + pdrf);
    }
    snprintf(las, sizeof las, "f%u_%u.las", pdrf, extra);
    snprintf(laz, sizeof laz, "f%u_%u.laz", pdrf, extra);
    int rc = write_read(las, wpd_reader_header(r), &p, &a, &err);
    CHECK_MSG(rc == 0, "%s: %s", las, err.msg);
    rc = write_read(laz, wpd_reader_header(r), &p, &b, &err);
    CHECK_MSG(rc == 0, "%s: %s", laz, err.msg);
    CHECK_MSG(a.n == n && b.n == n && a.record_size == b.record_size &&
                  !memcmp(a.records, b.records, (size_t)n * a.record_size) &&
                  !memcmp(a.xyz, b.xyz, (size_t)n * 3 * sizeof *a.xyz),
              "format %u, %u extra bytes: the LAZ records differ from the LAS ones", pdrf, extra);
    cf_cloud_free(&p), cf_cloud_free(&a), cf_cloud_free(&b);
    wpd_reader_close(r);
}

TEST(laz_writer_gives_the_las_records_formats_0_to_3)
{
    /* More than two chunks of WPD_LAZ_CHUNK_POINTS, the last one short. */
    uint32_t n = 2 * WPD_LAZ_CHUNK_POINTS + 1234;
    for (uint8_t pdrf = 0; pdrf <= 3; pdrf++) {
        check_format(failures_, pdrf, 0, pdrf == 3 ? n : 20000);
        check_format(failures_, pdrf, 3, pdrf == 1 ? n : 3000);
    }
    check_format(failures_, 3, 0, 1); /* one point: a chunk of the raw record only */
}

TEST(laz_writer_gives_the_las_records_formats_6_to_8)
{
    uint32_t n = 2 * WPD_LAZ_CHUNK_POINTS + 1234;
    for (uint8_t pdrf = 6; pdrf <= 8; pdrf++) {
        check_format(failures_, pdrf, 0, pdrf == 6 ? n : 20000);
        check_format(failures_, pdrf, 5, pdrf == 8 ? n : 3000);
    }
    check_format(failures_, 7, 0, 1);
}

TEST(laz_writer_refuses_waveform_point_formats)
{
    static const uint8_t waveform[] = {4, 5, 9, 10};
    for (size_t i = 0; i < sizeof waveform; i++) {
        uint8_t pdrf = waveform[i];
        wpd_error err = {0};
        wpd_laz_writer *z = wpd_laz_writer_create("x.laz", pdrf, 80, &err);
        CHECK_MSG(!z && err.code == WPD_E_USAGE && strstr(err.msg, "cannot write LAZ point format"),
                  "format %u: %s", pdrf, err.msg);
        wpd_laz_writer_free(z);
    }
}

/* ---- the layered items' contexts against LASzip ---- */

/* 32 records of point format 8 with 2 extra bytes whose scanner channels
 * switch to new contexts, back to used ones and stay on channels other
 * than 0, with colour, NIR and extra bytes changing on every point. */
static const char layered_channels[] = "11122002331102223011300221133200";

static void layered_record(uint8_t *r, int i)
{
    int32_t xyz[3] = {1000 + 7 * i, 2000 - 3 * i, 300 + i * i % 17};
    uint16_t intensity = (uint16_t)(100 + i % 5), source = 1;
    uint16_t colour[4] = {(uint16_t)(1000 + 37 * i), (uint16_t)(2000 + 11 * (i % 4)),
                          (uint16_t)(3000 - 5 * i), (uint16_t)(500 + 3 * i)};
    double t = 1000.0 + 0.5 * i;
    memset(r, 0, 40);
    memcpy(r, xyz, 12);
    memcpy(r + 12, &intensity, 2);
    r[14] = 0x11;
    r[15] = (uint8_t)((layered_channels[i] - '0') << 4);
    r[16] = 2;
    memcpy(r + 20, &source, 2);
    memcpy(r + 22, &t, 8);
    memcpy(r + 30, colour, 8);
    r[38] = (uint8_t)(i * 5);
    r[39] = (uint8_t)(i / 3);
}

/* The one chunk LASzip (laszip_enc of ../shared/tools/laszip) wrote for
 * those records: its raw first record, point count, layer byte counts and
 * layers. */
static const uint8_t laszip_chunk[] =
    "\xe8\x03\x00\x00\xd0\x07\x00\x00\x2c\x01\x00\x00\x64\x00\x11\x10\x02\x00\x00\x00\x01\x00\x00\x00\x00\x00\x00\x40\x8f\x40\xe8\x03"
    "\xd0\x07\xb8\x0b\xf4\x01\x00\x00\x20\x00\x00\x00\x64\x00\x00\x00\x22\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x19\x00\x00\x00"
    "\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\xc5\x00\x00\x00\x86\x00\x00\x00\x2b\x00\x00\x00\x23\x00\x00\x00\x23\x00\x00\x00"
    "\x20\x3a\x2a\xe2\xea\xf2\x13\x63\x6a\x9e\x2b\x0c\x06\x00\x5d\x8e\xd4\xe6\x1f\x1e\x49\xcd\x53\xf9\x46\x7a\x60\x30\x20\xeb\x23\x64"
    "\x2a\xcc\xc4\x6e\xe2\xef\x1f\x61\x86\x24\x31\xe0\x1d\x46\xd2\x1e\xff\xbf\x32\x45\x74\xce\x04\xb9\xf4\x06\xc4\xc8\xdf\x74\x09\x8e"
    "\xe1\x87\xe2\x4a\xc1\x4f\xcd\xe9\xe1\x01\x78\x8a\xc5\x87\x8f\x75\xb8\xa1\xbc\xe2\xc8\xbc\xc7\xd3\xe1\xda\x6e\xe8\xb6\x31\x27\xd5"
    "\xf0\x92\x00\x00\x04\x2b\xdc\x49\x42\xdb\x17\xda\x3e\x31\x49\x7e\x55\x67\x47\x80\x8b\xa8\xe3\xb7\x04\xd1\x9a\xda\x63\x24\xfc\xda"
    "\x8f\xd9\xf2\x00\x00\x00\x07\xc1\x52\xb8\x66\x71\x55\x08\x7d\x41\xf0\xfc\xa6\xdb\x07\xdb\x6e\xb5\xaf\x3d\x07\xd5\x00\x00\x00\x44"
    "\x42\x5c\x2b\x40\x00\x1e\x07\xf3\x49\x00\x00\x0b\xad\x37\x50\xc0\x00\x04\x87\x82\x87\x00\x00\x01\xc8\xb7\xd8\x80\x00\x00\xb1\xd9"
    "\x75\x4c\x00\x00\x4f\x4b\x2e\xc0\x00\x00\x07\x63\xff\xb6\x80\x00\x02\xe3\x5a\xcb\x60\x00\x01\x35\xe5\x6e\x12\x30\x00\x0e\x7f\x3d"
    "\x35\xe0\x00\x05\xff\xf1\x55\x38\x00\x00\x4a\x3a\x72\x34\x00\x00\x03\x62\xf9\x7e\x60\x00\x01\x7b\x6e\x58\x80\x00\x01\xa5\x3b\x0a"
    "\x20\x00\x00\x14\x4e\xfa\x13\xdc\x00\x00\xfd\x64\x99\x58\x00\x00\x0c\xf8\xee\x5e\xc0\x00\x0e\x0a\x11\xe3\x78\x00\x01\x5c\x75\xfa"
    "\xc9\x90\x00\x24\xa4\x7f\x8b\xc0\x00\x35\x87\x32\x00\x78\x00\x07\x5c\xb9\x7b\x60\x00\x0a\x08\xb9\x94\x58\x00\x01\x3f\xf9\xae\xc0"
    "\x00\x01\x60\x88\xe0\x3c\x00\x00\x12\x0c\x36\x3b\x00\x00\x19\xe0\x26\x3c\x00\x00\x03\xd5\x26\xcf\xac\x00\x00\x79\x7a\x7c\xf1\xc0"
    "\x00\x80\x00\x00\xae\x49\x9a\x35\xd9\xa2\xc2\x79\xa6\xc5\x85\x4b\x37\x8b\x08\x88\x52\xc7\x50\x19\x0f\x4c\x27\x9a\x6c\x58\x54\xb3"
    "\x77\x1f\x1c\x22\x61\xa1\x3a\xd3\xeb\xe4\x97\x17\x78\x7d\x08\xe6\x52\x57\x79\x57\xf2\x83\x32\x13\xad\x3e\xbf\x09\x59\xc4\x32\xfa"
    "\x17\xa5\xe9\xcc\x50\x88\x85\x27\xe6\x6f\x88\x72\xd6\x54\x32\xd2\x99\xbe\x21\xcb\x57\xf2\x82\xc0\x07\xb0\xbd\x0b\xd2\xf4\xe6\x28"
    "\x54\xb3\x7a\xfc\x25\xf7\x82\xa2\x6b\x14\x4a\xed\xb5\x04\xc9\x93\xc8\xad\x00\x4f\xe2\xd4\x13\x26\x4f\x62\x85\xe3\xf7\xf4\xba\x02"
    "\x6e\x26\x9c\x1a\xd0\x04\xa8\x00\x00\x00\x40\xd0\x12\x6d\x61\x21\x62\x08\x08\x2a\x06\x8a\x7c\x5f\x20\xea\xb1\xad\xd2\x34\x87\xf3"
    "\x2b\x96\xea\x1d\xbe\xb8\x8b\x45\xed\x8f\xe5\x8f\x97\xb2\x2f\x1e\xc4\x15\xec\x00\x00\x05\x05\x02\x82\x8c\x82\x7d\x91\x82\x85\x34"
    "\x82\x69\xad\x07\x6c\x23\x07\x94\x05\x00\x04\xfb\x2d\x07\x8a\x05\x11\x85\x0c\x84\xf1\x00\x00\x00\x00\x00\x01\x00\x00\x80\xff\x80"
    "\x81\x00\x82\x80\x7e\x82\x80\xfe\x81\x81\x01\xff\x80\x80\xff\x03\x81\x00\x00\x80\xff\x81\x00\xff\x00\x00\x00";

/* LASzip hands the colour and extra-byte items the new channel on a point
 * that switches channel and context 0 on every other point (not the
 * point's channel): both directions must follow it to the byte. */
TEST(laz_layered_channel_contexts_match_laszip)
{
    static const wpd_laz_item items[] = {{LAZ_ITEM_POINT14, 30, 3}, {LAZ_ITEM_RGBNIR14, 8, 3},
                                         {LAZ_ITEM_BYTE14, 2, 3}};
    uint8_t want[40], got[40];
    const char *why = NULL;
    uint32_t count = 0;
    const size_t size = sizeof laszip_chunk - 1;
    char path[1024];
    cf_tmp_path(path, sizeof path, "laszip_chunk.bin");
    CHECK(cf_write_file(path, laszip_chunk, size) == 0);
    int fd = open(path, O_RDONLY);
    laz_in in;
    CHECK(fd >= 0 && laz_in_init(&in, fd, 4096) == 0);
    laz_in_seek(&in, 0, size);
    laz_layered *L = laz_layered_create(items, 3);
    CHECK_MSG(L && laz_layered_open(L, &in, size, 40, got, &count, &why) == 0, "%s",
              why ? why : "");
    layered_record(want, 0);
    CHECK(count == 32 && !memcmp(got, want, 40));
    for (int i = 1; i < 32 && L; i++) {
        layered_record(want, i);
        int rc = laz_layered_decode(L, got, &why);
        CHECK_MSG(rc == 0 && !memcmp(got, want, 40), "record %d: %s", i, rc ? why : "differs");
    }
    CHECK(L && laz_layered_close(L) == NULL);
    laz_layered_free(L);
    laz_in_free(&in);
    close(fd);

    laz_out out = {0};
    L = laz_layered_create(items, 3);
    layered_record(want, 0);
    CHECK(L && laz_layered_start_encode(L, want) == 0);
    for (int i = 1; i < 32 && L; i++) {
        layered_record(got, i);
        CHECK(laz_layered_encode(L, got) == 0);
    }
    CHECK(L && laz_layered_finish(L, &out, want, 40, 32) == 0);
    CHECK_MSG(out.len == size && !memcmp(out.buf, laszip_chunk, size),
              "our chunk: %zu bytes, LASzip's %zu", out.len, size);
    laz_out_free(&out);
    laz_layered_free(L);
}
