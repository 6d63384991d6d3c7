/* test_laz.c - the LAZ reader through the public API: every LAZ file of
 * ../shared/data/laz against its decompressed twin (the manifest names
 * it), seeking by point index, and damaged files (truncated, corrupt
 * stream, corrupt chunk table, contradictory LASzip VLR). */
#include "harness.h"
#include "las_files.h"

#include "io/reader.h"
#include "io/record_cache.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

/* ------------------------------------------------------------ helpers */

/* Every point of path (batch_cap per read), or an error. */
static int read_file(const char *path, cf_cloud *c, size_t batch_cap, wpd_error *err)
{
    memset(c, 0, sizeof *c);
    wpd_reader *r = wpd_reader_open(path, err);
    if (!r)
        return -1;
    int rc = cf_read_all(r, c, batch_cap, err);
    wpd_reader_close(r);
    return rc;
}

static int same_records(const cf_cloud *a, const cf_cloud *b)
{
    return a->n == b->n && a->record_size == b->record_size &&
           (!a->n || !memcmp(a->records, b->records, a->n * a->record_size));
}

/* The LAZ point data record format and twin named by a manifest row of
 * laz/: "PDRF <n>" in the format column, "twin: <file>" in the notes. */
typedef struct laz_row {
    char file[256], twin[256];
    int pdrf;
} laz_row;

static int parse_row(char *line, laz_row *row)
{
    char *col[9] = {0};
    int n = 0;
    for (char *p = line; n < 9 && p; n++) {
        col[n] = p;
        p = strchr(p, '\t');
        if (p)
            *p++ = '\0';
    }
    if (n < 8 || strlen(col[0]) < 5 || strcmp(col[0] + strlen(col[0]) - 4, ".laz"))
        return 0;
    snprintf(row->file, sizeof row->file, "%s", col[0]);
    const char *f = strstr(col[5], "PDRF ");
    row->pdrf = f ? atoi(f + 5) : -1;
    row->twin[0] = '\0';
    const char *t = strstr(col[7], "twin: ");
    if (t)
        sscanf(t + 6, "%255[^;,| \t\n]", row->twin);
    return 1;
}

/* ------------------------------------------------------------ the manifest */

static void check_refused(int *failures_, const char *path, const char *expect)
{
    wpd_error err = lt_open_and_read(path);
    CHECK_MSG(err.code == WPD_E_INPUT, "%s: code %d", path, err.code);
    CHECK_MSG(lt_starts_with(err.msg, path) && !strchr(err.msg, '\n') &&
                  strstr(err.msg, expect),
              "%s: \"%s\" (want \"%s\")", path, err.msg, expect);
}

static void check_twin(int *failures_, const char *path, const char *twin, int *read)
{
    cf_cloud a, b;
    wpd_error err = {0};
    int ra = read_file(path, &a, 1000, &err);
    CHECK_MSG(ra == 0, "%s: %s", path, err.msg);
    int rb = read_file(twin, &b, 4096, &err);
    CHECK_MSG(rb == 0, "%s: %s", twin, err.msg);
    if (ra == 0 && rb == 0) {
        CHECK_MSG(same_records(&a, &b), "%s: %zu records differ from %s (%zu)", path, a.n,
                  twin, b.n);
        ++*read;
    }
    cf_cloud_free(&a);
    cf_cloud_free(&b);
}

/* Every file with a twin must read to exactly the twin's records: point
 * formats 0-5 (point-wise compressor) and 6-10 (layered compressor, COPC
 * included). Files without a twin (LASzip 1.x items, waveform packets)
 * are refused with one line. */
