/* spill_bench.c - measurements behind the spill format (src/spill/).
 *
 *   spill_bench layouts FILE [TILES] [BUFFER_BYTES]
 *       Loads FILE, splits it into TILES (default 64) tiles by an x/y grid
 *       (points keep input order within a tile, as the tiler appends them),
 *       cuts each tile into chunks of BUFFER_BYTES raw bytes (default 256K)
 *       and, for every candidate layout and zstd level, prints compressed
 *       ratio and single-core compress / decompress throughput of the
 *       coordinate part (gid, xyz, halo) and of the record part.
 *
 *   spill_bench api FILE [TILES] [REPEAT] [DIR]
 *       The real module end to end: streams FILE REPEAT times (gids keep
 *       increasing) into a wpd_spill of TILES tiles (default 256) under DIR
 *       (default /tmp), every 16th point a halo point, then reads every
 *       tile back with OMP_NUM_THREADS threads, coordinates only
 *       SPILL_PASSES times (default 3) and once with records.
 *
 * Environment: SPILL_LEVELS, SPILL_LAYOUTS (layouts: which levels and
 * layouts to run); SPILL_LEVEL, SPILL_THREADS, SPILL_BUFFER (api: override
 * the default options); SPILL_SHOW_CLOCK (api: print the CLOCK_MONOTONIC
 * time reading starts, to cut a `perf record -k CLOCK_MONOTONIC`).
 *
 * Coordinates are frame coordinates (minus the minimum corner), as in the
 * engine. Candidate layouts of the coordinate part:
 *   rows      gid x y z halo per point (33 bytes), as appended
 *   cols      gid[] x[] y[] z[] halo[]
 *   cols-d    cols with gid delta-encoded
 *   shuf      gid deltas, x, y, z each byte-shuffled (byte k of every value
 *             together), halo[]
 *   shuf-d    shuf with x, y, z replaced by the difference of their bit
 *             patterns from the previous point's (as 64-bit integers)
 *   shuf-x    shuf with x, y, z replaced by XOR with the previous point's
 *   quant     what the spill does (src/spill/codec.h): per chunk and axis
 *             the values become integers on their binary grid and indices
 *             on their decimal grid (LAS scale) plus a rounding residual;
 *             differences, in the fewest bytes, as byte planes
 * Record part: raw rows, or transposed (byte k of every record together).
 *
 * The spill's own codec (spill/codec.h) and byte planes (spill/planes.h)
 * are measured through their headers, as the library links them.
 */

#include <malloc.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <zstd.h>
#include <omp.h>

#include "io/reader.h"
#include "spill/codec.h"
#include "spill/planes.h"
#include "spill/spill.h"

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + ts.tv_nsec * 1e-9;
}

static void die(const char *what)
{
    fprintf(stderr, "spill_bench: %s\n", what);
    exit(2);
}

static void *xmalloc(size_t n)
{
    void *p = malloc(n ? n : 1);
    if (!p)
        die("out of memory");
    return p;
}

/* ---- the input ---- */

typedef struct cloud {
    size_t n;
    uint32_t rs;
    double *xyz;        /* frame coordinates */
    uint8_t *rec;
    double min[3], max[3];
} cloud;

static void load(const char *path, cloud *c)
{
    wpd_error err;
    wpd_reader *r = wpd_reader_open(path, &err);
    if (!r)
        die(err.msg);
    const wpd_header *h = wpd_reader_header(r);
    c->rs = h->schema.record_size;
    size_t cap = h->point_count;
    c->xyz = xmalloc(cap * 24);
    c->rec = xmalloc(cap * c->rs);
    c->n = 0;
    wpd_batch b;
    if (wpd_batch_init(&b, 1 << 16, c->rs))
        die("out of memory");
    long got;
    while ((got = wpd_reader_read(r, &b, &err)) > 0) {
        if (c->n + got > cap)
            die("more points than the header says");
        memcpy(c->xyz + 3 * c->n, b.xyz, got * 24);
        memcpy(c->rec + c->n * c->rs, b.records, got * c->rs);
        c->n += got;
    }
    if (got < 0)
        die(err.msg);
    wpd_batch_free(&b);
    wpd_reader_close(r);
    for (int k = 0; k < 3; k++)
        c->min[k] = 1e300, c->max[k] = -1e300;
    for (size_t i = 0; i < c->n; i++)
        for (int k = 0; k < 3; k++) {
            double v = c->xyz[3 * i + k];
            c->min[k] = v < c->min[k] ? v : c->min[k];
            c->max[k] = v > c->max[k] ? v : c->max[k];
        }
    for (size_t i = 0; i < c->n; i++)
        for (int k = 0; k < 3; k++)
            c->xyz[3 * i + k] -= c->min[k];
}

