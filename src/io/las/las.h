/* las.h - LAS facts that code outside the LAS reader/writer needs. */
#ifndef WPD_LAS_H
#define WPD_LAS_H

#include "common/error.h"
#include "common/warnings.h"
#include "io/cloud.h"
#include "io/schema.h"

/* Standard record size of point data record format pdrf (0..10), 0 if unknown. */
uint16_t wpd_las_pdrf_size(int pdrf);

/* Builds h->schema from h->las: the PDRF's standard dimensions, X/Y/Z scaled
 * with las.scale/las.offset, then the extra bytes (record_length minus the
 * standard size) described by the Extra Bytes VLR (LASF_Spec/4) in las.vlrs
 * or as unnamed bytes. The same schema the LAS reader produces. An Extra
 * Bytes VLR that does not fit the records is ignored with a warning in
 * h->warnings. Returns 0, or -1 with err set (naming h->path) for an unknown
 * PDRF or a record length too short for it. */
int wpd_las_schema_from_info(wpd_header *h, wpd_error *err);

/* The Extra Bytes data_type code of a scalar of type t (1 uchar .. 10
 * double; LAS 1.4 R15 table 25). */
uint8_t wpd_las_extra_type_code(wpd_type t);

/* Fills one 192-byte Extra Bytes descriptor (LAS 1.4 R15 table 24) for a
 * scalar field of type t: its name and description (at most 32 bytes
 * each, longer ones cut), no scale, offset, no_data, min or max. */
void wpd_las_put_descriptor(uint8_t *desc, wpd_type type, const char *name,
                            const char *description);

/* Appends a field of type t called name to every record of the LAS header
 * h (owning its VLRs, as from wpd_header_copy): the record grows by its
 * size, and the Extra Bytes VLR (LASF_Spec/4; made when there is none)
 * describes it as the last extra bytes. Descriptors that las_schema.c
 * reads are kept; extra bytes they leave undescribed get data_type 0
 * descriptors ("undocumented bytes") so the new field lands at its place;
 * a VLR the reader ignores is replaced. h->schema is rebuilt. Returns 0,
 * or -1 with err set (WPD_E_INPUT: the record or the VLR has no room;
 * WPD_E_MEMORY). */
int wpd_las_append_extra(wpd_header *h, const char *name, wpd_type type,
                         const char *description, wpd_error *err);

/* Adds the return numbers of the n records at rec (laid out as h says) to
 * by_return (index = return number; 0 counts the invalid return number 0). */
void wpd_las_tally_returns(const wpd_header *h, const uint8_t *rec, size_t n,
                           uint64_t by_return[16]);

/* For `wpd info`, which reads every point: appends a warning to w when the
 * header bounds of LAS file h differ from b, the bounds of its points, by
 * more than one step of the coordinate grid, and one when its points-by-
 * return counts differ from by_return (as tallied by wpd_las_tally_returns).
 * Nothing for other formats. */
void wpd_las_check_header_against_points(const wpd_header *h, const wpd_bounds *b,
                                         const uint64_t by_return[16], wpd_warnings *w);

#endif
