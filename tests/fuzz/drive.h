/* drive.h - streams one file through the public reader API and checks the
 * reader's promises. Shared by the libFuzzer targets (tests/fuzz/fuzz_*.c)
 * and the regression unit test (tests/unit/test_fuzz_regressions.c), so a
 * finding is replayed in `make test` through the same path that found it.
 *
 * The path is the one `wpd info` and `wpd convert` take (open, read every
 * batch, close) plus what the out-of-core engine adds on top of it: reading
 * every dimension of the records, copying the header, seeking and reading
 * again. A crash or sanitizer report is a finding; so is a broken promise,
 * which fuzz_drive reports as FUZZ_BROKEN with the reason (the fuzz targets
 * abort on it so that libFuzzer keeps the input).
 */
#ifndef WPD_FUZZ_DRIVE_H
#define WPD_FUZZ_DRIVE_H

#include "io/reader.h"
#include "io/schema.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* An odd, small batch capacity: seeds of a few hundred records then cross
 * several batch boundaries and end on a partial batch. */
#define FUZZ_BATCH_CAP 97

enum { FUZZ_ACCEPTED = 0, FUZZ_REFUSED = 1, FUZZ_SKIPPED = 2, FUZZ_BROKEN = -1 };

static int fuzz_broken(char *why, size_t whylen, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));

static int fuzz_broken(char *why, size_t whylen, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(why, whylen, fmt, ap);
    va_end(ap);
    return FUZZ_BROKEN;
}

/* A refusal must be a clean one: an input error (exit code 2) whose single
 * line starts with the file's path. */
static int fuzz_check_refusal(const char *path, const wpd_error *err, char *why, size_t whylen)
{
    size_t n = strlen(path);
    if (err->code != WPD_E_INPUT)
        return fuzz_broken(why, whylen, "refused with code %d instead of %d: %s", (int)err->code,
                           (int)WPD_E_INPUT, err->msg);
    if (strncmp(err->msg, path, n) || strncmp(err->msg + n, ": ", 2) || !err->msg[n + 2])
        return fuzz_broken(why, whylen, "message does not start with '<path>: ': %s", err->msg);
    if (strchr(err->msg, '\n'))
        return fuzz_broken(why, whylen, "message has more than one line: %s", err->msg);
    return FUZZ_REFUSED;
}

/* A warning, like an error, is one line that starts with the file's path. */
static int fuzz_check_warnings(const char *path, const wpd_warnings *w, char *why, size_t whylen)
{
    size_t n = strlen(path);
    if (w->n > WPD_WARNINGS_MAX)
        return fuzz_broken(why, whylen, "%u warnings stored", w->n);
    for (uint32_t i = 0; i < w->n; i++) {
        const char *line = w->line[i];
        if (!memchr(line, '\0', sizeof w->line[i]) || strncmp(line, path, n) ||
            strncmp(line + n, ": ", 2) || strchr(line, '\n'))
            return fuzz_broken(why, whylen, "warning %u is not one line naming the file: %.200s",
                               i, line);
    }
    return 0;
}

static int fuzz_cmp_u64(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return x < y ? -1 : x > y;
}

/* Finds two dimensions with one name: sorted name hashes, strcmp only on
 * equal hashes (libFuzzer hooks every strcmp, so a pairwise check took
 * most of each execution). Returns 1 with *a < *b set, or 0. */
static int fuzz_duplicate_name(const wpd_schema *s, uint32_t *a, uint32_t *b)
{
    uint64_t key[WPD_MAX_DIMS]; /* FNV-1a hash, dim index in the low 8 bits */
    for (uint32_t i = 0; i < s->ndims; i++) {
        uint64_t h = 14695981039346656037ull;
        for (const unsigned char *p = (const unsigned char *)s->dims[i].name; *p; p++)
            h = (h ^ *p) * 1099511628211ull;
        key[i] = (h & ~(uint64_t)0xff) | i;
    }
    qsort(key, s->ndims, sizeof key[0], fuzz_cmp_u64);
    for (uint32_t k = 1; k < s->ndims; k++) {
        uint32_t i = (uint32_t)(key[k - 1] & 0xff), j = (uint32_t)(key[k] & 0xff);
        if ((key[k] ^ key[k - 1]) >> 8 == 0 && !strcmp(s->dims[i].name, s->dims[j].name)) {
            *a = i < j ? i : j;
            *b = i < j ? j : i;
            return 1;
        }
    }
    return 0;
}