/* Tile of a frame point on a g x g grid over the bounds. */
static int tile_of(const double *p, const double *ext, int g)
{
    int tx = (int)(p[0] / ext[0] * g), ty = (int)(p[1] / ext[1] * g);
    tx = tx < 0 ? 0 : tx >= g ? g - 1 : tx;
    ty = ty < 0 ? 0 : ty >= g ? g - 1 : ty;
    return ty * g + tx;
}

/* ---- candidate encodings ---- */

enum { ROWS, COLS, COLS_D, SHUF, SHUF_D, SHUF_X, QUANT, NLAYOUT };
static const char *layout_name[NLAYOUT] = {"rows", "cols", "cols-d", "shuf", "shuf-d", "shuf-x", "quant"};

static void shuffle(uint8_t *restrict dst, const uint8_t *restrict src, size_t n, size_t w)
{
    for (size_t i = 0; i < n; i++)
        for (size_t b = 0; b < w; b++)
            dst[b * n + i] = src[i * w + b];
}

static void unshuffle(uint8_t *restrict dst, const uint8_t *restrict src, size_t n, size_t w)
{
    for (size_t b = 0; b < w; b++)
        for (size_t i = 0; i < n; i++)
            dst[i * w + b] = src[b * n + i];
}

/* The chunk's points as the tiler appends them: gid, xyz, halo. */
typedef struct chunk {
    size_t n;
    uint64_t *gid;
    double *xyz;
    uint8_t *halo;
    uint8_t *rec;
} chunk;

/* Writes the coordinate part of c in layout L into out (wpd_coords_bound(n)
 * bytes); tmp holds 16 n bytes of scratch. Returns the bytes written. */
static size_t encode(int L, const chunk *c, uint8_t *out, uint64_t *tmp)
{
    size_t n = c->n;
    if (L == QUANT)
        return wpd_coords_encode(c->gid, c->xyz, c->halo, n, out, tmp);
    if (L == ROWS) {
        for (size_t i = 0; i < n; i++) {
            memcpy(out + 33 * i, &c->gid[i], 8);
            memcpy(out + 33 * i + 8, &c->xyz[3 * i], 24);
            out[33 * i + 32] = c->halo[i];
        }
        return 33 * n;
    }
    for (size_t i = 0; i < n; i++)
        tmp[i] = (L == COLS) ? c->gid[i] : c->gid[i] - (i ? c->gid[i - 1] : 0);
    if (L <= COLS_D)
        memcpy(out, tmp, 8 * n);
    else
        shuffle(out, (uint8_t *)tmp, n, 8);
    for (int k = 0; k < 3; k++) {
        uint8_t *o = out + 8 * n * (k + 1);
        uint64_t prev = 0;
        for (size_t i = 0; i < n; i++) {
            uint64_t v;
            memcpy(&v, &c->xyz[3 * i + k], 8);
            tmp[i] = L == SHUF_D ? v - prev : L == SHUF_X ? v ^ prev : v;
            prev = v;
        }
        if (L <= COLS_D)
            memcpy(o, tmp, 8 * n);
        else
            shuffle(o, (uint8_t *)tmp, n, 8);
    }
    memcpy(out + 32 * n, c->halo, n);
    return 33 * n;
}

