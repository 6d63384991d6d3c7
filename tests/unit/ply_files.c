/* ply_files.c - helpers of the PLY unit tests (see ply_files.h). */
#include "ply_files.h"

#include "harness.h"
#include "io/batch.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void pf_tmp_path(char *out, size_t size, const char *name)
{
    snprintf(out, size, "%s/%s", test_tmp_dir(), name);
}

int pf_write_bytes(const char *path, const void *data, size_t len)
{
    FILE *f = fopen(path, "wb");
    if (!f)
        return -1;
    size_t n = fwrite(data, 1, len, f);
    return fclose(f) == 0 && n == len ? 0 : -1;
}

void pf_cloud_free(pf_cloud *c)
{
    free(c->records);
    free(c->xyz);
    memset(c, 0, sizeof *c);
}

/* Reads every point of an open reader in batches of batch_cap. Returns 0,
 * or -1 with err set. */
int pf_read_all_from(wpd_reader *r, pf_cloud *c, size_t batch_cap, wpd_error *err)
{
    const wpd_header *h = wpd_reader_header(r);
    memset(c, 0, sizeof *c);
    c->record_size = h->schema.record_size;
    wpd_batch b;
    if (wpd_batch_init(&b, batch_cap, c->record_size))
        return -1;
    size_t cap = 0;
    int rc = 0;
    for (;;) {
        long n = wpd_reader_read(r, &b, err);
        if (n < 0) {
            rc = -1;
            break;
        }
        if (n == 0)
            break;
        if (c->n + (size_t)n > cap) {
            cap = (c->n + (size_t)n) * 2;
            c->records = realloc(c->records, cap * c->record_size);
            c->xyz = realloc(c->xyz, cap * 3 * sizeof(double));
        }
        memcpy(c->records + c->n * c->record_size, b.records, (size_t)n * c->record_size);
        memcpy(c->xyz + 3 * c->n, b.xyz, (size_t)n * 3 * sizeof(double));
        c->n += (size_t)n;
    }
    c->dropped = wpd_reader_dropped(r);
    wpd_batch_free(&b);
    return rc;
}

/* Opens path and reads every point. Returns 0, or -1 with err set. */
int pf_read_all(const char *path, pf_cloud *c, wpd_error *err)
{
    memset(c, 0, sizeof *c);
    wpd_reader *r = wpd_reader_open(path, err);
    if (!r)
        return -1;
    int rc = pf_read_all_from(r, c, 1000, err);
    wpd_reader_close(r);
    return rc;
}

int pf_clouds_equal(const pf_cloud *a, const pf_cloud *b)
{
    return a->n == b->n && a->record_size == b->record_size &&
           !memcmp(a->records, b->records, a->n * a->record_size) &&
           !memcmp(a->xyz, b->xyz, a->n * 3 * sizeof(double));
}

/* Expects opening (or, if it opens, reading) path to fail with a message
 * that starts with the path and contains want. */
int pf_fails_with(const char *path, const char *want, char *msg, size_t msg_size)
{
    wpd_error err;
    wpd_error_clear(&err);
    pf_cloud c;
    int rc = pf_read_all(path, &c, &err);
    pf_cloud_free(&c);
    snprintf(msg, msg_size, "%s", err.msg);
    return rc < 0 && !strncmp(err.msg, path, strlen(path)) && strstr(err.msg, want) != NULL;
}

