#include "common/testhook.h"

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
