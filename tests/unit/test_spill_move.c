/* test_spill_move.c - a tile's compressed chunks moved from one spill into
 * another (spill/store_move.c, what the ranks of an MPI run do with the
 * tile pass's points): the receiving tile reads back the chunks' points,
 * after the ones it had, exactly; bytes that are no chunk and a tile with
 * points still buffered are refused. */
#include "harness.h"

#include <stdlib.h>
#include <string.h>

#include "spill/spill.h"

/* n points of tile t: increasing gids from first, varying coordinates,
 * every 7th in the halo. */
static void fill_points(uint64_t first, size_t n, int t, uint64_t *gid, double *xyz,
                        uint8_t *halo)
{
    for (size_t i = 0; i < n; i++) {
        gid[i] = first + 3 * i + (uint64_t)t;
        xyz[3 * i] = 100.0 * t + (double)(i % 1000) * 0.125;
        xyz[3 * i + 1] = (double)(i / 1000) * 0.37 - 5;
        xyz[3 * i + 2] = (double)((i * 7919) % 613) * 1e-3;
        halo[i] = i % 7 == 0;
    }
}

static wpd_spill *make_spill(const char *base, int ntiles, int threads, wpd_error *err)
{
    wpd_spill_options o;
    wpd_spill_default_options(&o);
    o.buffer_bytes = 4096; /* chunks of ~120 points: many of them */
    o.threads = threads;
    return wpd_spill_create(base, ntiles, 0, &o, err);
}

static void check_move(int *failures_, int threads)
{
    enum { N = 5000 };
    char base[1024];
    snprintf(base, sizeof base, "%s", test_tmp_dir());
    uint64_t *gid = malloc(3 * N * sizeof *gid);
    double *xyz = malloc(9 * N * sizeof *xyz);
    uint8_t *halo = malloc(3 * N);
    wpd_error err = {0};
    wpd_spill *a = make_spill(base, 3, threads, &err), *b = make_spill(base, 2, threads, &err);
    CHECK_MSG(a && b && gid && xyz && halo, "%s", err.msg);
    if (!a || !b || !gid || !xyz || !halo)
        goto done;
    /* a: tiles 0 and 2 from the first 3N gids, in slices as a tiler does. */
    fill_points(0, N, 0, gid, xyz, halo);
    fill_points(1, N, 2, gid + N, xyz + 3 * N, halo + N);
    for (size_t at = 0; at < N; at += 1000) {
        CHECK(wpd_spill_append(a, 0, gid + at, xyz + 3 * at, halo + at, NULL, 1000, &err) == 0);
        CHECK(wpd_spill_append(a, 2, gid + N + at, xyz + 3 * (N + at), halo + N + at, NULL,
                               1000, &err) == 0);
    }
    CHECK(wpd_spill_finish(a, &err) == 0);
    /* b's tile 1: a's tile 0, then a's tile 2 (empty tile 1 in between). */
    for (int t = 0; t < 3; t++) {
        uint8_t *bytes = NULL;
        size_t len = 0;
        CHECK_MSG(wpd_spill_tile_chunks(a, t, &bytes, &len, &err) == 0, "%s", err.msg);
        CHECK((len == 0) == (t == 1));
        CHECK_MSG(wpd_spill_add_chunks(b, 1, bytes, len, &err) == 0, "%s", err.msg);
        free(bytes);
    }
    /* Garbage is refused, and so are chunks behind buffered points. */
    uint8_t junk[64] = {1, 2, 3};
    CHECK(wpd_spill_add_chunks(b, 0, junk, sizeof junk, &err) == -1 && err.code == WPD_E_IO);
    CHECK(wpd_spill_append(b, 0, gid, xyz, halo, NULL, 10, &err) == 0);
    uint8_t *bytes = NULL;
    size_t len = 0;
    CHECK(wpd_spill_tile_chunks(a, 0, &bytes, &len, &err) == 0);
    CHECK(wpd_spill_add_chunks(b, 0, bytes, len, &err) == -1 && err.code == WPD_E_USAGE);
    free(bytes);
    CHECK_MSG(wpd_spill_finish(b, &err) == 0, "%s", err.msg);
    wpd_tile_data d;
    CHECK_MSG(wpd_spill_read(b, 1, 0, &d, &err) == 0, "%s", err.msg);
    int same = d.n == 2 * N && !memcmp(d.gid, gid, 2 * N * sizeof *gid) &&
               !memcmp(d.xyz, xyz, 6 * N * sizeof *xyz);
    for (size_t i = 0; same && i < 2 * N; i++)
        same = !d.halo[i] == !halo[i];
    CHECK_MSG(same, "threads %d: %zu points read back, %d moved", threads, d.n, 2 * N);
    wpd_tile_data_free(&d);
    wpd_spill_stats st;
    wpd_spill_get_stats(b, &st);
    CHECK(st.points == 2 * N + 10);
done:
    wpd_spill_destroy(a);
    wpd_spill_destroy(b);
    free(gid);
    free(xyz);
    free(halo);
}

TEST(spill_chunks_move_to_another_spill)
{
    check_move(failures_, 0);
    check_move(failures_, 2);
}
