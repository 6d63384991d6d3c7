/* test_synth.c - the synthetic scan generator (tools/synth.c): exact counts,
 * determinism, tiles, scene content, and the record layouts as seen by the
 * LAS and PLY readers. */
#include "harness.h"

#include <fcntl.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "io/reader.h"
#include "tools/synth/synth.h"

/* ------------------------------------------------------------ helpers */

static const char *tmp_path(const char *name)
{
    static char path[8][1024];
    static int next;
    char *p = path[next++ % 8];
    snprintf(p, sizeof path[0], "%s/%s", test_tmp_dir(), name);
    return p;
}

/* Generates a file; returns 0 on success (err printed otherwise). */
static int synth(const char *path, uint64_t n, uint64_t seed, int tiles, int ascii)
{
    wpd_synth_options o = {.points = n, .seed = seed, .tiles = tiles, .ply_ascii = ascii,
                           .overwrite = 1, .output = path};
    wpd_error err;
    wpd_error_clear(&err);
    if (wpd_synth_run(&o, &err)) {
        fprintf(stderr, "  synth %s: %s\n", path, err.msg);
        return -1;
    }
    return 0;
}

static int same_bytes(const char *a, const char *b)
{
    FILE *fa = fopen(a, "rb"), *fb = fopen(b, "rb");
    int same = fa && fb;
    while (same) {
        int ca = fgetc(fa), cb = fgetc(fb);
        if (ca != cb)
            same = 0;
        if (ca == EOF || cb == EOF)
            break;
    }
    if (fa) fclose(fa);
    if (fb) fclose(fb);
    return same;
}

static int exists(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0;
}

/* One point as read back, by field name (so it checks the layout the
 * readers see, not the generator's own idea of it). */
typedef struct pt {
    double x, y, z, gps;
    int intensity, ret, nret, cls, source, angle, red;
} pt;

typedef struct cloud {
    const wpd_header *hdr;      /* valid until the reader closes: copied facts below */
    uint64_t header_count;
    wpd_format format;
    char system_id[33];
    uint8_t version_minor, pdrf;
    uint16_t record_length;
    double scale[3], offset[3];
    uint32_t ndims;
    char names[16][WPD_DIM_NAME_MAX];
    wpd_type types[16];
    pt *p;
    size_t n;
} cloud;

static double field(const wpd_schema *s, int i, const uint8_t *rec)
{
    return i >= 0 ? wpd_dim_get(&s->dims[i], rec) : -1;
}

/* Reads every point of path; returns 0, or -1 with a message printed. */
static int load(const char *path, cloud *c)
{
    memset(c, 0, sizeof *c);
    wpd_error err;
    wpd_reader *r = wpd_reader_open(path, &err);
    if (!r) {
        fprintf(stderr, "  %s\n", err.msg);
        return -1;
    }
    const wpd_header *h = wpd_reader_header(r);
    const wpd_schema *s = &h->schema;
    c->header_count = h->point_count;
    c->format = h->format;
    memcpy(c->system_id, h->las.system_id, sizeof c->system_id);
    c->version_minor = h->las.version_minor, c->pdrf = h->las.pdrf;
    c->record_length = h->las.record_length;
    memcpy(c->scale, h->las.scale, sizeof c->scale);
    memcpy(c->offset, h->las.offset, sizeof c->offset);
    c->ndims = s->ndims;
    for (uint32_t i = 0; i < s->ndims && i < 16; i++) {
        snprintf(c->names[i], WPD_DIM_NAME_MAX, "%s", s->dims[i].name);
        c->types[i] = s->dims[i].type;
    }
    int fi = wpd_schema_find(s, "intensity"), fr = wpd_schema_find(s, "return_number"),
        fn = wpd_schema_find(s, "number_of_returns"), fc = wpd_schema_find(s, "classification"),
        fs = wpd_schema_find(s, "point_source_id"), fg = wpd_schema_find(s, "gps_time"),
        fa = wpd_schema_find(s, "scan_angle_rank"), fred = wpd_schema_find(s, "red");
    c->p = malloc((h->point_count + 1) * sizeof *c->p);
    wpd_batch b;
    if (!c->p || wpd_batch_init(&b, 8192, s->record_size)) {
        wpd_reader_close(r);
        return -1;
    }
    long k;
    while ((k = wpd_reader_read(r, &b, &err)) > 0) {
        for (long i = 0; i < k && c->n < h->point_count; i++) {
            const uint8_t *rec = b.records + i * (size_t)b.record_size;
            pt *q = &c->p[c->n++];
            q->x = b.xyz[3 * i], q->y = b.xyz[3 * i + 1], q->z = b.xyz[3 * i + 2];
            q->gps = field(s, fg, rec);
            q->intensity = (int)field(s, fi, rec), q->ret = (int)field(s, fr, rec);
            q->nret = (int)field(s, fn, rec), q->cls = (int)field(s, fc, rec);
            q->source = (int)field(s, fs, rec), q->angle = (int)field(s, fa, rec);
            q->red = (int)field(s, fred, rec);
        }
    }
    if (k < 0)
        fprintf(stderr, "  %s\n", err.msg);
    wpd_batch_free(&b);
    wpd_reader_close(r);
    return k < 0 ? -1 : 0;
}