TEST(laz_manifest_twins)
{
    const char *data = test_data_dir();
    if (!data)
        return;
    char dir[1024], path[1024];
    snprintf(dir, sizeof dir, "%s/laz", data);
    snprintf(path, sizeof path, "%.1000s/MANIFEST.tsv", dir);
    FILE *f = fopen(path, "r");
    if (!f)
        return;
    char line[16384];
    int read = 0, refused = 0, layered_before = 0, layered = 0;
    while (fgets(line, sizeof line, f)) {
        laz_row row;
        if (!parse_row(line, &row))
            continue;
        char laz[1200], twin[1200];
        snprintf(laz, sizeof laz, "%.600s/%.255s", dir, row.file);
        snprintf(twin, sizeof twin, "%.600s/%.255s", dir, row.twin);
        if (row.twin[0]) {
            layered_before = read;
            check_twin(failures_, laz, twin, &read);
            layered += row.pdrf >= 6 && read > layered_before;
        } else {
            check_refused(failures_, laz, "not supported");
            refused++;
        }
    }
    fclose(f);
    CHECK_MSG(read >= 22, "only %d LAZ files read against twins", read);
    CHECK_MSG(layered >= 8, "only %d layered LAZ files read against twins", layered);
    CHECK(refused == 2);
}

/* ------------------------------------------------------------ seeking */

/* Reads [from, to) of path after a range seek. */
static int read_range(const char *path, uint64_t from, uint64_t to, cf_cloud *c)
{
    wpd_error err = {0};
    memset(c, 0, sizeof *c);
    wpd_reader *r = wpd_reader_open(path, &err);
    if (!r)
        return -1;
    int rc = !wpd_reader_can_seek(r) || wpd_reader_seek_range(r, from, to, &err) ||
             cf_read_all(r, c, 777, &err);
    wpd_reader_close(r);
    return rc ? -1 : 0;
}

/* Ranges [from, to) of name.laz against the same of its twin name.las. */
static void check_ranges(int *failures_, const char *data, const char *name,
                         const uint64_t (*ranges)[2], size_t n)
{
    char laz[1024], las[1024];
    snprintf(laz, sizeof laz, "%.900s/laz/%s.laz", data, name);
    snprintf(las, sizeof las, "%.900s/laz/%s.las", data, name);
    for (size_t i = 0; i < n; i++) {
        cf_cloud a, b;
        int ra = read_range(laz, ranges[i][0], ranges[i][1], &a);
        int rb = read_range(las, ranges[i][0], ranges[i][1], &b);
        CHECK_MSG(ra == 0 && rb == 0, "%s range %llu..%llu: read failed", name,
                  (unsigned long long)ranges[i][0], (unsigned long long)ranges[i][1]);
        if (ra == 0 && rb == 0)
            CHECK_MSG(same_records(&a, &b) && a.n == ranges[i][1] - ranges[i][0],
                      "%s range %llu..%llu: %zu records, differ", name,
                      (unsigned long long)ranges[i][0], (unsigned long long)ranges[i][1], a.n);
        cf_cloud_free(&a);
        cf_cloud_free(&b);
    }
}

/* Ranges inside one chunk, across chunk boundaries (50000 points each in
 * lastools_fusa.laz: 6 chunks; copcvalidator_ellipsoid-1.4.laz, layered:
 * 2), in the short last chunk, and at the end, as the engine's parallel
 * range readers ask for them; and in a COPC file's 65 variable chunks. */
TEST(laz_seek_ranges)
{
    const char *data = test_data_dir();
    if (!data)
        return;
    static const uint64_t fusa[][2] = {
        {0, 10},          {49990, 50010},   {50000, 50001}, {123456, 234567},
        {249999, 277573}, {277570, 277573}, {277573, 277573}, {1, 277573},
    };
    static const uint64_t ellipsoid[][2] = {
        {0, 10}, {49990, 50010}, {50000, 50001}, {99999, 100000}, {100000, 100000}, {1, 100000},
    };
    static const uint64_t copc[][2] = {{0, 1}, {17, 400}, {500, 1065}, {1064, 1065}};
    check_ranges(failures_, data, "lastools_fusa", fusa, sizeof fusa / sizeof *fusa);
    check_ranges(failures_, data, "copcvalidator_ellipsoid-1.4", ellipsoid,
                 sizeof ellipsoid / sizeof *ellipsoid);
    check_ranges(failures_, data, "laspy_simple_with_page.copc", copc, sizeof copc / sizeof *copc);
}