/* What every consumer of a schema relies on: fields inside the record, bit
 * fields inside their field, coordinates present, names unique. */
static int fuzz_check_schema(const wpd_header *h, char *why, size_t whylen)
{
    const wpd_schema *s = &h->schema;
    if (!s->record_size || s->ndims > WPD_MAX_DIMS)
        return fuzz_broken(why, whylen, "record size %u, %u dims", s->record_size, s->ndims);
    if (s->dim_x < 0 || s->dim_y < 0 || (uint32_t)s->dim_x >= s->ndims ||
        (uint32_t)s->dim_y >= s->ndims || s->dim_z >= (int)s->ndims || s->dim_z < -1)
        return fuzz_broken(why, whylen, "coordinate dims %d %d %d of %u", s->dim_x, s->dim_y,
                           s->dim_z, s->ndims);
    for (uint32_t i = 0; i < s->ndims; i++) {
        const wpd_dim *d = &s->dims[i];
        if ((unsigned)d->type > WPD_F64)
            return fuzz_broken(why, whylen, "dim %u has type %d", i, (int)d->type);
        size_t size = wpd_type_size(d->type);
        if (d->offset > s->record_size || size > s->record_size - d->offset)
            return fuzz_broken(why, whylen, "dim %u '%.48s' (%zu bytes at %u) outside the %u-byte record",
                               i, d->name, size, d->offset, s->record_size);
        if (d->bit_count && d->bit_shift + d->bit_count > 8 * size)
            return fuzz_broken(why, whylen, "dim %u bits %u+%u outside its field", i,
                               d->bit_shift, d->bit_count);
        if (!memchr(d->name, '\0', sizeof d->name) || !d->name[0])
            return fuzz_broken(why, whylen, "dim %u has an empty or unterminated name", i);
    }
    uint32_t a, b;
    if (fuzz_duplicate_name(s, &a, &b))
        return fuzz_broken(why, whylen, "dims %u and %u are both '%.48s'", a, b, s->dims[a].name);
    return 0;
}

/* Checks one delivered batch: finite coordinates, every dimension of the
 * first and last record readable (ASan sees an out-of-record offset here;
 * wpd_dim_get lives in another file, so the calls are not optimised away). */
static int fuzz_check_batch(const wpd_header *h, const wpd_batch *b, long got, char *why,
                            size_t whylen)
{
    if (got < 0 || (size_t)got != b->n || b->n > b->cap)
        return fuzz_broken(why, whylen, "read returned %ld with n %zu cap %zu", got, b->n,
                           b->cap);
    for (size_t i = 0; i < 3 * b->n; i++)
        if (!isfinite(b->xyz[i]))
            return fuzz_broken(why, whylen, "non-finite coordinate delivered (point %zu)", i / 3);
    const wpd_schema *s = &h->schema;
    const uint8_t *first = b->records, *last = b->records + (b->n - 1) * (size_t)s->record_size;
    for (uint32_t k = 0; k < s->ndims; k++) {
        (void)wpd_dim_get(&s->dims[k], first);
        (void)wpd_dim_get(&s->dims[k], last);
    }
    return 0;
}

/* Streams path through the reader. Returns FUZZ_ACCEPTED when the file was
 * read to the end, FUZZ_REFUSED when it was refused cleanly (err holds the
 * message), FUZZ_BROKEN with why set when a promise was broken, and
 * FUZZ_SKIPPED, unread, when its header counts more than max_points points
 * (0: no limit): a decoder's time grows with the count it is told, so a
 * target spends it on many small inputs instead of a few that claim
 * millions (the per-point paths are the same at any count). */