/* Inverse of encode into the arrays of d (gid, xyz, halo). */
static void decode(int L, const uint8_t *in, size_t size, size_t n, chunk *d, uint64_t *tmp)
{
    d->n = n;
    if (L == QUANT) {
        wpd_error err;
        if (wpd_coords_decode(in, size, n, d->gid, d->xyz, d->halo, tmp, &err))
            die(err.msg);
        return;
    }
    if (L == ROWS) {
        for (size_t i = 0; i < n; i++) {
            memcpy(&d->gid[i], in + 33 * i, 8);
            memcpy(&d->xyz[3 * i], in + 33 * i + 8, 24);
            d->halo[i] = in[33 * i + 32];
        }
        return;
    }
    if (L <= COLS_D)
        memcpy(d->gid, in, 8 * n);
    else
        unshuffle((uint8_t *)d->gid, in, n, 8);
    if (L != COLS)
        for (size_t i = 1; i < n; i++)
            d->gid[i] += d->gid[i - 1];
    for (int k = 0; k < 3; k++) {
        const uint8_t *src = in + 8 * n * (k + 1);
        if (L <= COLS_D)
            memcpy(tmp, src, 8 * n);
        else
            unshuffle((uint8_t *)tmp, src, n, 8);
        uint64_t prev = 0;
        for (size_t i = 0; i < n; i++) {
            uint64_t v = L == SHUF_D ? tmp[i] + prev : L == SHUF_X ? tmp[i] ^ prev : tmp[i];
            prev = v;
            memcpy(&d->xyz[3 * i + k], &v, 8);
        }
    }
    memcpy(d->halo, in + 32 * n, n);
}

/* ---- layouts mode ---- */

typedef struct chunks {
    size_t count;
    chunk *c;
} chunks;

/* Splits the cloud into tiles of a g x g grid and the tiles into chunks of
 * at most per points (input order kept). Halo: every 16th point (roughly
 * what a halo of a few spacings adds to a tile). */
static chunks make_chunks(const cloud *cl, int g, size_t per)
{
    double ext[3];
    for (int k = 0; k < 3; k++)
        ext[k] = cl->max[k] - cl->min[k] + 1e-9;
    int nt = g * g;
    size_t *count = calloc(nt, sizeof *count);
    int *tile = xmalloc(cl->n * sizeof *tile);
    for (size_t i = 0; i < cl->n; i++)
        count[tile[i] = tile_of(cl->xyz + 3 * i, ext, g)]++;
    chunks out = {0, NULL};
    for (int t = 0; t < nt; t++)
        out.count += (count[t] + per - 1) / per;
    out.c = calloc(out.count, sizeof *out.c);
    /* chunk index of tile t's current chunk */
    size_t *cur = xmalloc(nt * sizeof *cur), next = 0;
    for (int t = 0; t < nt; t++)
        cur[t] = SIZE_MAX;
    for (size_t i = 0; i < cl->n; i++) {
        int t = tile[i];
        if (cur[t] == SIZE_MAX || out.c[cur[t]].n == per) {
            cur[t] = next++;
            chunk *c = &out.c[cur[t]];
            c->gid = xmalloc(per * 8);
            c->xyz = xmalloc(per * 24);
            c->halo = xmalloc(per);
            c->rec = xmalloc(per * cl->rs);
        }
        chunk *c = &out.c[cur[t]];
        c->gid[c->n] = i;
        memcpy(c->xyz + 3 * c->n, cl->xyz + 3 * i, 24);
        c->halo[c->n] = (i % 16) == 0;
        memcpy(c->rec + c->n * cl->rs, cl->rec + i * cl->rs, cl->rs);
        c->n++;
    }
    free(count);
    free(tile);
    free(cur);
    return out;
}

typedef struct result {
    double raw, packed, tc, td;
} result;

static void print_result(const char *part, const char *layout, int level, const result *r)
{
    printf("%-7s %-7s %5d %8.2f %10.0f %10.0f\n", part, layout, level, r->raw / r->packed,
           r->raw / r->tc / 1e6, r->raw / r->td / 1e6);
    fflush(stdout);
}