/* Units of whole chunks: small chunks grouped up to the cap, a larger one
 * alone, cut at n; and a COPC file's table read through the reader: its
 * units cover every record once and start on chunk starts. */
TEST(laz_chunk_units)
{
    static const uint64_t first[] = {0, 10, 30, 100, 105, 110, 400};
    uint64_t starts[7];
    CHECK(wpd_chunk_units(first, 6, 400, 40, starts) == 4);
    CHECK(starts[0] == 0 && starts[1] == 30 && starts[2] == 100 && starts[3] == 110 &&
          starts[4] == 400);
    CHECK(wpd_chunk_units(first, 6, 104, 1000, starts) == 1 && starts[1] == 104);
    CHECK(wpd_chunk_units(first, 6, 105, 1, starts) == 4 && starts[3] == 100 && starts[4] == 105);
    CHECK(wpd_chunk_units(first, 6, 0, 40, starts) == 0 && starts[0] == 0);
    const char *data = test_data_dir();
    if (!data)
        return;
    char path[1024];
    snprintf(path, sizeof path, "%s/laz/laspy_simple_with_page.copc.laz", data);
    wpd_error err;
    wpd_reader *r = wpd_reader_open(path, &err);
    CHECK_MSG(r, "%s", err.msg);
    if (!r)
        return;
    const uint64_t *table;
    uint64_t nchunks = wpd_reader_chunks(r, &table), units = 0;
    CHECK(nchunks == 65 && table[0] == 0 && table[65] == 1065);
    uint64_t *cut = malloc((nchunks + 1) * sizeof *cut);
    if (cut)
        units = wpd_chunk_units(table, nchunks, 1065, 200, cut);
    CHECK(cut && units > 5 && units < 65 && cut[units] == 1065);
    for (uint64_t u = 0; cut && u < units; u++) {
        CHECK(cut[u] == table[wpd_chunk_holding(table, nchunks, cut[u])]);
        CHECK(cut[u + 1] > cut[u]);
    }
    free(cut);
    wpd_reader_close(r);
}

/* Positions only (layered: the X Y and Z layers alone) give the twin's
 * coordinates, on every chunk, after a seek too; a point-wise file says
 * it saves nothing and reads whole records. */
TEST(laz_positions_only)
{
    const char *data = test_data_dir();
    if (!data)
        return;
    static const char *names[] = {"copcvalidator_ellipsoid-1.4", "laspy_append-bug",
                                  "laspy_simple_with_page.copc", "lastools_house"};
    for (size_t f = 0; f < sizeof names / sizeof *names; f++) {
        char laz[1024], las[1024];
        snprintf(laz, sizeof laz, "%.900s/laz/%s.laz", data, names[f]);
        snprintf(las, sizeof las, "%.900s/laz/%s.las", data, names[f]);
        cf_cloud a = {0}, b = {0};
        wpd_error err = {0};
        wpd_reader *r = wpd_reader_open(laz, &err);
        int saves = r ? wpd_reader_positions_only(r, 1) : -1;
        int ra = r ? cf_read_all(r, &a, 999, &err) : -1;
        wpd_reader_close(r);
        CHECK_MSG(ra == 0 && read_file(las, &b, 4096, &err) == 0, "%s: %s", laz, err.msg);
        CHECK_MSG(saves == (f < 3), "%s: positions only saves %d", names[f], saves);
        CHECK_MSG(a.n == b.n && a.n && !memcmp(a.xyz, b.xyz, 3 * a.n * sizeof *a.xyz),
                  "%s: positions differ from the twin's", names[f]);
        cf_cloud_free(&a);
        cf_cloud_free(&b);
    }
}

