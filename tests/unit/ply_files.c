/* ply_files.c - helpers of the PLY unit tests (see ply_files.h). */
#include "ply_files.h"

#include "harness.h"
#include "io/batch.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Opens path and reads every point. Returns 0, or -1 with err set. */
int pf_read_all(const char *path, cf_cloud *c, wpd_error *err)
{
    memset(c, 0, sizeof *c);
    wpd_reader *r = wpd_reader_open(path, err);
    if (!r)
        return -1;
    int rc = cf_read_all(r, c, 1000, err);
    wpd_reader_close(r);
    return rc;
}

int pf_clouds_equal(const cf_cloud *a, const cf_cloud *b)
{
    if (a->n != b->n || a->record_size != b->record_size)
        return 0;
    return a->n == 0 || (!memcmp(a->records, b->records, a->n * a->record_size) &&
           !memcmp(a->xyz, b->xyz, a->n * 3 * sizeof(double)));
}

/* Expects opening (or, if it opens, reading) path to fail with a message
 * that starts with the path and contains want. */
int pf_fails_with(const char *path, const char *want, char *msg, size_t msg_size)
{
    wpd_error err;
    wpd_error_clear(&err);
    cf_cloud c;
    int rc = pf_read_all(path, &c, &err);
    cf_cloud_free(&c);
    snprintf(msg, msg_size, "%s", err.msg);
    return rc < 0 && !strncmp(err.msg, path, strlen(path)) && strstr(err.msg, want) != NULL;
}

