/* format.h - internal plug-in interface between the generic reader/writer
 * (reader.c, writer.c) and one file per format (ply_*.c, las_*.c).
 * Not for use outside src/io. */
#ifndef WPD_FORMAT_H
#define WPD_FORMAT_H

#include "common/outfile.h"
#include "io/reader.h"
#include "io/writer.h"

typedef struct wpd_reader_ops {
    /* Same contract as wpd_reader_read; r->dropped must be maintained and
     * no record at or past r->end read. */
    long (*read)(wpd_reader *r, wpd_batch *b, wpd_error *err);
    /* NULL when the format cannot seek. Same contract as wpd_reader_seek. */
    int (*seek)(wpd_reader *r, uint64_t index, wpd_error *err);
    /* Frees r->impl (not the header, not the fd). */
    void (*close)(wpd_reader *r);
    /* NULL when reading positions only saves nothing. Same contract as
     * wpd_reader_positions_only. */
    int (*positions_only)(wpd_reader *r, int on);
    /* NULL when records cost nothing to decode. Same contract as
     * wpd_reader_new_cache. */
    int (*new_cache)(wpd_reader *r, const char *dir, int id, wpd_record_cache **out,
                     wpd_error *err);
    /* NULL for formats without chunks. Same contract as wpd_reader_chunks. */
    uint64_t (*chunks)(const wpd_reader *r, const uint64_t **first);
} wpd_reader_ops;

struct wpd_reader {
    const wpd_reader_ops *ops;
    int fd;                 /* open read-only on hdr.path */
    wpd_header hdr;
    uint64_t dropped;
    uint64_t end;           /* reads stop before this record (the point count
                               unless wpd_reader_seek_range bounded them) */
    void *impl;             /* format state */
    wpd_record_cache *cache; /* decoded records kept for later passes, or NULL */
};

/* Parse the header from r->fd (positioned at 0; r->hdr.path and
 * r->hdr.file_size are set), fill r->hdr, r->ops, r->impl. Return 0, or -1
 * with err set; on failure nothing needs freeing beyond wpd_header_free. */
int wpd_ply_open_reader(wpd_reader *r, wpd_error *err);
int wpd_las_open_reader(wpd_reader *r, wpd_error *err);
/* Called by wpd_las_open_reader for a compressed file once the header and
 * VLRs are read (r->hdr.las.laz filled, the LASzip VLR taken out of the
 * list, r->hdr.point_count set): checks the LASzip VLR against the header,
 * reads the chunk table, sets r->ops and r->impl. *points_end is the end
 * of the compressed points (after the chunk table when there is one). */
int wpd_laz_open_reader(wpd_reader *r, uint64_t *points_end, wpd_error *err);

typedef struct wpd_writer_ops {
    /* Same contract as wpd_writer_write; w->count must be maintained. */
    int (*write)(wpd_writer *w, const wpd_batch *b, wpd_error *err);
    /* Completes the file content (header patch, EVLRs); does not commit. */
    int (*finish)(wpd_writer *w, wpd_error *err);
    /* Frees w->impl. */
    void (*close)(wpd_writer *w);
    /* Same contracts as wpd_writer_end_part and wpd_writer_add_part, for
     * the format's own facts (count, bytes and the position are the
     * generic writer's). */
    int (*end_part)(wpd_writer *w, wpd_write_part *part, wpd_error *err);
    int (*add_part)(wpd_writer *w, const wpd_write_part *part, wpd_error *err);
} wpd_writer_ops;

struct wpd_writer {
    const wpd_writer_ops *ops;
    wpd_outfile out;
    wpd_header hdr;         /* deep copy of the caller's header */
    wpd_write_options opt;
    uint64_t count;
    int part;               /* 1: a part (wpd_writer_open_part): records only */
    uint64_t records_start; /* file position of the first record */
    void *impl;
};

/* Write the file's prelude (header, VLRs) to w->out, set w->ops, w->impl.
 * Return 0, or -1 with err set. */
int wpd_ply_open_writer(wpd_writer *w, wpd_error *err);
int wpd_las_open_writer(wpd_writer *w, wpd_error *err);

#endif