/* ------------------------------------------------------------ damaged files */

/* Offset of the chunk table (the i64 at the start of the point data). */
static uint64_t table_offset(const uint8_t *b)
{
    uint32_t off;
    int64_t t;
    memcpy(&off, b + 96, 4);
    memcpy(&t, b + off, 8);
    return (uint64_t)t;
}

/* Writes bytes to a temp file, reads it; returns the error (code OK when
 * it read) and, when it read, whether the records equal twin's. */
static wpd_error read_bytes(const char *name, const uint8_t *b, size_t len, const cf_cloud *twin,
                            int *same, int *can_seek, wpd_warnings *warn)
{
    char path[1024];
    cf_tmp_path(path, sizeof path, name);
    wpd_error err = {0};
    cf_cloud c = {0};
    *same = 0;
    if (cf_write_file(path, b, len)) {
        err.code = WPD_E_IO;
        return err;
    }
    wpd_reader *r = wpd_reader_open(path, &err);
    if (!r)
        return err;
    *can_seek = wpd_reader_can_seek(r);
    if (warn)
        *warn = wpd_reader_header(r)->warnings;
    if (cf_read_all(r, &c, 5000, &err) == 0)
        *same = twin && same_records(&c, twin);
    cf_cloud_free(&c);
    wpd_reader_close(r);
    return err;
}

static int warned(const wpd_warnings *w, const char *text)
{
    for (uint32_t i = 0; i < w->n; i++)
        if (strstr(w->line[i], text))
            return 1;
    return 0;
}

/* A truncated file fails with one line; a chunk table that cannot be used
 * (cut off, offset past the end, garbage) gives a warning and a sequential
 * read of the right records; a corrupt stream fails with one line. */
TEST(laz_damaged_files)
{
    const char *data = test_data_dir();
    if (!data)
        return;
    char laz[1024], las[1024];
    snprintf(laz, sizeof laz, "%.900s/laz/lastools_house.laz", data);
    snprintf(las, sizeof las, "%.900s/laz/lastools_house.las", data);
    size_t len;
    uint8_t *b = cf_read_file(laz, &len), *m = malloc(len);
    cf_cloud twin;
    wpd_error err = {0};
    if (!b || !m || read_file(las, &twin, 4096, &err)) {
        CHECK_MSG(0, "cannot load %s or its twin", laz);
        free(b), free(m);
        return;
    }
    uint64_t table = table_offset(b);
    int same, seek;
    wpd_warnings w;
    clock_t t0 = clock();

    /* Cut inside the points: no table, then the data end inside a chunk. */
    err = read_bytes("cut_half.laz", b, len / 2, &twin, &same, &seek, NULL);
    CHECK_MSG(err.code == WPD_E_INPUT && strstr(err.msg, "LAZ chunk") && !strchr(err.msg, '\n'),
              "cut_half: %d \"%s\"", err.code, err.msg);
    /* Cut inside the table: sequential read with a warning. */
    err = read_bytes("cut_table.laz", b, (size_t)table + 9, &twin, &same, &seek, &w);
    CHECK_MSG(err.code == WPD_OK && same && !seek && warned(&w, "chunk table is unusable"),
              "cut_table: %d \"%s\" same %d", err.code, err.msg, same);
    /* Table offset past the end. */
    memcpy(m, b, len);
    uint32_t off;
    memcpy(&off, b + 96, 4);
    memcpy(m + off, (int64_t[]){(int64_t)len + 100}, 8);
    err = read_bytes("table_ptr.laz", m, len, &twin, &same, &seek, &w);
    CHECK_MSG(err.code == WPD_OK && same && !seek && warned(&w, "not in the file"),
              "table_ptr: %d \"%s\"", err.code, err.msg);
    /* Garbage in the table's entries. */
    memcpy(m, b, len);
    for (size_t i = (size_t)table + 8; i < len; i++)
        m[i] ^= 0x5A;
    err = read_bytes("table_garbage.laz", m, len, &twin, &same, &seek, &w);
    CHECK_MSG(err.code == WPD_OK && same && !seek, "table_garbage: %d \"%s\"", err.code,
              err.msg);
    /* Corrupt stream in the first chunk: the decoder does not end where
     * the table says the chunk ends. */
    memcpy(m, b, len);
    for (size_t i = off + 8 + 28 + 1000; i < off + 8 + 28 + 1100; i++)
        m[i] = (uint8_t)(i * 37);
    err = read_bytes("stream.laz", m, len, &twin, &same, &seek, NULL);
    CHECK_MSG(err.code == WPD_E_INPUT && strstr(err.msg, "LAZ chunk 0") &&
                  !strchr(err.msg, '\n'),
              "stream: %d \"%s\"", err.code, err.msg);
    /* Bad input must be refused fast, not after a long loop. */
    CHECK_MSG(clock() - t0 < 20 * CLOCKS_PER_SEC, "damaged files took %.1f s",
              (double)(clock() - t0) / CLOCKS_PER_SEC);
    cf_cloud_free(&twin);
    free(b), free(m);
}

