#include "common/testhook.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

void wpd_test_stall(const char *name)
{
    const char *want = getenv("WPD_TEST_STALL");
    if (!want || strcmp(want, name))
        return;
    fprintf(stderr, "wpd: stalled at %s\n", name);
    fflush(stderr);
    for (;;)
        pause();
}

unsigned long wpd_test_number(const char *var, unsigned long fallback, unsigned long max)
{
    const char *s = getenv(var);
    if (!s || *s < '0' || *s > '9')
        return fallback;
    char *end;
    errno = 0;
    unsigned long v = strtoul(s, &end, 10);
    return *end || errno || v < 1 || v > max ? fallback : v;
}