static void unload(cloud *c)
{
    free(c->p);
    memset(c, 0, sizeof *c);
}

static void bounds(const cloud *c, double mn[3], double mx[3])
{
    for (int a = 0; a < 3; a++)
        mn[a] = INFINITY, mx[a] = -INFINITY;
    for (size_t i = 0; i < c->n; i++) {
        const double v[3] = {c->p[i].x, c->p[i].y, c->p[i].z};
        for (int a = 0; a < 3; a++) {
            if (v[a] < mn[a]) mn[a] = v[a];
            if (v[a] > mx[a]) mx[a] = v[a];
        }
    }
}

static size_t count_class(const cloud *c, int cls)
{
    size_t n = 0;
    for (size_t i = 0; i < c->n; i++)
        n += c->p[i].cls == cls;
    return n;
}

/* Columns (0.5 m cells) in which building points span more than 2 m of
 * height: a wall below a roof edge. A roof alone (flat, or a gable rising at
 * most 0.85 m per m) spans less than 0.5 m in such a cell. */
typedef struct cell_z { int64_t key; double z; } cell_z;

static int by_key(const void *a, const void *b)
{
    const cell_z *p = a, *q = b;
    return p->key < q->key ? -1 : p->key > q->key;
}

static size_t wall_columns(const cloud *c)
{
    cell_z *v = malloc(c->n * sizeof *v);
    size_t m = 0, walls = 0;
    for (size_t i = 0; v && i < c->n; i++)
        if (c->p[i].cls == 6) {
            int64_t cx = (int64_t)floor(c->p[i].x * 2), cy = (int64_t)floor(c->p[i].y * 2);
            v[m++] = (cell_z){cx * 100000000 + cy, c->p[i].z};
        }
    if (v)
        qsort(v, m, sizeof *v, by_key);
    for (size_t i = 0; i < m;) {
        size_t j = i;
        double lo = v[i].z, hi = v[i].z;
        for (; j < m && v[j].key == v[i].key; j++)
            lo = v[j].z < lo ? v[j].z : lo, hi = v[j].z > hi ? v[j].z : hi;
        walls += hi - lo > 2.0;
        i = j;
    }
    free(v);
    return walls;
}

/* ------------------------------------------------------------ tests */