static int fuzz_drive(const char *path, uint64_t max_points, wpd_error *err, char *why,
                      size_t whylen)
{
    wpd_error_clear(err);
    why[0] = '\0';
    wpd_reader *r = wpd_reader_open(path, err);
    if (!r)
        return fuzz_check_refusal(path, err, why, whylen);
    const wpd_header *h = wpd_reader_header(r);
    if (max_points && h->point_count > max_points) {
        wpd_reader_close(r);
        return FUZZ_SKIPPED;
    }
    int rc = fuzz_check_schema(h, why, whylen);
    if (rc == 0)
        rc = fuzz_check_warnings(path, &h->warnings, why, whylen);
    wpd_batch b, first;
    memset(&first, 0, sizeof first);
    if (rc == 0 && wpd_batch_init(&b, FUZZ_BATCH_CAP, h->schema.record_size)) {
        wpd_reader_close(r);
        return fuzz_broken(why, whylen, "out of memory for a %u-byte batch",
                           h->schema.record_size);
    }
    if (rc) {
        wpd_reader_close(r);
        return rc;
    }
    uint64_t total = 0;
    long got;
    while ((got = wpd_reader_read(r, &b, err)) > 0) {
        if ((rc = fuzz_check_batch(h, &b, got, why, whylen)))
            goto done;
        if (!first.records && wpd_batch_init(&first, b.n, b.record_size) == 0) {
            memcpy(first.records, b.records, b.n * (size_t)b.record_size);
            memcpy(first.xyz, b.xyz, 3 * b.n * sizeof *b.xyz);
            first.n = b.n;
        }
        total += (uint64_t)got;
    }
    if (got < 0) {
        rc = fuzz_check_refusal(path, err, why, whylen);
        goto done;
    }
    if (total + wpd_reader_dropped(r) != h->point_count) {
        rc = fuzz_broken(why, whylen, "%llu points + %llu dropped, header says %llu",
                         (unsigned long long)total, (unsigned long long)wpd_reader_dropped(r),
                         (unsigned long long)h->point_count);
        goto done;
    }
    if ((got = wpd_reader_read(r, &b, err)) != 0) {
        rc = fuzz_broken(why, whylen, "read past the end returned %ld", got);
        goto done;
    }
    /* Engine workers seek: the same records must come back, and reading
     * from the middle must stop at the end. */
    if (wpd_reader_can_seek(r)) {
        if (wpd_reader_seek(r, 0, err) || (got = wpd_reader_read(r, &b, err)) < 0) {
            rc = fuzz_broken(why, whylen, "seek to 0 / read again failed: %s", err->msg);
            goto done;
        }
        if ((size_t)got != first.n ||
            (first.n && (memcmp(b.records, first.records, first.n * (size_t)b.record_size) ||
                         memcmp(b.xyz, first.xyz, 3 * first.n * sizeof *b.xyz)))) {
            rc = fuzz_broken(why, whylen, "read after seek(0) differs from the first read");
            goto done;
        }
        uint64_t mid = h->point_count / 2, again = 0;
        if (wpd_reader_seek(r, mid, err)) {
            rc = fuzz_broken(why, whylen, "seek to %llu failed: %s", (unsigned long long)mid,
                             err->msg);
            goto done;
        }
        while ((got = wpd_reader_read(r, &b, err)) > 0)
            again += (uint64_t)got;
        if (got < 0 || again > h->point_count - mid) {
            rc = fuzz_broken(why, whylen, "reading from %llu gave %ld / %llu points",
                             (unsigned long long)mid, got, (unsigned long long)again);
            goto done;
        }
    }
    /* Writers and the engine take deep copies of the header. */
    wpd_header *copy = calloc(1, sizeof *copy);
    if (!copy || wpd_header_copy(copy, h)) {
        free(copy);
        rc = fuzz_broken(why, whylen, "header copy failed");
        goto done;
    }
    wpd_header_free(copy);
    free(copy);
    rc = FUZZ_ACCEPTED;
done:
    wpd_batch_free(&first);
    wpd_batch_free(&b);
    wpd_reader_close(r);
    return rc;
}

#endif
