/* fuzz_reader.c - libFuzzer target for the point readers. Built twice
 * (Makefile, `make fuzz`): with -DFUZZ_PLY for the PLY reader (header and
 * body; the input's format line picks ascii, binary_little_endian or
 * binary_big_endian, so one target covers the three encodings) and with
 * -DFUZZ_LAS for the LAS reader (header, VLRs, EVLRs, point records of PDRF
 * 0-10, extra bytes), and with -DFUZZ_LAZ for LAZ (LAS files whose point
 * format byte marks compression: the LASzip VLR, the chunk table, the
 * arithmetic decoder and item decoders).
 *
 * The readers open files by path, so each input is written to one memfd
 * (made once, truncated per run) and opened as /proc/self/fd/N: no disk
 * I/O and no file creation per execution. Inputs without the target's
 * signature are rejected (return -1 keeps them out of the corpus) so that
 * each target spends its time on its own format.
 */
#include "drive.h"

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <unistd.h>

#if defined(FUZZ_PLY)
#define FUZZ_MAGIC "ply"
#elif defined(FUZZ_LAS) || defined(FUZZ_LAZ)
#define FUZZ_MAGIC "LASF"
#else
#error "build with -DFUZZ_PLY, -DFUZZ_LAS or -DFUZZ_LAZ"
#endif

/* 1 if data is for this target: its signature, and for LAZ the
 * compression bits of the point format byte (offset 104). */
static int wanted(const uint8_t *data, size_t size)
{
    if (size < sizeof FUZZ_MAGIC - 1 || memcmp(data, FUZZ_MAGIC, sizeof FUZZ_MAGIC - 1))
        return 0;
#if defined(FUZZ_LAZ)
    return size > 104 && (data[104] & 0xC0);
#else
    return 1;
#endif
}

/* LAZ inputs that claim more points than this are not explored: a
 * decoder of adapted models turns a few bytes into thousands of points, and
 * at 50,000 a chunk most of a run's time would go to decoding the same
 * paths again. Chunk boundaries stay covered: the seeds' LASzip VLRs can
 * be mutated to chunks of a few points. The LAS and PLY readers copy
 * records, so their inputs' size bounds their cost already. */
#if defined(FUZZ_LAZ)
#define FUZZ_MAX_POINTS 5000u
#else
#define FUZZ_MAX_POINTS 0u
#endif

static int memfd = -1;
static char memfd_path[64];

int LLVMFuzzerInitialize(int *argc, char ***argv);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerInitialize(int *argc, char ***argv)
{
    (void)argc;
    (void)argv;
    memfd = memfd_create("wpd-fuzz-input", MFD_CLOEXEC);
    if (memfd < 0) {
        perror("memfd_create");
        exit(1);
    }
    snprintf(memfd_path, sizeof memfd_path, "/proc/self/fd/%d", memfd);
    return 0;
}

/* Replaces the memfd's content with data. */
static void load_input(const uint8_t *data, size_t size)
{
    if (ftruncate(memfd, 0) != 0) {
        perror("ftruncate");
        abort();
    }
    size_t done = 0;
    while (done < size) {
        ssize_t n = pwrite(memfd, data + done, size - done, (off_t)done);
        if (n <= 0) {
            perror("pwrite");
            abort();
        }
        done += (size_t)n;
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (!wanted(data, size))
        return -1;
    load_input(data, size);
    wpd_error err;
    char why[1024];
    int rc = fuzz_drive(memfd_path, FUZZ_MAX_POINTS, &err, why, sizeof why);
    if (rc == FUZZ_BROKEN) {
        fprintf(stderr, "fuzz_reader: reader promise broken: %s\n", why);
        abort();
    }
    return rc == FUZZ_SKIPPED ? -1 : 0;
}
