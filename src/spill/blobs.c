/* blobs.c - numbered byte arrays in files (blobs.h). */
#include "spill/blobs.h"

#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "common/fullio.h"
#include "common/tmpdir.h"

struct wpd_blobs {
    char dir[PATH_MAX];
    size_t nkeys;
    size_t *bytes;            /* [nkeys] size of each blob's file */
    wpd_blobs_use *use;       /* where its bytes are counted, or NULL */
};

/* use->now += delta (a difference of sizes, modulo 2^64), and the peak. */
static void count(wpd_blobs_use *use, uint64_t delta)
{
    if (!use)
        return;
    uint64_t now = __atomic_add_fetch(&use->now, delta, __ATOMIC_RELAXED);
    uint64_t peak = __atomic_load_n(&use->peak, __ATOMIC_RELAXED);
    while (now > peak && !__atomic_compare_exchange_n(&use->peak, &peak, now, 1,
                                                       __ATOMIC_RELAXED, __ATOMIC_RELAXED))
        ;
}

int wpd_blobs_open(const char *base_dir, size_t nkeys, wpd_blobs_use *use, wpd_blobs **out,
                   wpd_error *err)
{
    wpd_blobs *b = calloc(1, sizeof *b);
    *out = NULL;
    if (!b || !(b->bytes = calloc(nkeys ? nkeys : 1, sizeof *b->bytes))) {
        free(b);
        return wpd_fail(err, WPD_E_MEMORY, "out of memory");
    }
    b->nkeys = nkeys;
    b->use = use;
    if (wpd_tmpdir_create(base_dir, "wpd-blobs", b->dir, sizeof b->dir, err)) {
        free(b->bytes);
        free(b);
        return -1;
    }
    *out = b;
    return 0;
}

void wpd_blobs_close(wpd_blobs *b)
{
    if (!b)
        return;
    for (size_t k = 0; k < b->nkeys; k++)
        count(b->use, -(uint64_t)b->bytes[k]);
    wpd_tmpdir_remove(b->dir);
    free(b->bytes);
    free(b);
}

static void path_of(const wpd_blobs *b, size_t key, char *path, size_t cap)
{
    snprintf(path, cap, "%s/b-%zu", b->dir, key);
}

int wpd_blobs_put(wpd_blobs *b, size_t key, void *data, size_t bytes, wpd_error *err)
{
    char path[PATH_MAX + 32];
    path_of(b, key, path, sizeof path);
    int fd = open(path, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
    int rc = fd < 0 ? wpd_fail_errno(err, "%s: cannot create", path) : 0;
    if (rc == 0 && wpd_write_full(fd, data, bytes))
        rc = wpd_fail_errno(err, "%s: cannot write", path);
    if (fd >= 0 && close(fd) && rc == 0)
        rc = wpd_fail_errno(err, "%s: cannot write", path);
    free(data);
    size_t now = rc ? 0 : bytes;
    count(b->use, (uint64_t)now - (uint64_t)b->bytes[key]);
    b->bytes[key] = now;
    return rc;
}

int wpd_blobs_get(const wpd_blobs *b, size_t key, void **data, size_t *bytes, wpd_error *err)
{
    size_t n = b->bytes[key];
    *data = malloc(n ? n : 1);
    *bytes = n;
    if (!*data)
        return wpd_fail(err, WPD_E_MEMORY, "out of memory");
    if (n == 0)
        return 0;
    char path[PATH_MAX + 32];
    path_of(b, key, path, sizeof path);
    int fd = open(path, O_RDONLY | O_CLOEXEC);
    ssize_t got = fd < 0 ? -1 : wpd_pread_full(fd, *data, n, 0);
    int saved = errno;
    if (fd >= 0)
        close(fd);
    if (got == (ssize_t)n)
        return 0;
    free(*data);
    *data = NULL;
    errno = saved;
    if (got >= 0)
        return wpd_fail(err, WPD_E_IO, "%s: %zd of %zu bytes (the file was cut short)", path,
                        got, n);
    return wpd_fail_errno(err, "%s: cannot read", path);
}
