/* laz_bench.c - decode speed of the LAZ reader (issue 13).
 *
 *   laz_bench FILE [THREADS] [REPEAT] [xyz]
 *
 * Decodes every point of FILE (LAZ or LAS) on THREADS threads (default 1)
 * the way the engine's passes do (io/pass.c): the points are cut
 * into units of whole LAZ chunks (wpd_chunk_units: consecutive chunks up to
 * 50,000 points, a larger chunk alone; 50,000 points where the file has no
 * chunk table), each thread opens the file once and
 * takes the next unit from a shared counter, seeks to it
 * (wpd_reader_seek_range) and reads it in 50,000-point batches. Prints the
 * best of REPEAT (default 5) runs in M points/s, opening included. More
 * than 1 thread needs a file that can seek (a LAZ file with a chunk
 * table). "xyz" reads positions only (wpd_reader_positions_only: layered
 * LAZ then decodes only its X, Y and Z layers).
 */
#include "io/reader.h"

#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static double now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

/* Units of 50,000 records: of whole chunks where the file has a chunk
 * table (wpd_chunk_units, as the engine's passes cut LAZ files). Returns
 * the number of units and sets *starts (nunits + 1 entries), or 0. */
static unsigned long long plan_units(wpd_reader *r, unsigned long long count,
                                     unsigned long long **starts)
{
    const uint64_t *first;
    uint64_t nchunks = wpd_reader_chunks(r, &first);
    unsigned long long room = nchunks ? nchunks + 1 : count / 50000 + 2, n = 0;
    if (!(*starts = malloc(room * sizeof **starts)))
        return 0;
    if (nchunks)
        return wpd_chunk_units(first, nchunks, count, 50000, (uint64_t *)*starts);
    for (unsigned long long at = 0; at < count; at += 50000)
        (*starts)[n++] = at;
    (*starts)[n] = count;
    return n;
}

/* One thread's share: units taken from *next until none is left. Returns
 * the points read or -1. */
static long long read_units(const char *path, const unsigned long long *starts,
                            unsigned long long units, unsigned long long *next, int seek, int xyz)
{
    wpd_error err;
    wpd_reader *r = wpd_reader_open(path, &err);
    if (!r) {
        fprintf(stderr, "%s\n", err.msg);
        return -1;
    }
    wpd_batch b;
    long long n = 0;
    long got = 0;
    if (wpd_batch_init(&b, 50000, wpd_reader_header(r)->schema.record_size)) {
        wpd_reader_close(r);
        return -1;
    }
    for (;;) {
        unsigned long long u;
#pragma omp atomic capture
        u = (*next)++;
        if (u >= units)
            break;
        if (seek && wpd_reader_seek_range(r, starts[u], starts[u + 1], &err)) {
            got = -1;
            break;
        }
        if (xyz)
            wpd_reader_positions_only(r, 1);
        while ((got = wpd_reader_read(r, &b, &err)) > 0)
            n += got;
        if (got < 0)
            break;
    }
    if (got < 0)
        fprintf(stderr, "%s\n", err.msg);
    wpd_batch_free(&b);
    wpd_reader_close(r);
    return got < 0 ? -1 : n;
}

/* One run on threads threads: the seconds it took, or -1. One thread
 * reads the whole file as one unit, without seeking. */
static double run(const char *path, unsigned long long count, const unsigned long long *starts,
                  unsigned long long units, int threads, int xyz)
{
    double t0 = now();
    long long total = 0;
    int bad = 0;
    unsigned long long next = 0, whole[2] = {0, count};
    if (threads == 1)
        starts = whole, units = 1;
#pragma omp parallel num_threads(threads) reduction(+ : total, bad)
    {
        long long n = read_units(path, starts, units, &next, threads > 1, xyz);
        if (n < 0)
            bad++;
        else
            total += n;
    }
    if (bad || (unsigned long long)total != count)
        return -1;
    return now() - t0;
}

int main(int argc, char **argv)
{
    if (argc < 2) {
        fprintf(stderr, "usage: laz_bench FILE [THREADS] [REPEAT]\n");
        return 1;
    }
    int threads = argc > 2 ? atoi(argv[2]) : 1, repeat = argc > 3 ? atoi(argv[3]) : 5;
    int xyz = argc > 4 && !strcmp(argv[4], "xyz");
    wpd_error err;
    wpd_reader *r = wpd_reader_open(argv[1], &err);
    if (!r) {
        fprintf(stderr, "%s\n", err.msg);
        return 2;
    }
    unsigned long long count = wpd_reader_header(r)->point_count, *starts;
    unsigned long long units = plan_units(r, count, &starts);
    int can_seek = wpd_reader_can_seek(r);
    wpd_reader_close(r);
    if (!starts)
        return 2;
    if (threads < 1 || (threads > 1 && !can_seek)) {
        fprintf(stderr, "%s: %d threads need a file that can seek\n", argv[1], threads);
        return 1;
    }
    double best = 1e30;
    for (int i = 0; i < repeat; i++) {
        double s = run(argv[1], count, starts, units, threads, xyz);
        if (s < 0)
            return 2;
        if (s < best)
            best = s;
    }
    unsigned long long shown = threads > 1 ? units : 1;
    printf("%s: %llu points in %llu unit%s, %d thread%s%s, best of %d: %.4f s, %.2f M points/s\n",
           argv[1], count, shown, shown > 1 ? "s" : "", threads, threads > 1 ? "s" : "",
           xyz ? ", positions only" : "", repeat, best, (double)count / best / 1e6);
    free(starts);
    return 0;
}
