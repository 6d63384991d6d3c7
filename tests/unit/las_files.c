/* las_files.c - see las_files.h. */
#include "las_files.h"

#include "harness.h"
#include "io/writer.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

int lt_starts_with(const char *s, const char *prefix)
{
    return !strncmp(s, prefix, strlen(prefix));
}

wpd_error lt_open_and_read(const char *path)
{
    wpd_error err = {0};
    wpd_reader *r = wpd_reader_open(path, &err);
    if (r) {
        cf_cloud p;
        cf_read_all(r, &p, 4096, &err);
        cf_cloud_free(&p);
        wpd_reader_close(r);
    }
    return err;
}

size_t lt_build_las(uint8_t *buf, const lt_synth *s)
{
    uint16_t hsize = s->minor >= 4 ? 375 : s->minor == 3 ? 235 : 227;
    size_t vlr = s->with_vlr ? 54 + 10 : 0;
    uint32_t off = (uint32_t)(hsize + vlr);
    memcpy(buf, "LASF", 4);
    buf[24] = 1;
    buf[25] = s->minor;
    memcpy(buf + 26, "synthetic", 9);
    memcpy(buf + 94, &hsize, 2);
    memcpy(buf + 96, &off, 4);
    uint32_t nvlr = s->with_vlr ? 1 : 0;
    memcpy(buf + 100, &nvlr, 4);
    buf[104] = s->pdrf;
    memcpy(buf + 105, &s->record_length, 2);
    uint32_t legacy = s->pdrf >= 6 ? 0 : s->npoints;
    memcpy(buf + 107, &legacy, 4);
    const double scale[3] = {0.01, 0.01, 0.01}, offset[3] = {1000, 2000, 0};
    memcpy(buf + 131, scale, 24);
    memcpy(buf + 155, offset, 24);
    if (s->minor >= 4) {
        uint64_t n = s->npoints;
        memcpy(buf + 247, &n, 8);
    }
    if (s->with_vlr) {
        uint8_t *v = buf + hsize;
        memcpy(v + 2, "test", 4);
        v[18] = 7;
        v[20] = 10;
        memcpy(v + 54, "0123456789", 10);
    }
    for (uint32_t i = 0; i < s->npoints; i++) {
        uint8_t *p = buf + off + (size_t)i * s->record_length;
        int32_t xyz[3] = {100 * (int32_t)i, -50 * (int32_t)i, 7};
        memcpy(p, xyz, 12);
        p[14] = (uint8_t)(i % 3 + 1);
    }
    return off + (size_t)s->npoints * s->record_length;
}

void lt_expect_failure(int *failures_, const char *name, const uint8_t *bytes, size_t len,
                       const char *expect)
{
    char path[1024];
    cf_tmp_path(path, sizeof path, name);
    if (cf_write_file(path, bytes, len)) {
        CHECK_MSG(0, "cannot write %s", path);
        return;
    }
    wpd_error err = lt_open_and_read(path);
    CHECK_MSG(err.code == WPD_E_INPUT, "%s: code %d \"%s\"", name, err.code, err.msg);
    CHECK_MSG(lt_starts_with(err.msg, path) && strstr(err.msg, expect),
              "%s: \"%s\" (want \"%s\")", name, err.msg, expect);
}

int lt_write_points(const char *out, const wpd_header *h, const cf_cloud *p,
                    size_t batch_cap, wpd_error *err)
{
    wpd_write_options opt = {.overwrite = 1};
    wpd_writer *w = wpd_writer_open(out, h, &opt, err);
    if (!w)
        return -1;
    for (uint64_t done = 0; done < p->n;) {
        size_t n = p->n - done < batch_cap ? (size_t)(p->n - done) : batch_cap;
        wpd_batch b = {.cap = n, .n = n, .record_size = p->record_size,
                       .records = p->records + done * p->record_size,
                       .xyz = p->xyz + 3 * done};
        if (wpd_writer_write(w, &b, err)) {
            wpd_writer_abort(w);
            return -1;
        }
        done += n;
    }
    return wpd_writer_close(w, err);
}