/* Byte offset of the LASzip VLR payload in b (its header before it), or 0. */

static size_t laszip_payload(const uint8_t *b, size_t len)
{
    uint16_t hsize;
    uint32_t nvlr;
    memcpy(&hsize, b + 94, 2);
    memcpy(&nvlr, b + 100, 4);
    size_t at = hsize;
    for (uint32_t i = 0; i < nvlr && at + 54 <= len; i++) {
        uint16_t vlen;
        memcpy(&vlen, b + at + 20, 2);
        if (!memcmp(b + at + 2, "laszip encoded", 14))
            return at + 54;
        at += 54 + (size_t)vlen;
    }
    return 0;
}

/* Loads ../shared/data/laz/name into *b (and a scratch copy's room *m),
 * with the LASzip VLR payload's offset in *v. 0 when there is no data
 * folder (the test passes unchecked there) or it cannot be loaded (a
 * failure). */
static int load_laz(int *failures_, const char *name, uint8_t **b, uint8_t **m, size_t *len,
                    size_t *v)
{
    const char *data = test_data_dir();
    if (!data)
        return 0;
    char laz[1024];
    snprintf(laz, sizeof laz, "%.900s/laz/%s", data, name);
    *b = cf_read_file(laz, len);
    *m = *b ? malloc(*len) : NULL;
    *v = *b ? laszip_payload(*b, *len) : 0;
    if (!*b || !*m || !*v) {
        CHECK_MSG(0, "cannot load %s", laz);
        free(*b), free(*m);
        return 0;
    }
    return 1;
}

/* Damage to a layered chunk (laspy_append-bug.laz: 1 chunk, record 41
 * bytes, 14 layers): byte counts that pass the chunk, a point count that
 * contradicts the table, a corrupt layer, a cut file, unknown item
 * versions and waveform items: one line naming the file each. */
