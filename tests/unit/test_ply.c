/* test_ply.c - the PLY reader and writer through the public API: real files
 * from ../shared/data, synthetic files in every encoding and type, error
 * cases, seeking, write/read round trips and a throughput figure. */
#include "harness.h"

#include "io/reader.h"
#include "io/writer.h"

#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

/* ------------------------------------------------------------------ helpers */

static void tmp_path(char *out, size_t size, const char *name)
{
    snprintf(out, size, "%s/%s", test_tmp_dir(), name);
}

static int write_bytes(const char *path, const void *data, size_t len)
{
    FILE *f = fopen(path, "wb");
    if (!f)
        return -1;
    size_t n = fwrite(data, 1, len, f);
    return fclose(f) == 0 && n == len ? 0 : -1;
}

/* All points of a file: concatenated records and coordinates. */
typedef struct cloud {
    size_t n;
    uint32_t record_size;
    uint8_t *records;
    double *xyz;
    uint64_t dropped;
} cloud;

static void cloud_free(cloud *c)
{
    free(c->records);
    free(c->xyz);
    memset(c, 0, sizeof *c);
}

/* Reads every point of an open reader in batches of batch_cap. Returns 0,
 * or -1 with err set. */
static int read_all_from(wpd_reader *r, cloud *c, size_t batch_cap, wpd_error *err)
{
    const wpd_header *h = wpd_reader_header(r);
    memset(c, 0, sizeof *c);
    c->record_size = h->schema.record_size;
    wpd_batch b;
    if (wpd_batch_init(&b, batch_cap, c->record_size))
        return -1;
    size_t cap = 0;
    int rc = 0;
    for (;;) {
        long n = wpd_reader_read(r, &b, err);
        if (n < 0) {
            rc = -1;
            break;
        }
        if (n == 0)
            break;
        if (c->n + (size_t)n > cap) {
            cap = (c->n + (size_t)n) * 2;
            c->records = realloc(c->records, cap * c->record_size);
            c->xyz = realloc(c->xyz, cap * 3 * sizeof(double));
        }
        memcpy(c->records + c->n * c->record_size, b.records, (size_t)n * c->record_size);
        memcpy(c->xyz + 3 * c->n, b.xyz, (size_t)n * 3 * sizeof(double));
        c->n += (size_t)n;
    }
    c->dropped = wpd_reader_dropped(r);
    wpd_batch_free(&b);
    return rc;
}

/* Opens path and reads every point. Returns 0, or -1 with err set. */
static int read_all(const char *path, cloud *c, wpd_error *err)
{
    memset(c, 0, sizeof *c);
    wpd_reader *r = wpd_reader_open(path, err);
    if (!r)
        return -1;
    int rc = read_all_from(r, c, 1000, err);
    wpd_reader_close(r);
    return rc;
}

static int clouds_equal(const cloud *a, const cloud *b)
{
    return a->n == b->n && a->record_size == b->record_size &&
           !memcmp(a->records, b->records, a->n * a->record_size) &&
           !memcmp(a->xyz, b->xyz, a->n * 3 * sizeof(double));
}

/* Expects opening (or, if it opens, reading) path to fail with a message
 * that starts with the path and contains want. */
static int fails_with(const char *path, const char *want, char *msg, size_t msg_size)
{
    wpd_error err;
    wpd_error_clear(&err);
    cloud c;
    int rc = read_all(path, &c, &err);
    cloud_free(&c);
    snprintf(msg, msg_size, "%s", err.msg);
    return rc < 0 && !strncmp(err.msg, path, strlen(path)) && strstr(err.msg, want) != NULL;
}

/* ------------------------------------------------------------------ shared files */

/* Calls fn for every .ply file listed in <data>/<folder>/MANIFEST.tsv with
 * its manifest point count. */
static void for_each_manifest_ply(const char *folder, int *failures_,
                                  void (*fn)(const char *path, const char *file,
                                             uint64_t count, int *failures_))
{
    const char *data = test_data_dir();
    if (!data)
        return;
    char manifest[512];
    snprintf(manifest, sizeof manifest, "%s/%s/MANIFEST.tsv", data, folder);
    FILE *f = fopen(manifest, "r");
    if (!f)
        return;
    char line[8192];
    int files = 0;
    while (fgets(line, sizeof line, f)) {
        char *cols[8] = {0};
        int n = 0;
        for (char *p = line; n < 8 && p; n++) {
            cols[n] = p;
            p = strchr(p, '\t');
            if (p)
                *p++ = '\0';
        }
        size_t len = strlen(cols[0]);
        if (n < 7 || len < 4 || strcmp(cols[0] + len - 4, ".ply"))
            continue;
        char path[1024];
        snprintf(path, sizeof path, "%s/%s/%s", data, folder, cols[0]);
        fn(path, cols[0], strtoull(cols[6], NULL, 10), failures_);
        files++;
    }
    fclose(f);
    CHECK_MSG(files > 0, "no PLY file listed in %s", manifest);
}