/* Times level on the coordinate part in layout L over all chunks. */
static result measure_coords(const chunks *cs, int L, int level, size_t per)
{
    ZSTD_CCtx *cc = ZSTD_createCCtx();
    ZSTD_DCtx *dc = ZSTD_createDCtx();
    size_t bound = ZSTD_compressBound(wpd_coords_bound(per));
    uint8_t *raw = xmalloc(wpd_coords_bound(per)), *z = xmalloc(bound),
            *back = xmalloc(wpd_coords_bound(per));
    uint64_t *tmp = xmalloc(16 * per);
    chunk d = {0, xmalloc(8 * per), xmalloc(24 * per), xmalloc(per), NULL};
    result r = {0, 0, 0, 0};
    for (size_t k = 0; k < cs->count; k++) {
        const chunk *c = &cs->c[k];
        double t0 = now();
        size_t rn = encode(L, c, raw, tmp);
        size_t zn = ZSTD_compressCCtx(cc, z, bound, raw, rn, level);
        double t1 = now();
        size_t bn = ZSTD_decompressDCtx(dc, back, wpd_coords_bound(per), z, zn);
        decode(L, back, bn, c->n, &d, tmp);
        double t2 = now();
        if (ZSTD_isError(zn) || bn != rn || memcmp(d.gid, c->gid, 8 * c->n) ||
            memcmp(d.xyz, c->xyz, 24 * c->n) || memcmp(d.halo, c->halo, c->n))
            die("coordinate round trip failed");
        r.raw += 33.0 * c->n;
        r.packed += zn;
        r.tc += t1 - t0;
        r.td += t2 - t1;
    }
    ZSTD_freeCCtx(cc);
    ZSTD_freeDCtx(dc);
    free(raw); free(z); free(back); free(tmp);
    free(d.gid); free(d.xyz); free(d.halo);
    return r;
}

static result measure_records(const chunks *cs, uint32_t rs, int transposed, int level, size_t per)
{
    ZSTD_CCtx *cc = ZSTD_createCCtx();
    ZSTD_DCtx *dc = ZSTD_createDCtx();
    size_t bound = ZSTD_compressBound(rs * per);
    uint8_t *raw = xmalloc(rs * per), *z = xmalloc(bound), *back = xmalloc(rs * per),
            *out = xmalloc(rs * per);
    result r = {0, 0, 0, 0};
    for (size_t k = 0; k < cs->count; k++) {
        const chunk *c = &cs->c[k];
        size_t bytes = rs * c->n;
        double t0 = now();
        const uint8_t *src = c->rec;
        if (transposed) {
            wpd_planes_from_records(raw, c->rec, c->n, rs);
            src = raw;
        }
        size_t zn = ZSTD_compressCCtx(cc, z, bound, src, bytes, level);
        double t1 = now();
        size_t bn = ZSTD_decompressDCtx(dc, transposed ? back : out, rs * per, z, zn);
        if (transposed)
            wpd_planes_to_records(out, back, c->n, rs);
        double t2 = now();
        if (ZSTD_isError(zn) || bn != bytes || memcmp(out, c->rec, bytes))
            die("record round trip failed");
        r.raw += bytes;
        r.packed += zn;
        r.tc += t1 - t0;
        r.td += t2 - t1;
    }
    ZSTD_freeCCtx(cc);
    ZSTD_freeDCtx(dc);
    free(raw); free(z); free(back); free(out);
    return r;
}