TEST(synth_las_exact_count_header_and_scene)
{
    const char *path = tmp_path("synth_city.las");
    CHECK(synth(path, 100000, 1, 1, 0) == 0);
    cloud c;
    if (load(path, &c))
        CHECK_MSG(0, "cannot read %s", path);
    CHECK_MSG(c.header_count == 100000 && c.n == 100000, "header %llu, read %zu",
              (unsigned long long)c.header_count, c.n);
    CHECK(c.format == WPD_FMT_LAS && c.version_minor == 2 && c.pdrf == 3);
    CHECK(c.record_length == 34);
    CHECK(!strcmp(c.system_id, "wpd synth"));
    CHECK(c.scale[0] == 0.01 && c.scale[2] == 0.01);
    CHECK(c.offset[0] == 500000 && c.offset[1] == 4500000);
    /* Classes: ground, vegetation, building, each a real share. */
    size_t ground = count_class(&c, 2), veg = count_class(&c, 5), bld = count_class(&c, 6);
    size_t noise = count_class(&c, 7);
    CHECK_MSG(ground > 20000 && veg > 2000 && bld > 5000, "ground %zu veg %zu building %zu",
              ground, veg, bld);
    CHECK_MSG(ground + veg + bld + noise == c.n, "other classes present");
    /* Multiple returns, consistently numbered; gps time never decreases. */
    size_t later = 0, bad = 0, unsorted = 0, sources = 0;
    int seen_source[8] = {0};
    for (size_t i = 0; i < c.n; i++) {
        const pt *q = &c.p[i];
        later += q->ret > 1;
        bad += q->ret < 1 || q->ret > q->nret || q->nret > 5;
        unsorted += i && q->gps < c.p[i - 1].gps;
        bad += q->angle < -23 || q->angle > 23;
        if (q->source >= 1 && q->source < 8 && !seen_source[q->source]++)
            sources++;
        /* Returns of one pulse share its time and come in order. */
        if (q->ret > 1 && i)
            bad += c.p[i - 1].gps != q->gps || c.p[i - 1].ret != q->ret - 1;
    }
    CHECK_MSG(later > 1000, "only %zu later returns", later);
    CHECK_MSG(bad == 0, "%zu points with bad return numbers, angles or order", bad);
    CHECK_MSG(unsorted == 0, "gps time decreases %zu times", unsorted);
    CHECK_MSG(sources >= 2, "%zu flight strips", sources);
    /* Walls: building points stacked vertically. */
    size_t walls = wall_columns(&c);
    CHECK_MSG(walls >= 20, "only %zu wall columns", walls);
    /* Realistic density over the covered area. */
    double mn[3], mx[3];
    bounds(&c, mn, mx);
    double density = c.n / ((mx[0] - mn[0]) * (mx[1] - mn[1]));
    CHECK_MSG(density >= 8 && density <= 20, "density %.2f points/m2", density);
    CHECK_MSG(mn[0] >= 500000 && mn[1] >= 4500000 && mn[2] > 50 && mx[2] < 400,
              "bounds x %.2f y %.2f z %.2f..%.2f", mn[0], mn[1], mn[2], mx[2]);
    unload(&c);
}

TEST(synth_ply_matches_las_point_for_point)
{
    const char *las = tmp_path("synth_pair.las"), *ply = tmp_path("synth_pair.ply");
    CHECK(synth(las, 100000, 9, 1, 0) == 0);
    CHECK(synth(ply, 100000, 9, 1, 0) == 0);
    cloud a, b;
    if (load(las, &a) || load(ply, &b)) {
        CHECK_MSG(0, "cannot read the pair");
        return;
    }
    CHECK_MSG(b.format == WPD_FMT_PLY && b.n == 100000, "ply count %zu", b.n);
    static const char *const names[] = {
        "x", "y", "z", "intensity", "return_number", "number_of_returns", "classification",
        "point_source_id", "gps_time", "red", "green", "blue"};
    static const wpd_type types[] = {WPD_F64, WPD_F64, WPD_F64, WPD_U16, WPD_U8, WPD_U8,
                                     WPD_U8, WPD_U16, WPD_F64, WPD_U8, WPD_U8, WPD_U8};
    CHECK_MSG(b.ndims == 12, "ply has %u properties", b.ndims);
    for (int i = 0; i < 12 && i < (int)b.ndims; i++)
        CHECK_MSG(!strcmp(b.names[i], names[i]) && b.types[i] == types[i],
                  "property %d is %s", i, b.names[i]);
    size_t diff = 0;
    for (size_t i = 0; i < a.n && i < b.n; i++) {
        const pt *p = &a.p[i], *q = &b.p[i];
        diff += fabs(p->x - q->x) > 1e-6 || fabs(p->y - q->y) > 1e-6 || fabs(p->z - q->z) > 1e-6 ||
                p->gps != q->gps || p->intensity != q->intensity || p->ret != q->ret ||
                p->nret != q->nret || p->cls != q->cls || p->source != q->source ||
                p->red != q->red * 257;
    }
    CHECK_MSG(diff == 0, "%zu points differ between LAS and PLY", diff);
    unload(&a);
    unload(&b);
}

