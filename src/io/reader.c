/* reader.c - format detection and dispatch to the per-format readers. */
#include "io/format.h"
#include "common/fullio.h"

#include <errno.h>
#include <fcntl.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static int detect_format(wpd_reader *r, wpd_error *err)
{
    char magic[5] = {0};
    /* pread: the format parser starts at offset 0 and must find it there. */
    ssize_t n = wpd_pread_full(r->fd, magic, 4, 0);
    if (n < 0)
        return wpd_fail_errno(err, "%s: cannot read", r->hdr.path);
    if (n == 0)
        return wpd_fail(err, WPD_E_INPUT, "%s: file is empty", r->hdr.path);
    if (n == 4 && !memcmp(magic, "LASF", 4))
        r->hdr.format = WPD_FMT_LAS;
    else if (n >= 3 && !memcmp(magic, "ply", 3))
        r->hdr.format = WPD_FMT_PLY;
    else
        return wpd_fail(err, WPD_E_INPUT,
                        "%s: not a LAS or PLY file (no 'LASF' or 'ply' signature)",
                        r->hdr.path);
    return 0;
}

wpd_reader *wpd_reader_open(const char *path, wpd_error *err)
{
    if (strlen(path) >= sizeof ((wpd_header *)0)->path) {
        wpd_fail(err, WPD_E_USAGE, "%.200s...: path too long", path);
        return NULL;
    }
    wpd_reader *r = calloc(1, sizeof *r);
    if (!r) {
        wpd_fail(err, WPD_E_MEMORY, "%s: out of memory", path);
        return NULL;
    }
    strcpy(r->hdr.path, path);
    r->fd = open(path, O_RDONLY | O_CLOEXEC);
    struct stat st;
    if (r->fd < 0 || fstat(r->fd, &st) != 0) {
        wpd_fail_errno(err, "%s: cannot open", path);
        goto fail;
    }
    if (S_ISDIR(st.st_mode)) {
        wpd_fail(err, WPD_E_INPUT, "%s: is a directory", path);
        goto fail;
    }
    r->hdr.file_size = (uint64_t)st.st_size;
    if (detect_format(r, err))
        goto fail;
    int rc = r->hdr.format == WPD_FMT_LAS ? wpd_las_open_reader(r, err)
                                          : wpd_ply_open_reader(r, err);
    if (rc == 0) {
        r->end = r->hdr.point_count;
        return r;
    }
fail:
    wpd_reader_close(r);
    return NULL;
}

const wpd_header *wpd_reader_header(const wpd_reader *r) { return &r->hdr; }

long wpd_reader_read(wpd_reader *r, wpd_batch *b, wpd_error *err)
{
    if (b->record_size != r->hdr.schema.record_size)
        return wpd_fail(err, WPD_E_USAGE, "%s: batch record size %u does not match %u",
                        r->hdr.path, b->record_size, r->hdr.schema.record_size);
    return r->ops->read(r, b, err);
}

int wpd_reader_can_seek(const wpd_reader *r) { return r->ops->seek != NULL; }

int wpd_reader_seek(wpd_reader *r, uint64_t index, wpd_error *err)
{
    if (!r->ops->seek)
        return wpd_fail(err, WPD_E_USAGE, "%s: this file cannot be read by point index",
                        r->hdr.path);
    if (index > r->hdr.point_count)
        return wpd_fail(err, WPD_E_USAGE, "%s: point index %llu past the end (%llu points)",
                        r->hdr.path, (unsigned long long)index,
                        (unsigned long long)r->hdr.point_count);
    if (r->ops->seek(r, index, err))
        return -1;
    r->end = r->hdr.point_count;
    return 0;
}

int wpd_reader_seek_range(wpd_reader *r, uint64_t index, uint64_t end, wpd_error *err)
{
    if (wpd_reader_seek(r, index, err))
        return -1;
    r->end = end < index ? index : end < r->hdr.point_count ? end : r->hdr.point_count;
    return 0;
}

uint64_t wpd_reader_chunks(const wpd_reader *r, const uint64_t **first)
{
    *first = NULL;
    return r->ops->chunks ? r->ops->chunks(r, first) : 0;
}

uint64_t wpd_chunk_units(const uint64_t *first, uint64_t nchunks, uint64_t n, uint64_t cap,
                         uint64_t *starts)
{
    uint64_t units = 0, c = 0;
    while (c < nchunks && first[c] < n) {
        starts[units++] = first[c];
        uint64_t end = first[c] + cap;
        c++; /* a unit takes one chunk at least */
        while (c < nchunks && first[c + 1] <= end && first[c] < n)
            c++;
    }
    starts[units] = n;
    return units;
}

int wpd_reader_new_cache(wpd_reader *r, const char *dir, int id, wpd_record_cache **out,
                         wpd_error *err)
{
    *out = NULL;
    return r->ops->new_cache ? r->ops->new_cache(r, dir, id, out, err) : 0;
}

void wpd_reader_use_cache(wpd_reader *r, wpd_record_cache *c)
{
    if (c && r->ops->positions_only)
        r->ops->positions_only(r, 0);
    r->cache = c;
}

int wpd_reader_positions_only(wpd_reader *r, int on)
{
    if (r->cache) /* the cache keeps whole records */
        return 0;
    return r->ops->positions_only ? r->ops->positions_only(r, on) : 0;
}

uint64_t wpd_reader_dropped(const wpd_reader *r) { return r->dropped; }

void wpd_reader_close(wpd_reader *r)
{
    if (!r)
        return;
    if (r->ops && r->ops->close)
        r->ops->close(r);
    if (r->fd >= 0)
        close(r->fd);
    wpd_header_free(&r->hdr);
    free(r);
}