static int cmd_layouts(int argc, char **argv)
{
    int tiles = argc > 3 ? atoi(argv[3]) : 64;
    size_t buffer = argc > 4 ? strtoull(argv[4], NULL, 0) : 256 << 10;
    cloud cl;
    load(argv[2], &cl);
    int g = 1;
    while (g * g < tiles)
        g++;
    size_t per = buffer / (33 + cl.rs);
    chunks cs = make_chunks(&cl, g, per);
    printf("# %s: %zu points, %u-byte records, %d tiles, %zu chunks of <= %zu points (%zu bytes)\n",
           argv[2], cl.n, cl.rs, g * g, cs.count, per, buffer);
    printf("# MB/s of raw bytes, one core; decompress includes the inverse transform\n");
    printf("%-7s %-7s %5s %8s %10s %10s\n", "part", "layout", "level", "ratio", "comp_MB/s",
           "decomp_MB/s");
    /* SPILL_LEVELS="-7 -1" and SPILL_LAYOUTS="quant transp" narrow the run. */
    int levels[16], nlevels = 0;
    const char *lv = getenv("SPILL_LEVELS") ? getenv("SPILL_LEVELS") : "-7 -3 -1 1 3";
    for (char *end; nlevels < 16; lv = end) {
        long l = strtol(lv, &end, 10);
        if (end == lv)
            break;
        levels[nlevels++] = (int)l;
    }
    const char *only = getenv("SPILL_LAYOUTS");
    for (int L = 0; L < NLAYOUT; L++)
        for (int li = 0; li < nlevels && (!only || strstr(only, layout_name[L])); li++) {
            result r = measure_coords(&cs, L, levels[li], per);
            print_result("coords", layout_name[L], levels[li], &r);
        }
    for (int tr = 0; tr < 2; tr++)
        for (int li = 0; li < nlevels && (!only || strstr(only, tr ? "transp" : "rows")); li++) {
            result r = measure_records(&cs, cl.rs, tr, levels[li], per);
            print_result("records", tr ? "transp" : "rows", levels[li], &r);
        }
    return 0;
}

/* ---- api mode ---- */