TEST(synth_same_seed_same_bytes_other_seed_differs)
{
    const char *a = tmp_path("synth_a.las"), *b = tmp_path("synth_b.las"),
               *c = tmp_path("synth_c.las");
    CHECK(synth(a, 100000, 42, 1, 0) == 0);
    CHECK(synth(b, 100000, 42, 1, 0) == 0);
    CHECK(synth(c, 100000, 43, 1, 0) == 0);
    CHECK(same_bytes(a, b));
    CHECK(!same_bytes(a, c));
    const char *p = tmp_path("synth_a.ply"), *q = tmp_path("synth_b.ply");
    CHECK(synth(p, 30000, 42, 1, 0) == 0);
    CHECK(synth(q, 30000, 42, 1, 0) == 0);
    CHECK(same_bytes(p, q));
}

TEST(synth_tiles_partition_the_scene)
{
    const char *one = tmp_path("synth_whole.las"), *tiled = tmp_path("synth_tiled.las");
    CHECK(synth(one, 100000, 3, 1, 0) == 0);
    CHECK(synth(tiled, 100000, 3, 4, 0) == 0);
    CHECK(!exists(tiled));
    cloud whole, t[4];
    if (load(one, &whole)) {
        CHECK_MSG(0, "cannot read %s", one);
        return;
    }
    double mn[4][3], mx[4][3];
    size_t total = 0;
    double sum_tiles = 0, sum_whole = 0;
    for (int k = 0; k < 4; k++) {
        char path[1024];
        CHECK(wpd_synth_tile_path(tiled, k + 1, path, sizeof path) == 0);
        if (load(path, &t[k])) {
            CHECK_MSG(0, "cannot read %s", path);
            for (int j = 0; j < k; j++)
                unload(&t[j]);
            unload(&whole);
            return;
        }
        CHECK_MSG(t[k].n > 5000, "tile %d has %zu points", k + 1, t[k].n);
        total += t[k].n;
        bounds(&t[k], mn[k], mx[k]);
        for (size_t i = 0; i < t[k].n; i++)
            sum_tiles += t[k].p[i].x - 500000 + t[k].p[i].gps - 335000000;
    }
    for (size_t i = 0; i < whole.n; i++)
        sum_whole += whole.p[i].x - 500000 + whole.p[i].gps - 335000000;
    CHECK_MSG(total == 100000, "tiles hold %zu points", total);
    CHECK_MSG(fabs(sum_tiles - sum_whole) < 1e-6 * fabs(sum_whole),
              "tiles are not the whole file's points");
    /* Two tiles' boxes may touch at a border but never overlap. */
    for (int i = 0; i < 4; i++)
        for (int j = i + 1; j < 4; j++) {
            double ox = fmin(mx[i][0], mx[j][0]) - fmax(mn[i][0], mn[j][0]);
            double oy = fmin(mx[i][1], mx[j][1]) - fmax(mn[i][1], mn[j][1]);
            CHECK_MSG(ox <= 0 || oy <= 0, "tiles %d and %d overlap by %.2f x %.2f m", i + 1,
                      j + 1, ox, oy);
        }
    for (int k = 0; k < 4; k++)
        unload(&t[k]);
    unload(&whole);
}

TEST(synth_exact_count_for_small_and_odd_sizes)
{
    static const uint64_t sizes[] = {1, 2, 7, 999, 12345};
    for (size_t i = 0; i < sizeof sizes / sizeof *sizes; i++) {
        const char *path = tmp_path("synth_small.las");
        CHECK(synth(path, sizes[i], 11, 1, 0) == 0);
        cloud c;
        if (load(path, &c) == 0) {
            CHECK_MSG(c.n == sizes[i] && c.header_count == sizes[i], "asked %llu, got %zu",
                      (unsigned long long)sizes[i], c.n);
            unload(&c);
        }
    }
    /* One point over four tiles: three empty files, one with the point. */
    const char *tiny = tmp_path("synth_tiny.ply");
    CHECK(synth(tiny, 1, 11, 4, 0) == 0);
    size_t total = 0;
    for (int k = 1; k <= 4; k++) {
        char path[1024];
        wpd_synth_tile_path(tiny, k, path, sizeof path);
        cloud c;
        if (load(path, &c) == 0) {
            total += c.n;
            unload(&c);
        }
    }
    CHECK_MSG(total == 1, "%zu points over the tiles", total);
}

