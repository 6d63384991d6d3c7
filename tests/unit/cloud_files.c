/* cloud_files.c - see cloud_files.h. */
#include "cloud_files.h"

#include "harness.h"
#include "io/batch.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

char *cf_tmp_path(char *out, size_t size, const char *name)
{
    snprintf(out, size, "%s/%s", test_tmp_dir(), name);
    return out;
}

int cf_write_file(const char *path, const void *data, size_t len)
{
    FILE *f = fopen(path, "wb");
    if (!f)
        return -1;
    size_t n = fwrite(data, 1, len, f);
    return fclose(f) == 0 && n == len ? 0 : -1;
}

uint8_t *cf_read_file(const char *path, size_t *len)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    uint8_t *b = malloc(n > 0 ? (size_t)n : 1);
    if (b && fread(b, 1, (size_t)n, f) != (size_t)n) {
        free(b);
        b = NULL;
    }
    fclose(f);
    *len = (size_t)n;
    return b;
}

void cf_cloud_free(cf_cloud *c)
{
    free(c->records);
    free(c->xyz);
    memset(c, 0, sizeof *c);
}

/* Appends n points of b to c, growing c's arrays. Returns 0 or -1. */
static int append(cf_cloud *c, size_t *cap, const wpd_batch *b, size_t n)
{
    if (c->n + n > *cap) {
        size_t want = (c->n + n) * 2;
        uint8_t *records = realloc(c->records, want * c->record_size);
        if (records)
            c->records = records;
        double *xyz = realloc(c->xyz, want * 3 * sizeof *xyz);
        if (xyz)
            c->xyz = xyz;
        if (!records || !xyz)
            return -1;
        *cap = want;
    }
    memcpy(c->records + c->n * c->record_size, b->records, n * c->record_size);
    memcpy(c->xyz + 3 * c->n, b->xyz, n * 3 * sizeof *c->xyz);
    c->n += n;
    return 0;
}

int cf_read_all(wpd_reader *r, cf_cloud *c, size_t batch_cap, wpd_error *err)
{
    const wpd_header *h = wpd_reader_header(r);
    memset(c, 0, sizeof *c);
    c->record_size = h->schema.record_size;
    wpd_batch b;
    if (wpd_batch_init(&b, batch_cap, c->record_size))
        return -1;
    size_t cap = 0;
    long got;
    int rc = 0;
    while (rc == 0 && (got = wpd_reader_read(r, &b, err)) != 0) {
        if (got < 0 || c->n + (uint64_t)got > h->point_count) /* error, or more than announced */
            rc = -1;
        else
            rc = append(c, &cap, &b, (size_t)got);
    }
    c->dropped = wpd_reader_dropped(r);
    wpd_batch_free(&b);
    return rc;
}