static int cmd_api(int argc, char **argv)
{
    int tiles = argc > 3 ? atoi(argv[3]) : 256;
    int repeat = argc > 4 ? atoi(argv[4]) : 1;
    const char *dir = argc > 5 ? argv[5] : "/tmp";
    wpd_error err;
    wpd_reader *r = wpd_reader_open(argv[2], &err);
    if (!r)
        die(err.msg);
    const wpd_header *h = wpd_reader_header(r);
    uint32_t rs = h->schema.record_size;
    double mn[3], ext[3];
    for (int k = 0; k < 3; k++) {
        mn[k] = h->format == WPD_FMT_LAS ? h->las.min[k] : 0;
        ext[k] = (h->format == WPD_FMT_LAS ? h->las.max[k] : 1) - mn[k] + 1e-9;
    }
    int g = 1;
    while (g * g < tiles)
        g++;
    wpd_spill_options opt;
    wpd_spill_default_options(&opt);
    if (getenv("SPILL_LEVEL"))
        opt.level = atoi(getenv("SPILL_LEVEL"));
    if (getenv("SPILL_THREADS"))
        opt.threads = atoi(getenv("SPILL_THREADS"));
    if (getenv("SPILL_BUFFER"))
        opt.buffer_bytes = strtoull(getenv("SPILL_BUFFER"), NULL, 0);
    wpd_spill *s = wpd_spill_create(dir, g * g, rs, &opt, &err);
    if (!s)
        die(err.msg);
    wpd_batch b;
    if (wpd_batch_init(&b, 1 << 16, rs))
        die("out of memory");
    uint64_t gid0 = 0;
    double t_append = 0, t_read = 0, t_start = now();
    /* Points of one batch grouped by tile, as a tiler would append them. */
    int *tile = xmalloc(b.cap * sizeof *tile);
    size_t *order = xmalloc(b.cap * sizeof *order), *start = xmalloc((g * g + 1) * sizeof *start);
    uint64_t *gid = xmalloc(b.cap * 8);
    double *xyz = xmalloc(b.cap * 24);
    uint8_t *halo = xmalloc(b.cap), *rec = xmalloc(b.cap * rs);
    for (int rep = 0; rep < repeat; rep++) {
        if (wpd_reader_seek(r, 0, &err))
            die(err.msg);
        long got;
        while ((got = wpd_reader_read(r, &b, &err)) > 0) {
            memset(start, 0, (g * g + 1) * sizeof *start);
            for (long i = 0; i < got; i++) {
                for (int k = 0; k < 3; k++)
                    b.xyz[3 * i + k] -= mn[k];
                start[(tile[i] = tile_of(b.xyz + 3 * i, ext, g)) + 1]++;
            }
            for (int t = 0; t < g * g; t++)
                start[t + 1] += start[t];
            for (long i = 0; i < got; i++)
                order[start[tile[i]]++] = i;
            for (long j = 0; j < got; j++) {
                size_t i = order[j];
                gid[j] = gid0 + i;
                memcpy(xyz + 3 * j, b.xyz + 3 * i, 24);
                halo[j] = (i % 16) == 0;
                memcpy(rec + j * rs, b.records + i * rs, rs);
            }
            double ta = now();
            for (long j = 0; j < got;) {
                long e = j;
                while (e < got && tile[order[e]] == tile[order[j]])
                    e++;
                if (wpd_spill_append(s, tile[order[j]], gid + j, xyz + 3 * j, halo + j,
                                     rec + j * rs, e - j, &err))
                    die(err.msg);
                j = e;
            }
            t_append += now() - ta;
            gid0 += got;
        }
        if (got < 0)
            die(err.msg);
    }
    double tf = now();
    if (wpd_spill_finish(s, &err))
        die(err.msg);
    t_append += now() - tf;
    double t_total = now() - t_start;
    wpd_spill_stats st;
    wpd_spill_get_stats(s, &st);
    printf("# %s x%d: %llu points, %d tiles, level %d, buffer %zu, %d threads\n", argv[2],
           repeat, (unsigned long long)st.points, g * g, opt.level, opt.buffer_bytes,
           opt.threads);
    printf("tiling: %.3f s wall (input read + tiling + spill), %.3f s of it in append+finish\n",
           t_total, t_append);
    printf("spill:  compress %.3f s, write %.3f s (summed over threads); raw %.0f MB, disk %.0f MB, "
           "ratio %.2f\n", st.compress_seconds, st.write_seconds, st.raw_bytes / 1e6,
           st.disk_bytes / 1e6, (double)st.raw_bytes / st.disk_bytes);
    /* Coordinates read as often as the engine's passes do (SPILL_PASSES,
     * default 3), then once with records. */
    int passes = getenv("SPILL_PASSES") ? atoi(getenv("SPILL_PASSES")) : 3;
    if (getenv("SPILL_SHOW_CLOCK")) /* to cut a `perf record -k CLOCK_MONOTONIC` */
        printf("# reading starts at %.6f\n", now());
    for (int pass = 0; pass <= passes; pass++) {
        int with = pass == passes;
        uint64_t total = 0;
        int failed = 0;
        double t0 = now();
#pragma omp parallel for schedule(dynamic, 1) reduction(+ : total, failed)
        for (int t = 0; t < g * g; t++) {
            wpd_tile_data d;
            wpd_error e;
            if (wpd_spill_read(s, t, with, &d, &e)) {
                failed++;
                continue;
            }
            total += d.n;
            wpd_tile_data_free(&d);
        }
        t_read = now() - t0;
        if (failed || total != st.points)
            die("read back failed");
        printf("read %-13s %.3f s with %d threads (%.0f M points/s)\n",
               with ? "with records:" : "coordinates:", t_read, omp_get_max_threads(),
               total / t_read / 1e6);
    }
    wpd_spill_destroy(s);
    wpd_batch_free(&b);
    wpd_reader_close(r);
    free(tile); free(order); free(start); free(gid); free(xyz); free(halo); free(rec);
    return 0;
}

int main(int argc, char **argv)
{
    mallopt(M_MMAP_THRESHOLD, 256 << 20); /* as wpd's main does */
    if (argc >= 3 && !strcmp(argv[1], "layouts"))
        return cmd_layouts(argc, argv);
    if (argc >= 3 && !strcmp(argv[1], "api"))
        return cmd_api(argc, argv);
    fprintf(stderr, "usage: spill_bench layouts FILE [TILES] [BUFFER_BYTES]\n"
                    "       spill_bench api FILE [TILES] [REPEAT] [DIR]\n");
    return 1;
}