TEST(synth_ascii_ply_same_points_as_binary)
{
    const char *bin = tmp_path("synth_bin.ply"), *asc = tmp_path("synth_asc.ply");
    CHECK(synth(bin, 5000, 2, 1, 0) == 0);
    CHECK(synth(asc, 5000, 2, 1, 1) == 0);
    cloud a, b;
    if (load(bin, &a) || load(asc, &b)) {
        CHECK_MSG(0, "cannot read the pair");
        return;
    }
    size_t diff = a.n != b.n;
    for (size_t i = 0; i < a.n && i < b.n; i++)
        diff += a.p[i].x != b.p[i].x || a.p[i].z != b.p[i].z || a.p[i].gps != b.p[i].gps ||
                a.p[i].cls != b.p[i].cls || a.p[i].red != b.p[i].red;
    CHECK_MSG(diff == 0, "%zu points differ (counts %zu, %zu)", diff, a.n, b.n);
    unload(&a);
    unload(&b);
}

TEST(synth_tile_path_names)
{
    char buf[64];
    CHECK(wpd_synth_tile_path("city.las", 1, buf, sizeof buf) == 0 && !strcmp(buf, "city_tile1.las"));
    CHECK(wpd_synth_tile_path("out/a.b/city.PLY", 12, buf, sizeof buf) == 0 &&
          !strcmp(buf, "out/a.b/city_tile12.PLY"));
    CHECK(wpd_synth_tile_path("a.b/city", 3, buf, sizeof buf) == 0 && !strcmp(buf, "a.b/city_tile3"));
    CHECK(wpd_synth_tile_path("city.las", 1, buf, 8) == -1);
}

/* Runs wpd_synth_main with stdout and stderr silenced; returns its status. */
static int run_main(int argc, char **argv)
{
    fflush(stdout), fflush(stderr);
    int out = dup(1), errfd = dup(2), null = open("/dev/null", O_WRONLY);
    dup2(null, 1), dup2(null, 2);
    int rc = wpd_synth_main(argc, argv);
    fflush(stdout), fflush(stderr);
    dup2(out, 1), dup2(errfd, 2);
    close(out), close(errfd), close(null);
    return rc;
}

TEST(synth_command_line_status)
{
    char out[1024], missing[1100];
    snprintf(out, sizeof out, "%s", tmp_path("synth_cli.las"));
    snprintf(missing, sizeof missing, "%s/no/such/dir/x.las", test_tmp_dir());
    char *help[] = {"synth", "--help"};
    char *none[] = {"synth"};
    char *unknown[] = {"synth", "-n", "10", "-o", out, "--bogus"};
    char *bad_n[] = {"synth", "-n", "ten", "-o", out};
    char *zero_n[] = {"synth", "-n", "0", "-o", out};
    char *bad_ext[] = {"synth", "-n", "10", "-o", "city.xyz"};
    char *ascii_las[] = {"synth", "-n", "10", "-o", out, "--ascii"};
    char *bad_tiles[] = {"synth", "-n", "10", "-o", out, "--tiles", "0"};
    char *ok[] = {"synth", "-n", "2k", "-o", out, "--seed=7", "--tiles", "1"};
    char *no_dir[] = {"synth", "-n", "10", "-o", missing};
    char *force[] = {"synth", "-n", "10", "-o", out, "--force"};
    CHECK(run_main(2, help) == 0);
    CHECK(run_main(1, none) == 1);
    CHECK(run_main(6, unknown) == 1);
    CHECK(run_main(5, bad_n) == 2);
    CHECK(run_main(5, zero_n) == 2);
    CHECK(run_main(5, bad_ext) == 2);
    CHECK(run_main(6, ascii_las) == 2);
    CHECK(run_main(7, bad_tiles) == 2);
    CHECK(run_main(8, ok) == 0);
    cloud c;
    if (load(out, &c) == 0) {
        CHECK_MSG(c.n == 2000, "-n 2k wrote %zu points", c.n);
        unload(&c);
    }
    CHECK(run_main(8, ok) == 1);       /* exists, no --force: a usage error */
    CHECK(run_main(6, force) == 0);
    CHECK(run_main(5, no_dir) == 3);
    CHECK(!exists(missing));
}