static void check_shared_file(const char *path, const char *file, uint64_t count, int *failures_)
{
    wpd_error err;
    cloud c;
    wpd_reader *r = wpd_reader_open(path, &err);
    CHECK_MSG(r != NULL, "%s", err.msg);
    if (!r)
        return;
    const wpd_header *h = wpd_reader_header(r);
    CHECK(h->format == WPD_FMT_PLY);
    CHECK_MSG(h->point_count == count, "%s: header %llu, manifest %llu", file,
              (unsigned long long)h->point_count, (unsigned long long)count);
    CHECK(h->schema.dim_x >= 0 && h->schema.dim_y >= 0);
    CHECK(strcmp(h->ply.elements[h->ply.vertex_element].name, "vertex") == 0);
    int rc = read_all_from(r, &c, 777, &err);
    CHECK_MSG(rc == 0, "%s", err.msg);
    uint64_t want_dropped = strstr(file, "office1_organized_nan") ? 52744 : 0;
    CHECK_MSG(c.n == count - want_dropped && c.dropped == want_dropped,
              "%s: read %zu, dropped %llu, manifest %llu", file, c.n,
              (unsigned long long)c.dropped, (unsigned long long)count);
    int finite = 1;
    for (size_t i = 0; i < 3 * c.n; i++)
        finite &= isfinite(c.xyz[i]) != 0;
    CHECK_MSG(finite, "%s: non-finite coordinate delivered", file);
    /* The decoded coordinates match the record fields. */
    const wpd_schema *s = &h->schema;
    int same = 1;
    for (size_t i = 0; i < c.n; i++) {
        const uint8_t *rec = c.records + i * c.record_size;
        same &= wpd_dim_get(&s->dims[s->dim_x], rec) == c.xyz[3 * i];
        same &= wpd_dim_get(&s->dims[s->dim_y], rec) == c.xyz[3 * i + 1];
        same &= (s->dim_z < 0 ? 0.0 : wpd_dim_get(&s->dims[s->dim_z], rec)) == c.xyz[3 * i + 2];
    }
    CHECK_MSG(same, "%s: xyz differ from the record fields", file);
    cloud_free(&c);
    wpd_reader_close(r);
}

TEST(ply_shared_files_read_manifest_counts)
{
    for_each_manifest_ply("ply", failures_, check_shared_file);
    for_each_manifest_ply("scans", failures_, check_shared_file);
}

TEST(ply_shared_platonic_shelf_endianness)
{
    const char *data = test_data_dir();
    if (!data)
        return;
    char le[512], be[512];
    snprintf(le, sizeof le, "%s/ply/happly_platonic_shelf.ply", data);
    snprintf(be, sizeof be, "%s/ply/happly_platonic_shelf_big_endian.ply", data);
    cloud a, b;
    wpd_error err;
    CHECK_MSG(read_all(le, &a, &err) == 0, "%s", err.msg);
    CHECK_MSG(read_all(be, &b, &err) == 0, "%s", err.msg);
    CHECK(a.n == 50 && clouds_equal(&a, &b));
    cloud_free(&a);
    cloud_free(&b);
}

TEST(ply_shared_sized_dims_without_z)
{
    const char *data = test_data_dir();
    if (!data)
        return;
    char path[512];
    snprintf(path, sizeof path, "%s/ply/pdal_sized_dims.ply", data);
    wpd_error err;
    wpd_reader *r = wpd_reader_open(path, &err);
    CHECK_MSG(r != NULL, "%s", err.msg);
    if (!r)
        return;
    const wpd_header *h = wpd_reader_header(r);
    CHECK(h->schema.dim_z == -1 && h->schema.ndims == 4 && h->schema.record_size == 15);
    CHECK(h->schema.dims[0].type == WPD_I8 && h->schema.dims[1].type == WPD_U16);
    CHECK(h->ply.ncomments == 1 && !strcmp(h->ply.comments[0], "Generated by PDAL"));
    cloud c;
    CHECK(read_all_from(r, &c, 10, &err) == 0);
    CHECK(c.n == 1 && c.xyz[2] == 0.0);
    cloud_free(&c);
    wpd_reader_close(r);
}

