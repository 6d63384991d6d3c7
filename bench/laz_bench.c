/* laz_bench.c - decode speed of the LAZ reader (issue 13).
 *
 *   laz_bench FILE [THREADS] [REPEAT] [xyz]
 *
 * Opens FILE (LAZ or LAS) once per thread, gives each thread an equal
 * share of the point indices (wpd_reader_seek_range: a LAZ reader decodes
 * from the start of the chunk holding the share's first point, so shares
 * that do not start on a chunk cost the decoding of part of a chunk
 * twice) and reads every point in 50,000-point batches. Prints the best
 * of REPEAT (default 5) runs in M points/s. THREADS defaults to 1; more
 * than 1 needs a file that can seek (a LAZ file with a chunk table).
 * "xyz" reads positions only (wpd_reader_positions_only: layered LAZ then
 * decodes only its X, Y and Z layers).
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

/* Reads points [from, to) of path; returns the count or -1. */
static long long read_share(const char *path, unsigned long long from, unsigned long long to,
                            int seek, int xyz)
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
    if (wpd_batch_init(&b, 50000, wpd_reader_header(r)->schema.record_size) ||
        (seek && wpd_reader_seek_range(r, from, to, &err))) {
        wpd_reader_close(r);
        return -1;
    }
    if (xyz)
        wpd_reader_positions_only(r, 1);
    while ((got = wpd_reader_read(r, &b, &err)) > 0)
        n += got;
    if (got < 0)
        fprintf(stderr, "%s\n", err.msg);
    wpd_batch_free(&b);
    wpd_reader_close(r);
    return got < 0 ? -1 : n;
}

/* One run on threads threads: the seconds it took, or -1. */
static double run(const char *path, unsigned long long count, int threads, int xyz)
{
    double t0 = now();
    long long total = 0;
    int bad = 0;
#pragma omp parallel for num_threads(threads) reduction(+ : total, bad)
    for (int t = 0; t < threads; t++) {
        unsigned long long from = count * (unsigned long long)t / (unsigned long long)threads;
        unsigned long long to = count * (unsigned long long)(t + 1) / (unsigned long long)threads;
        long long n = read_share(path, from, to, threads > 1, xyz);
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
    unsigned long long count = wpd_reader_header(r)->point_count;
    int can_seek = wpd_reader_can_seek(r);
    wpd_reader_close(r);
    if (threads < 1 || (threads > 1 && !can_seek)) {
        fprintf(stderr, "%s: %d threads need a file that can seek\n", argv[1], threads);
        return 1;
    }
    double best = 1e30;
    for (int i = 0; i < repeat; i++) {
        double s = run(argv[1], count, threads, xyz);
        if (s < 0)
            return 2;
        if (s < best)
            best = s;
    }
    printf("%s: %llu points, %d thread%s%s, best of %d: %.4f s, %.2f M points/s\n", argv[1],
           count, threads, threads > 1 ? "s" : "", xyz ? ", positions only" : "", repeat, best,
           (double)count / best / 1e6);
    return 0;
}
