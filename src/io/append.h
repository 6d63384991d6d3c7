/* append.h - a point file made longer without touching its points
 * (`wpd resample -o OUT --append`, docs/ingest.md): a new file that holds
 * OUT's header with its counts and box updated (LAS: the point count, the
 * points by return and the bounds; PLY: the vertex count), then OUT's
 * point records byte for byte, then the records of a second file of the
 * same record layout. Renamed over OUT by the caller, it is one atomic
 * replacement whose old records are the old file's bytes.
 *
 * LAS without compression and without EVLRs (they follow the points: the
 * new records would have to go before them), and PLY whose only element
 * is the vertex one. The second file's LAS coordinates are re-encoded
 * into OUT's scale and offset where those differ (the value rounded to
 * OUT's grid); every other byte of its records is copied. LAZ is refused:
 * appending would decode and encode every old record (docs/ingest.md). */
#ifndef WPD_APPEND_H
#define WPD_APPEND_H

#include <stdint.h>

#include "common/error.h"
#include "common/outfile.h"

/* Whether OUT (an existing file) can be appended to: 0, or -1 with err
 * set (WPD_E_USAGE: LAZ, EVLRs, other PLY elements; WPD_E_INPUT for a
 * file that does not read). */
int wpd_append_check(const char *out, wpd_error *err);

/* Writes OUT's header (counts and box updated), OUT's records and part's
 * into dest (opened by the caller for OUT's path), not finished. *old and
 * *added: the records of OUT and of part. Fails (WPD_E_USAGE) when part's
 * records are not laid out as OUT's (another point format, other fields).
 * Returns 0, or -1 with err set. */
int wpd_append_files(const char *out, const char *part, wpd_outfile *dest, uint64_t *old,
                     uint64_t *added, wpd_error *err);

#endif