TEST(ply_shared_bad_files_fail_cleanly)
{
    const char *data = test_data_dir();
    if (!data)
        return;
    static const struct { const char *file, *want; } cases[] = {
        {"pdal_no_vertex.ply", "no 'vertex' element"},
        {"assimp_crash-30d6d0f7.ply", "PLY header"},
        {"assimp_empty.ply", "empty"},
        {"stanford_bun000_headerless.ply", "not a"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        char path[512], msg[WPD_ERRMSG_MAX];
        snprintf(path, sizeof path, "%s/bad/%s", data, cases[i].file);
        CHECK_MSG(fails_with(path, cases[i].want, msg, sizeof msg), "%s: got '%s'",
                  cases[i].file, msg);
    }
}

/* ------------------------------------------------------------------ synthetic files */

enum { ENC_ASCII, ENC_LE, ENC_BE };
static const char *const enc_names[] = {"ascii", "binary_little_endian", "binary_big_endian"};

/* A vertex property of the synthetic files, under both type names. */
typedef struct synth_prop {
    const char *name, *type, *alias;
    wpd_type t;
} synth_prop;

static const synth_prop synth_props[] = {
    {"x", "double", "float64", WPD_F64}, {"y", "float", "float32", WPD_F32},
    {"z", "int", "int32", WPD_I32},      {"a_i8", "char", "int8", WPD_I8},
    {"a_u8", "uchar", "uint8", WPD_U8},  {"a_i16", "short", "int16", WPD_I16},
    {"a_u16", "ushort", "uint16", WPD_U16}, {"a_i32", "int", "int32", WPD_I32},
    {"a_u32", "uint", "uint32", WPD_U32}, {"a_i64", "int64", "int64", WPD_I64},
    {"a_u64", "uint64", "uint64", WPD_U64}, {"a_f32", "float32", "float", WPD_F32},
    {"a_f64", "float64", "double", WPD_F64},
};
#define NSYNTH (sizeof synth_props / sizeof synth_props[0])

typedef struct synth_opts {
    int enc;
    int crlf;          /* header lines end in CRLF */
    int vertex_list;   /* a list property inside the vertex element */
    int elems_before;  /* face and camera elements before the vertex element */
    int aliases;       /* sized type names (int8 ...) */
    size_t nverts;
} synth_opts;

static size_t type_bytes(wpd_type t)
{
    static const size_t s[] = {1, 1, 2, 2, 4, 4, 8, 8, 4, 8};
    return s[t];
}

/* The value of property k of vertex i as little-endian bytes. Covers each
 * type's extremes (vertices 0..2) and a spread of values. */
static void synth_value(size_t i, size_t k, wpd_type t, uint8_t *out)
{
    uint64_t mix = (uint64_t)i * 0x9E3779B97F4A7C15ull + (uint64_t)k * 0xBF58476D1CE4E5B9ull;
    mix ^= mix >> 29;
    if (t == WPD_F32) {
        float v = i == 0 ? -FLT_MAX : i == 1 ? FLT_MIN : i == 2 ? 1e-45f
                : (float)((double)(int64_t)(mix % 2000001) / 1000.0 - 1000.0) / 7.0f;
        memcpy(out, &v, 4);
    } else if (t == WPD_F64) {
        double v = i == 0 ? -DBL_MAX : i == 1 ? DBL_MIN : i == 2 ? 4.9406564584124654e-324
                 : ((double)(int64_t)(mix % 20000001) - 1e7) / 3.0 * 1e-3 + 1e6;
        memcpy(out, &v, 8);
    } else {
        size_t n = type_bytes(t);
        int is_signed = t == WPD_I8 || t == WPD_I16 || t == WPD_I32 || t == WPD_I64;
        uint64_t v = mix;
        if (i == 0) /* minimum */
            v = is_signed ? (uint64_t)1 << (8 * n - 1) : 0;
        else if (i == 1) /* maximum */
            v = is_signed ? ((uint64_t)1 << (8 * n - 1)) - 1 : ~(uint64_t)0;
        memcpy(out, &v, n); /* low bytes: little-endian host */
    }
}

/* Formats a little-endian value as ascii (floats with enough digits to
 * round-trip). */
static void format_synth(FILE *f, wpd_type t, const uint8_t *v)
{
    switch (t) {
    case WPD_F32: { float x; memcpy(&x, v, 4); fprintf(f, "%.9g", (double)x); break; }
    case WPD_F64: { double x; memcpy(&x, v, 8); fprintf(f, "%.17g", x); break; }
    case WPD_I8: fprintf(f, "%d", (int8_t)v[0]); break;
    case WPD_U8: fprintf(f, "%u", v[0]); break;
    case WPD_I16: { int16_t x; memcpy(&x, v, 2); fprintf(f, "%d", x); break; }
    case WPD_U16: { uint16_t x; memcpy(&x, v, 2); fprintf(f, "%u", x); break; }
    case WPD_I32: { int32_t x; memcpy(&x, v, 4); fprintf(f, "%d", x); break; }
    case WPD_U32: { uint32_t x; memcpy(&x, v, 4); fprintf(f, "%u", x); break; }
    case WPD_I64: { int64_t x; memcpy(&x, v, 8); fprintf(f, "%lld", (long long)x); break; }
    default: { uint64_t x; memcpy(&x, v, 8); fprintf(f, "%llu", (unsigned long long)x); break; }
    }
}

static void put_bin(FILE *f, const void *le, size_t n, int be)
{
    const uint8_t *p = le;
    for (size_t i = 0; i < n; i++)
        fputc(p[be ? n - 1 - i : i], f);
}

/* Writes a synthetic file; fills *expected (packed LE records) and returns
 * the record size, or 0 on failure. */
static size_t make_synth(const char *path, const synth_opts *o, uint8_t **expected)
{
    FILE *f = fopen(path, "wb");
    if (!f)
        return 0;
    const char *eol = o->crlf ? "\r\n" : "\n";
    int be = o->enc == ENC_BE;
    fprintf(f, "ply%sformat %s 1.0%s", eol, enc_names[o->enc], eol);
    fprintf(f, "comment first comment%sobj_info some info%scomment   second   %s", eol, eol, eol);
    size_t nfaces = 5;
    if (o->elems_before) {
        fprintf(f, "element face %zu%sproperty list uchar int vertex_indices%s", nfaces, eol, eol);
        fprintf(f, "property ushort flags%s", eol);
        fprintf(f, "element camera 1%sproperty float focal%sproperty int viewport%s", eol, eol, eol);
    }
    fprintf(f, "element   vertex   %zu %s", o->nverts, eol);
    size_t rs = 0;
    for (size_t k = 0; k < NSYNTH; k++) {
        fprintf(f, "property %s %s%s", o->aliases ? synth_props[k].alias : synth_props[k].type,
                synth_props[k].name, eol);
        if (o->vertex_list && k == 4)
            fprintf(f, "property list uint8 float32 vlist%s", eol);
        rs += type_bytes(synth_props[k].t);
    }
    fprintf(f, "element tail 2%sproperty list uchar uint idx%send_header%s", eol, eol, eol);
    if (o->elems_before) {
        for (size_t i = 0; i < nfaces; i++) {
            uint8_t cnt = (uint8_t)(i % 4);
            uint16_t flags = (uint16_t)(1000 + i);
            if (o->enc == ENC_ASCII) {
                fprintf(f, "%u", cnt);
                for (unsigned j = 0; j < cnt; j++)
                    fprintf(f, " %u", j);
                fprintf(f, " %u\n", flags);
            } else {
                put_bin(f, &cnt, 1, be);
                for (int32_t j = 0; j < cnt; j++)
                    put_bin(f, &j, 4, be);
                put_bin(f, &flags, 2, be);
            }
        }
        float focal = 2.5f;
        int32_t viewport = 640;
        if (o->enc == ENC_ASCII) {
            fprintf(f, "2.5 640\n");
        } else {
            put_bin(f, &focal, 4, be);
            put_bin(f, &viewport, 4, be);
        }
    }
    *expected = malloc(rs * (o->nverts ? o->nverts : 1));
    for (size_t i = 0; i < o->nverts; i++) {
        uint8_t *rec = *expected + i * rs;
        size_t off = 0;
        for (size_t k = 0; k < NSYNTH; k++) {
            wpd_type t = synth_props[k].t;
            synth_value(i, k, t, rec + off);
            if (o->enc == ENC_ASCII) {
                if (k)
                    fputc(' ', f);
                format_synth(f, t, rec + off);
            } else {
                put_bin(f, rec + off, type_bytes(t), be);
            }
            if (o->vertex_list && k == 4) {
                uint8_t cnt = (uint8_t)(i % 3);
                if (o->enc == ENC_ASCII) {
                    fprintf(f, " %u", cnt);
                    for (unsigned j = 0; j < cnt; j++)
                        fprintf(f, " %g", j * 0.5);
                } else {
                    put_bin(f, &cnt, 1, be);
                    for (unsigned j = 0; j < cnt; j++) {
                        float v = (float)j * 0.5f;
                        put_bin(f, &v, 4, be);
                    }
                }
            }
            off += type_bytes(t);
        }
        if (o->enc == ENC_ASCII)
            fputs(i % 2 ? "\r\n" : "\n", f);
    }
    /* The tail element (after the vertex element) is never read. */
    fputs(o->enc == ENC_ASCII ? "2 1 2\n0\n" : "\002garbage", f);
    fclose(f);
    return rs;
}

static void check_synth(const synth_opts *o, int *failures_)
{
    char path[512];
    snprintf(path, sizeof path, "%s/synth_%d_%d_%d_%d_%d_%zu.ply", test_tmp_dir(), o->enc, o->crlf,
             o->vertex_list, o->elems_before, o->aliases, o->nverts);
    uint8_t *expected = NULL;
    size_t rs = make_synth(path, o, &expected);
    CHECK(rs > 0);
    wpd_error err;
    wpd_reader *r = wpd_reader_open(path, &err);
    CHECK_MSG(r != NULL, "%s", err.msg);
    if (!r) {
        free(expected);
        return;
    }
    const wpd_header *h = wpd_reader_header(r);
    CHECK(h->schema.record_size == rs && h->schema.ndims == NSYNTH);
    CHECK(h->point_count == o->nverts);
    CHECK(h->ply.encoding == (wpd_ply_encoding)o->enc);
    CHECK(h->ply.ncomments == 2 && !strcmp(h->ply.comments[0], "first comment") &&
          !strcmp(h->ply.comments[1], "  second"));
    CHECK(h->ply.nobj_info == 1 && !strcmp(h->ply.obj_info[0], "some info"));
    CHECK(h->ply.nelements == (o->elems_before ? 4u : 2u));
    CHECK(h->ply.vertex_element == (o->elems_before ? 2u : 0u));
    for (size_t k = 0; k < NSYNTH; k++)
        CHECK(!strcmp(h->schema.dims[k].name, synth_props[k].name) &&
              h->schema.dims[k].type == synth_props[k].t);
    CHECK(wpd_reader_can_seek(r) == (o->enc != ENC_ASCII && !o->vertex_list));
    cloud c;
    CHECK_MSG(read_all_from(r, &c, 7, &err) == 0, "%s", err.msg);
    CHECK_MSG(c.n == o->nverts, "read %zu of %zu", c.n, o->nverts);
    if (c.n == o->nverts && c.n) {
        CHECK_MSG(!memcmp(c.records, expected, rs * c.n), "%s: records differ", path);
        int same = 1;
        for (size_t i = 0; i < c.n; i++) {
            double x, z;
            float y;
            int32_t zi;
            memcpy(&x, expected + i * rs, 8);
            memcpy(&y, expected + i * rs + 8, 4);
            memcpy(&zi, expected + i * rs + 12, 4);
            z = zi;
            same &= c.xyz[3 * i] == x && c.xyz[3 * i + 1] == (double)y && c.xyz[3 * i + 2] == z;
        }
        CHECK_MSG(same, "%s: xyz differ", path);
    }
    cloud_free(&c);
    wpd_reader_close(r);
    free(expected);
}

TEST(ply_synthetic_all_encodings_and_types)
{
    for (int enc = 0; enc < 3; enc++)
        for (int variant = 0; variant < 8; variant++) {
            synth_opts o = {.enc = enc, .crlf = variant & 1, .vertex_list = (variant >> 1) & 1,
                            .elems_before = (variant >> 2) & 1, .aliases = variant & 1,
                            .nverts = 23};
            check_synth(&o, failures_);
        }
    synth_opts empty = {.enc = ENC_LE, .nverts = 0};
    check_synth(&empty, failures_);
    synth_opts big = {.enc = ENC_ASCII, .elems_before = 1, .nverts = 30000};
    check_synth(&big, failures_); /* tokens straddle the 1 MiB buffer */
    big.enc = ENC_BE;
    big.vertex_list = 1;
    check_synth(&big, failures_);
}

TEST(ply_seek_binary)
{
    for (int enc = ENC_LE; enc <= ENC_BE; enc++) {
        char path[512];
        snprintf(path, sizeof path, "%s/seek_%d.ply", test_tmp_dir(), enc);
        synth_opts o = {.enc = enc, .elems_before = 1, .nverts = 5000};
        uint8_t *expected;
        size_t rs = make_synth(path, &o, &expected);
        wpd_error err;
        wpd_reader *r = wpd_reader_open(path, &err);
        CHECK_MSG(r != NULL, "%s", err.msg);
        if (!r) {
            free(expected);
            continue;
        }
        CHECK(wpd_reader_can_seek(r));
        static const uint64_t starts[] = {4321, 0, 4999, 5000, 17};
        for (size_t s = 0; s < sizeof starts / sizeof starts[0]; s++) {
            CHECK(wpd_reader_seek(r, starts[s], &err) == 0);
            wpd_batch b;
            wpd_batch_init(&b, 100, (uint32_t)rs);
            long n = wpd_reader_read(r, &b, &err);
            long want = starts[s] + 100 > 5000 ? (long)(5000 - starts[s]) : 100;
            CHECK_MSG(n == want, "seek %llu: read %ld", (unsigned long long)starts[s], n);
            if (n > 0)
                CHECK(!memcmp(b.records, expected + starts[s] * rs, (size_t)n * rs));
            wpd_batch_free(&b);
        }
        CHECK(wpd_reader_seek(r, 5001, &err) < 0);
        wpd_reader_close(r);
        free(expected);
    }
}

/* Copies src into dst without the tail element and without the end of the
 * last vertex: ascii loses the whole last line, binary its last 3 bytes. */
static void truncate_copy(const char *src, const char *dst, int ascii)
{
    FILE *f = fopen(src, "rb");
    fseek(f, 0, SEEK_END);
    long size = ftell(f);
    fseek(f, 0, SEEK_SET);
    char *buf = malloc((size_t)size);
    size_t len = fread(buf, 1, (size_t)size, f);
    fclose(f);
    len -= 8; /* the tail element: "2 1 2\n0\n" or "\002garbage" */
    if (ascii) {
        while (len && (buf[len - 1] == '\n' || buf[len - 1] == '\r'))
            len--;
        while (len && buf[len - 1] != '\n')
            len--;
    } else {
        len -= 3;
    }
    write_bytes(dst, buf, len);
    free(buf);
}

TEST(ply_truncated_body_is_an_error)
{
    for (int enc = 0; enc < 3; enc++)
        for (int vlist = 0; vlist < 2; vlist++) {
            char full[512], cut[512], msg[WPD_ERRMSG_MAX];
            snprintf(full, sizeof full, "%s/trunc_full_%d_%d.ply", test_tmp_dir(), enc, vlist);
            snprintf(cut, sizeof cut, "%s/trunc_cut_%d_%d.ply", test_tmp_dir(), enc, vlist);
            synth_opts o = {.enc = enc, .vertex_list = vlist, .nverts = 40};
            uint8_t *expected;
            make_synth(full, &o, &expected);
            free(expected);
            truncate_copy(full, cut, enc == ENC_ASCII);
            CHECK_MSG(fails_with(cut, "file ends after 39 of 40 vertices", msg, sizeof msg),
                      "enc %d list %d: got '%s'", enc, vlist, msg);
        }
}

TEST(ply_header_errors)
{
    static const struct { const char *text, *want; } cases[] = {
        {"ply\nformat binary_little_endian 1.0\nelement vertex 1000000000000\nproperty float x\n"
         "property float y\nproperty float z\nend_header\n0123456789ab",
         "1000000000000"},
        {"ply\nformat binary_little_endian 1.0\nelement face 18446744073709551615\n"
         "property list uchar int idx\nelement vertex 1\nproperty float x\nproperty float y\n"
         "end_header\n01234567",
         "element 'face' count 18446744073709551615"},
        {"ply\nformat ascii 1.0\nelement vertex 100\nproperty float x\nproperty float y\n"
         "end_header\n1 2\n", "element 'vertex' count 100"},
        {"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n1 2\n",
         "unknown keyword '1'"},
        {"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n",
         "no end_header"},
        {"ply\nelement vertex 1\nproperty float x\nproperty float y\nend_header\n1 2\n",
         "no format line"},
        {"ply\nformat ascii 1.0\nelement face 0\nend_header\n", "no 'vertex' element"},
        {"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float z\n"
         "end_header\n1 2\n", "no 'y' property"},
        {"ply\nformat ascii 1.0\nelement vertex 1\nproperty flaot x\nend_header\n",
         "unknown property type 'flaot'"},
        {"ply\nformat ascii 2.0\nend_header\n", "unsupported PLY version"},
        {"ply\nformat binary_middle_endian 1.0\nend_header\n", "unknown format"},
        {"ply\nformat ascii 1.0\nproperty float x\nend_header\n", "property before any element"},
        {"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
         "property float x\nend_header\n1 2 3\n", "'x' appears twice"},
        {"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty list uchar float y\n"
         "end_header\n1 1 2\n", "'y' is a list"},
        {"ply\nformat ascii 1.0\nelement vertex 1\nproperty list float uchar idx\n"
         "property float x\nproperty float y\nend_header\n", "not an integer type"},
        {"ply\nformat ascii 1.0\nelement vertex -5\nend_header\n", "bad element count"},
        {"plyx\nformat ascii 1.0\nend_header\n", "no 'ply' magic line"},
        {"ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty uchar y\n"
         "end_header\n1 2\n1 256\n", "vertex 1 property 'y': value '256' out of range for uchar"},
        {"ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty char y\n"
         "end_header\n1 2\n1 -129\n", "out of range for char"},
        {"ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty uint y\n"
         "end_header\n1 2\n1 -1\n", "out of range for uint"},
        {"ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
         "end_header\n1 2\n1 2x\n", "vertex 1 property 'y': '2x' is not a valid float"},
        {"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty int y\n"
         "end_header\n1 2.5\n", "'2.5' is not a valid int"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        char path[512], msg[WPD_ERRMSG_MAX];
        snprintf(path, sizeof path, "%s/hdr_err_%zu.ply", test_tmp_dir(), i);
        write_bytes(path, cases[i].text, strlen(cases[i].text));
        CHECK_MSG(fails_with(path, cases[i].want, msg, sizeof msg), "case %zu: got '%s'", i, msg);
    }
    /* A header longer than the limit. */
    size_t big = (1u << 20) + 100;
    char *text = malloc(big);
    memset(text, ' ', big);
    memcpy(text, "ply\nformat ascii 1.0\n", 21);
    for (size_t i = 100; i < big; i += 100)
        memcpy(text + i - 9, "\ncomment ", 9);
    char path[512], msg[WPD_ERRMSG_MAX];
    tmp_path(path, sizeof path, "hdr_huge.ply");
    write_bytes(path, text, big);
    free(text);
    CHECK_MSG(fails_with(path, "no end_header line within", msg, sizeof msg), "got '%s'", msg);
}

TEST(ply_ascii_numbers)
{
    static const char *const tokens[] = {
        "0", "-0", "+3.5", "1e-5", "0.1", "1E+2", ".5", "5.", "-123.456e-7",
        "123456789012345678901234567890", "0.30000000000000004", "1e23", "9007199254740993",
        "2.2250738585072011e-308", "4.9e-324", "1e-400", "0x1p-3", "00012.5000", "-.0e0",
        "1.7976931348623157e308", "3.14159265358979323846264338327950288",
    };
    const size_t nt = sizeof tokens / sizeof tokens[0];
    char path[512];
    tmp_path(path, sizeof path, "numbers.ply");
    FILE *f = fopen(path, "w");
    fprintf(f, "ply\nformat ascii 1.0\nelement vertex %zu\nproperty double x\n"
               "property double y\nproperty float z\nproperty short s\nend_header\n", nt + 4);
    for (size_t i = 0; i < nt; i++) /* z is a float: only tokens within its range */
        fprintf(f, "%s\t%s   %s %s\n", tokens[i], tokens[i],
                fabs(strtod(tokens[i], NULL)) <= FLT_MAX ? tokens[i] : "1", i % 2 ? "-7" : "3.0");
    fprintf(f, "nan 1 2 0\n1 -inf 2 0\n1 2 NaN 0\n1 2 infinity 0\n");
    fclose(f);
    cloud c;
    wpd_error err;
    CHECK_MSG(read_all(path, &c, &err) == 0, "%s", err.msg);
    CHECK(c.n == nt && c.dropped == 4);
    for (size_t i = 0; i < c.n && i < nt; i++) {
        double want = strtod(tokens[i], NULL);
        double got_x, got_y;
        float got_z;
        int16_t s;
        memcpy(&got_x, c.records + i * c.record_size, 8);
        memcpy(&got_y, c.records + i * c.record_size + 8, 8);
        memcpy(&got_z, c.records + i * c.record_size + 16, 4);
        memcpy(&s, c.records + i * c.record_size + 20, 2);
        CHECK_MSG(!memcmp(&got_x, &want, 8) && !memcmp(&got_y, &want, 8),
                  "token %s: got %.17g want %.17g", tokens[i], got_x, want);
        float want_z = fabs(want) <= FLT_MAX ? (float)want : 1.0f;
        CHECK_MSG(got_z == want_z, "token %s: float %.9g", tokens[i], (double)got_z);
        CHECK(s == (i % 2 ? -7 : 3));
        CHECK(c.xyz[3 * i] == want && c.xyz[3 * i + 2] == (double)want_z);
    }
    cloud_free(&c);
}

/* ------------------------------------------------------------------ writer */

/* Reads src, writes it as PLY (binary or ascii), reads that back and checks
 * records, coordinates, comments and obj_info. */
static void check_round_trip(const char *src, int ascii, int *failures_)
{
    wpd_error err;
    wpd_reader *r = wpd_reader_open(src, &err);
    CHECK_MSG(r != NULL, "%s", err.msg);
    if (!r)
        return;
    cloud a, b;
    CHECK_MSG(read_all_from(r, &a, 999, &err) == 0, "%s", err.msg);
    const wpd_header *h = wpd_reader_header(r);
    char out[512];
    const char *base = strrchr(src, '/') ? strrchr(src, '/') + 1 : src;
    snprintf(out, sizeof out, "%s/rt_%d_%s", test_tmp_dir(), ascii, base);
    wpd_write_options opt = {.ply_ascii = ascii, .overwrite = 1};
    wpd_writer *w = wpd_writer_open(out, h, &opt, &err);
    CHECK_MSG(w != NULL, "%s", err.msg);
    if (!w) {
        cloud_free(&a);
        wpd_reader_close(r);
        return;
    }
    /* Write in uneven batches. */
    wpd_batch batch;
    wpd_batch_init(&batch, 1234, a.record_size);
    for (size_t i = 0; i < a.n;) {
        size_t m = a.n - i < 1234 ? a.n - i : 1234;
        memcpy(batch.records, a.records + i * a.record_size, m * a.record_size);
        memcpy(batch.xyz, a.xyz + 3 * i, m * 3 * sizeof(double));
        batch.n = m;
        CHECK_MSG(wpd_writer_write(w, &batch, &err) == 0, "%s", err.msg);
        i += m;
    }
    CHECK(!memcmp(batch.records, a.records + (a.n - batch.n) * a.record_size,
                  batch.n * a.record_size)); /* the caller's batch is untouched */
    wpd_batch_free(&batch);
    CHECK(wpd_writer_count(w) == a.n);
    CHECK_MSG(wpd_writer_close(w, &err) == 0, "%s", err.msg);
    wpd_reader *r2 = wpd_reader_open(out, &err);
    CHECK_MSG(r2 != NULL, "%s", err.msg);
    if (r2) {
        const wpd_header *h2 = wpd_reader_header(r2);
        CHECK(h2->ply.encoding == (ascii ? WPD_PLY_ASCII : WPD_PLY_BINARY_LE));
        CHECK(h2->point_count == a.n && h2->ply.nelements == 1);
        CHECK(h2->schema.ndims == h->schema.ndims && h2->schema.dim_z == h->schema.dim_z);
        /* Comments carried over (the writer's blank padding comment aside). */
        uint32_t k = 0;
        for (uint32_t i = 0; i < h2->ply.ncomments; i++) {
            if (!h2->ply.comments[i][0])
                continue;
            CHECK_MSG(k < h->ply.ncomments && !strcmp(h2->ply.comments[i], h->ply.comments[k]),
                      "comment %u", i);
            k++;
        }
        CHECK(k == h->ply.ncomments);
        CHECK(h2->ply.nobj_info == h->ply.nobj_info);
        for (uint32_t i = 0; i < h2->ply.nobj_info && i < h->ply.nobj_info; i++)
            CHECK(!strcmp(h2->ply.obj_info[i], h->ply.obj_info[i]));
        CHECK_MSG(read_all_from(r2, &b, 4096, &err) == 0, "%s", err.msg);
        CHECK_MSG(clouds_equal(&a, &b), "%s (%s): round trip differs", src,
                  ascii ? "ascii" : "binary");
        cloud_free(&b);
        wpd_reader_close(r2);
    }
    cloud_free(&a);
    wpd_reader_close(r);
}

TEST(ply_writer_round_trip)
{
    char path[512];
    snprintf(path, sizeof path, "%s/rt_synth.ply", test_tmp_dir());
    synth_opts o = {.enc = ENC_BE, .vertex_list = 1, .elems_before = 1, .nverts = 3000};
    uint8_t *expected;
    make_synth(path, &o, &expected);
    free(expected);
    check_round_trip(path, 0, failures_);
    check_round_trip(path, 1, failures_);
    const char *data = test_data_dir();
    if (!data)
        return;
    static const char *const files[] = {
        "ply/pyntcloud_diamond.ply", "ply/potree_ripple_ascii.ply", "ply/pdal_sized_dims.ply",
        "ply/pdal_text_extradim.ply", "ply/happly_platonic_shelf_big_endian.ply",
        "scans/pcl_office1_organized_nan.ply",
    };
    for (size_t i = 0; i < sizeof files / sizeof files[0]; i++) {
        snprintf(path, sizeof path, "%s/%s", data, files[i]);
        check_round_trip(path, 0, failures_);
        check_round_trip(path, 1, failures_);
    }
}

/* Reads the header text of a file (up to end_header). */
static size_t header_text(const char *path, char *out, size_t size)
{
    FILE *f = fopen(path, "rb");
    size_t n = fread(out, 1, size - 1, f);
    fclose(f);
    out[n] = '\0';
    char *end = strstr(out, "end_header\n");
    return end ? (size_t)(end - out) + 11 : 0;
}

/* A schema whose dims are not in offset order (and have a gap): the writer
 * packs them in dim order. Also checks the header patching. */
TEST(ply_writer_unordered_dims_and_header)
{
    wpd_header h;
    memset(&h, 0, sizeof h);
    h.format = WPD_FMT_PLY;
    wpd_schema *s = &h.schema;
    wpd_schema_add(s, "intensity", WPD_U16, 20);
    wpd_schema_add(s, "x", WPD_F64, 0);
    wpd_schema_add(s, "z", WPD_F32, 16);
    wpd_schema_add(s, "y", WPD_F64, 8);
    wpd_schema_add(s, "k", WPD_I8, 23);
    s->record_size = 24;
    s->dim_x = 1;
    s->dim_y = 3;
    s->dim_z = 2;
    char *comments[] = {"multi\nline", "   ", "plain"};
    h.ply.comments = comments;
    h.ply.ncomments = 3;
    for (int ascii = 0; ascii < 2; ascii++) {
        char path[512], empty_path[512];
        snprintf(path, sizeof path, "%s/unordered_%d.ply", test_tmp_dir(), ascii);
        snprintf(empty_path, sizeof empty_path, "%s/unordered_empty_%d.ply", test_tmp_dir(), ascii);
        wpd_write_options opt = {.ply_ascii = ascii, .overwrite = 1};
        wpd_error err;
        wpd_writer *w = wpd_writer_open(path, &h, &opt, &err);
        CHECK_MSG(w != NULL, "%s", err.msg);
        if (!w)
            continue;
        const size_t n = 12345;
        wpd_batch b;
        wpd_batch_init(&b, n, 24);
        for (size_t i = 0; i < n; i++) {
            uint8_t *rec = b.records + i * 24;
            memset(rec, 0xEE, 24);
            uint16_t in = (uint16_t)(i * 7);
            int8_t k = (int8_t)(i % 200 - 100);
            memcpy(rec + 20, &in, 2);
            memcpy(rec + 23, &k, 1);
            b.xyz[3 * i] = i * 0.25;
            b.xyz[3 * i + 1] = -1e6 + i;
            b.xyz[3 * i + 2] = i * 0.1;
        }
        b.n = n;
        CHECK_MSG(wpd_writer_write(w, &b, &err) == 0, "%s", err.msg);
        CHECK_MSG(wpd_writer_close(w, &err) == 0, "%s", err.msg);
        wpd_writer *we = wpd_writer_open(empty_path, &h, &opt, &err);
        CHECK(we && wpd_writer_close(we, &err) == 0);

        char hdr[4096], hdr_empty[4096];
        size_t len = header_text(path, hdr, sizeof hdr);
        size_t len_empty = header_text(empty_path, hdr_empty, sizeof hdr_empty);
        CHECK_MSG(len > 0 && len == len_empty, "header lengths %zu and %zu", len, len_empty);
        CHECK(strstr(hdr, "\nelement vertex 12345\n") && strstr(hdr_empty, "\nelement vertex 0\n"));
        CHECK(strstr(hdr, "\ncomment multi line\n") && strstr(hdr, "\ncomment plain\n"));
        CHECK(strstr(hdr, "property ushort intensity\nproperty double x\nproperty float z\n"
                          "property double y\nproperty char k\nend_header\n"));
        /* rply-style tokenising: every "comment" keyword is followed by a
         * blank before the end of its line. */
        for (const char *p = strstr(hdr, "\ncomment"); p; p = strstr(p + 1, "\ncomment"))
            CHECK(p[8] == ' ');

        cloud c;
        CHECK_MSG(read_all(path, &c, &err) == 0, "%s", err.msg);
        CHECK(c.n == n && c.record_size == 23);
        int same = 1;
        for (size_t i = 0; i < c.n; i++) {
            const uint8_t *rec = c.records + i * 23;
            uint16_t in;
            double x, y;
            float z;
            memcpy(&in, rec, 2);
            memcpy(&x, rec + 2, 8);
            memcpy(&z, rec + 10, 4);
            memcpy(&y, rec + 14, 8);
            same &= in == (uint16_t)(i * 7) && (int8_t)rec[22] == (int8_t)(i % 200 - 100);
            same &= x == i * 0.25 && y == -1e6 + i && z == (float)(i * 0.1);
            same &= c.xyz[3 * i + 2] == (double)(float)(i * 0.1);
        }
        CHECK_MSG(same, "ascii=%d: values differ", ascii);
        cloud_free(&c);
        wpd_batch_free(&b);
    }
}

TEST(ply_writer_refuses_bad_schemas)
{
    wpd_header h;
    memset(&h, 0, sizeof h);
    h.format = WPD_FMT_PLY;
    wpd_schema_add(&h.schema, "x", WPD_F32, 0);
    wpd_schema_add(&h.schema, "bad name", WPD_F32, 4);
    h.schema.record_size = 8;
    h.schema.dim_x = 0;
    h.schema.dim_y = -1;
    h.schema.dim_z = -1;
    char path[512];
    tmp_path(path, sizeof path, "refused.ply");
    wpd_write_options opt = {.overwrite = 1};
    wpd_error err;
    wpd_writer *w = wpd_writer_open(path, &h, &opt, &err);
    CHECK(w == NULL && strstr(err.msg, "needs x and y"));
    h.schema.dim_y = 1;
    w = wpd_writer_open(path, &h, &opt, &err);
    CHECK(w == NULL && strstr(err.msg, "not a valid PLY property name"));
    CHECK(access(path, F_OK) != 0); /* nothing left behind */
}
