/* test_fuzz_regressions.c - every input the fuzzers ever found a problem
 * with (tests/fuzz/regressions/) goes through the same driver the fuzz
 * targets use (tests/fuzz/drive.h): each must be read to the end or refused
 * cleanly (input error, one line starting with the path), with the schema,
 * batch, seek and header-copy promises kept. Under `make test-asan` a
 * memory error on any of them fails the run as well. */
#include "harness.h"

#include "../fuzz/drive.h"

#include <dirent.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#define REGRESSION_DIR "tests/fuzz/regressions"

static int cmp_names(const void *a, const void *b)
{
    return strcmp(*(char *const *)a, *(char *const *)b);
}

TEST(fuzz_regressions_read_or_refused_cleanly)
{
    DIR *d = opendir(REGRESSION_DIR);
    CHECK_MSG(d != NULL, "cannot open %s (run from the repository root)", REGRESSION_DIR);
    if (!d)
        return;
    char *names[1024];
    size_t n = 0;
    struct dirent *e;
    while ((e = readdir(d)) && n < sizeof names / sizeof names[0])
        if (e->d_name[0] != '.')
            names[n++] = strdup(e->d_name);
    closedir(d);
    qsort(names, n, sizeof names[0], cmp_names);
    /* The directory holds the findings of issue 6; an empty one means the
     * files were lost, not that there is nothing to check. */
    CHECK_MSG(n > 0, "no regression files in %s", REGRESSION_DIR);
    size_t accepted = 0, refused = 0;
    for (size_t i = 0; i < n; i++) {
        char path[512], why[1024];
        snprintf(path, sizeof path, "%s/%s", REGRESSION_DIR, names[i]);
        wpd_error err;
        int rc = fuzz_drive(path, 0, &err, why, sizeof why);
        CHECK_MSG(rc != FUZZ_BROKEN, "%s: %s", path, why);
        accepted += rc == FUZZ_ACCEPTED;
        refused += rc == FUZZ_REFUSED;
        free(names[i]);
    }
    printf("  %zu regression files: %zu read, %zu refused\n", n, accepted, refused);
}
