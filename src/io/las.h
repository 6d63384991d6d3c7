/* las.h - LAS facts that code outside the LAS reader/writer needs. */
#ifndef WPD_LAS_H
#define WPD_LAS_H

#include "common/error.h"
#include "io/schema.h"

/* Standard record size of point data record format pdrf (0..10), 0 if unknown. */
uint16_t wpd_las_pdrf_size(int pdrf);

/* Builds h->schema from h->las: the PDRF's standard dimensions, X/Y/Z scaled
 * with las.scale/las.offset, then the extra bytes (record_length minus the
 * standard size) described by the Extra Bytes VLR (LASF_Spec/4) in las.vlrs
 * or as unnamed bytes. The same schema the LAS reader produces. Returns 0, or
 * -1 with err set (naming h->path) for an unknown PDRF or a bad descriptor. */
int wpd_las_schema_from_info(wpd_header *h, wpd_error *err);

#endif