TEST(laz_layered_damaged)
{
    size_t len, v;
    uint8_t *b, *m;
    if (!load_laz(failures_, "laspy_append-bug.laz", &b, &m, &len, &v))
        return;
    uint32_t off;
    memcpy(&off, b + 96, 4);
    size_t count_at = off + 8 + 41, sizes_at = count_at + 4, layers_at = sizes_at + 14 * 4;
    struct { const char *name; size_t at; uint32_t value; const char *expect; } cases[] = {
        {"layer_size.laz", sizes_at, 1u << 30, "layer byte counts pass the chunk's end"},
        {"layer_shift.laz", sizes_at + 4, 1, "LAZ chunk 0"},
        {"chunk_count.laz", count_at, 1000, "point count does not match"},
        {"layer_garbage.laz", layers_at + 500, 0x5A5A5A5Au, "LAZ chunk 0"},
        {"version.laz", v + 34 + 4, 4, "unknown LAZ item version 4 of POINT14"},
        {"wave.laz", v + 34 + 6 * 1, 13, "waveform packets in LAZ are not supported"},
        {"cut.laz", 0, 0, "LAZ chunk 0"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof *cases; i++) {
        memcpy(m, b, len);
        size_t n = len;
        if (!cases[i].at)
            n = layers_at + 20000; /* cut inside the layers */
        else if (cases[i].at >= v && cases[i].at < v + 100)
            memcpy(m + cases[i].at, &cases[i].value, 2);
        else
            memcpy(m + cases[i].at, &cases[i].value, 4);
        lt_expect_failure(failures_, cases[i].name, m, n, cases[i].expect);
    }
    free(b), free(m);
}


/* A LASzip VLR that contradicts the header or names what is unknown. */
TEST(laz_bad_vlr)
{
    size_t len, v;
    uint8_t *b, *m;
    if (!load_laz(failures_, "lazperf_point-color.laz", &b, &m, &len, &v))
        return;
    struct { const char *name; size_t at; uint16_t value; const char *expect; } cases[] = {
        {"compressor.laz", 0, 7, "unknown LAZ compressor 7"},
        {"coder.laz", 2, 1, "unknown LAZ coder 1"},
        {"item_version.laz", 34 + 4, 9, "unknown LAZ item version 9"},
        {"item_size.laz", 34 + 2, 22, "do not match point format 2"},
        {"item_type.laz", 34 + 6, 12, "LAZ item type 12 (RGBNIR14)"},
        {"item_count.laz", 32, 200, "lists 200 items"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof *cases; i++) {
        memcpy(m, b, len);
        memcpy(m + v + cases[i].at, &cases[i].value, 2);
        lt_expect_failure(failures_, cases[i].name, m, len, cases[i].expect);
    }
    free(b), free(m);
}

/* Random damage anywhere in small files: each read ends, with the points
 * or with one line naming the file (never a crash; run under
 * make test-asan for memory errors). */
TEST(laz_random_damage)
{
    const char *data = test_data_dir();
    if (!data)
        return;
    static const char *files[] = {"rlas_extra_byte.laz", "lazperf_point-color.laz",
                                  "pdal_ellipsoid_copc-draft.laz", "rlas_las14_prf6.laz",
                                  "laspy_simple_with_page.copc.laz"};
    unsigned seed = 12345;
    for (size_t f = 0; f < sizeof files / sizeof *files; f++) {
        char laz[1024];
        snprintf(laz, sizeof laz, "%.900s/laz/%s", data, files[f]);
        size_t len;
        uint8_t *b = cf_read_file(laz, &len), *m = malloc(len);
        if (!b || !m) {
            CHECK_MSG(0, "cannot load %s", laz);
            free(b), free(m);
            continue;
        }
        int rounds = f == 2 ? 6 : 60;
        for (int k = 0; k < rounds; k++) {
            memcpy(m, b, len);
            for (int j = 0; j < 1 + k % 4; j++) {
                seed = seed * 1103515245u + 12345u;
                m[(seed >> 8) % len] ^= (uint8_t)(1u << (seed % 8));
            }
            size_t cut = k % 5 == 4 ? (seed >> 4) % len : len;
            int same, seek;
            char path[1024];
            cf_tmp_path(path, sizeof path, "damaged.laz");
            wpd_error err = read_bytes("damaged.laz", m, cut, NULL, &same, &seek, NULL);
            if (err.code != WPD_OK)
                CHECK_MSG(lt_starts_with(err.msg, path) && !strchr(err.msg, '\n'),
                          "%s round %d: \"%s\"", files[f], k, err.msg);
        }
        free(b), free(m);
    }
}
