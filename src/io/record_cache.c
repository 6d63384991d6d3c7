/* record_cache.c - the decoded-record cache of record_cache.h. */
#include "io/record_cache.h"

#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "common/fullio.h"

struct wpd_record_cache {
    char file[PATH_MAX + 32];
    uint32_t record_length;
    uint64_t nchunks;
    uint64_t *first;              /* [nchunks + 1] */
    _Atomic uint8_t *complete;    /* [nchunks] */
    _Atomic uint64_t hits;
};

wpd_record_cache *wpd_record_cache_create(const char *dir, int id, const char *path,
                                          uint32_t record_length, const uint64_t *first,
                                          uint64_t nchunks, wpd_error *err)
{
    wpd_record_cache *c = calloc(1, sizeof *c);
    if (c) {
        c->first = malloc((nchunks + 1) * sizeof *c->first);
        c->complete = calloc(nchunks ? nchunks : 1, sizeof *c->complete);
    }
    if (!c || !c->first || !c->complete) {
        wpd_record_cache_free(c);
        wpd_fail(err, WPD_E_MEMORY, "%s: out of memory for its record cache", path);
        return NULL;
    }
    memcpy(c->first, first, (nchunks + 1) * sizeof *c->first);
    c->nchunks = nchunks;
    c->record_length = record_length;
    int len = snprintf(c->file, sizeof c->file, "%s/records-%d", dir, id);
    int fd = len > 0 && (size_t)len < sizeof c->file
                 ? open(c->file, O_RDWR | O_CREAT | O_EXCL | O_CLOEXEC, 0600)
                 : -1;
    if (fd < 0) {
        wpd_fail_errno(err, "%s: cannot create", c->file);
        c->file[0] = '\0';
        wpd_record_cache_free(c);
        return NULL;
    }
    close(fd);
    return c;
}

/* The cache file, opened for one read or write. */
static int open_file(const wpd_record_cache *c, wpd_error *err)
{
    int fd = open(c->file, O_RDWR | O_CLOEXEC);
    if (fd < 0)
        wpd_fail_errno(err, "%s: cannot open", c->file);
    return fd;
}

int wpd_record_cache_write(wpd_record_cache *c, uint64_t index, const uint8_t *rec, size_t n,
                           wpd_error *err)
{
    int fd = open_file(c, err);
    if (fd < 0)
        return -1;
    int rc = 0;
    if (wpd_pwrite_full(fd, rec, n * c->record_length, index * c->record_length))
        rc = wpd_fail_errno(err, "%s: cannot write", c->file);
    close(fd);
    return rc;
}

void wpd_record_cache_complete(wpd_record_cache *c, uint64_t chunk)
{
    if (chunk < c->nchunks)
        atomic_store_explicit(&c->complete[chunk], 1, memory_order_release);
}

size_t wpd_record_cache_held(const wpd_record_cache *c, uint64_t index, size_t n)
{
    uint64_t end = index + n < c->first[c->nchunks] ? index + n : c->first[c->nchunks];
    uint64_t k = wpd_chunk_holding(c->first, c->nchunks, index);
    for (; k < c->nchunks && c->first[k] < end; k++)
        if (!atomic_load_explicit(&c->complete[k], memory_order_acquire))
            break;
    uint64_t held = k < c->nchunks && c->first[k] < end ? c->first[k] : end;
    return held > index ? (size_t)(held - index) : 0;
}

int wpd_record_cache_read(wpd_record_cache *c, uint64_t index, uint8_t *rec, size_t n,
                          wpd_error *err)
{
    int fd = open_file(c, err);
    if (fd < 0)
        return -1;
    size_t bytes = n * c->record_length;
    ssize_t got = wpd_pread_full(fd, rec, bytes, index * c->record_length);
    int saved = errno;
    close(fd);
    errno = saved;
    if (got < 0)
        return wpd_fail_errno(err, "%s: cannot read", c->file);
    if ((size_t)got != bytes)
        return wpd_fail(err, WPD_E_IO, "%s: %zd of %zu bytes (the file was cut short)", c->file,
                        got, bytes);
    atomic_fetch_add_explicit(&c->hits, n, memory_order_relaxed);
    return 0;
}

uint64_t wpd_record_cache_hits(const wpd_record_cache *c)
{
    return atomic_load_explicit(&c->hits, memory_order_relaxed);
}

void wpd_record_cache_free(wpd_record_cache *c)
{
    if (!c)
        return;
    if (c->file[0])
        unlink(c->file);
    free(c->first);
    free((void *)c->complete);
    free(c);
}
