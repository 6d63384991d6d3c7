/* las_internal.h - LAS facts shared by las_read.c and las_write.c: header
 * and record sizes, byte offsets of the header fields, little-endian field
 * access, and the record schema of each point data record format (PDRF).
 * Not for use outside src/io.
 *
 * Header layout (ASPRS LAS 1.4 R15, same offsets in 1.0-1.3 up to their end):
 *   0 "LASF"  4 file source id  6 global encoding  8 GUID[16]  24 version
 *   26 system id[32]  58 generating software[32]  90 creation day  92 year
 *   94 header size  96 offset to point data  100 number of VLRs  104 PDRF
 *   105 record length  107 legacy point count  111 legacy by return[5]
 *   131 scale[3]  155 offset[3]  179 max x, min x, max y, min y, max z, min z
 *   227 (1.3) start of waveform data packet record
 *   235 (1.4) start of first EVLR  243 EVLR count  247 point count (64-bit)
 *   255 points by return[15] (64-bit)  375 end
 */
#ifndef WPD_LAS_INTERNAL_H
#define WPD_LAS_INTERNAL_H

#include <stdint.h>
#include <string.h>

#include "common/error.h"
#include "io/las/las.h"
#include "io/schema.h"

enum {
    LAS_HEADER_SIZE_10 = 227, /* LAS 1.0 to 1.2 */
    LAS_HEADER_SIZE_13 = 235,
    LAS_HEADER_SIZE_14 = 375,
    LAS_VLR_HEADER_SIZE = 54,
    LAS_EVLR_HEADER_SIZE = 60,
    LAS_MAX_PDRF = 10,
    LAS_EXTRA_BYTES_DESCRIPTOR_SIZE = 192,
    LAS_WAVEFORM_RECORD_ID = 65535, /* EVLR holding waveform data packets */
};

/* Header field offsets (see the table above). */
enum {
    LAS_OFF_SOURCE_ID = 4, LAS_OFF_GLOBAL_ENCODING = 6, LAS_OFF_GUID = 8,
    LAS_OFF_VERSION_MAJOR = 24, LAS_OFF_VERSION_MINOR = 25,
    LAS_OFF_SYSTEM_ID = 26, LAS_OFF_SOFTWARE = 58, LAS_OFF_DAY = 90,
    LAS_OFF_YEAR = 92, LAS_OFF_HEADER_SIZE = 94, LAS_OFF_POINT_OFFSET = 96,
    LAS_OFF_NVLR = 100, LAS_OFF_PDRF = 104, LAS_OFF_RECORD_LENGTH = 105,
    LAS_OFF_LEGACY_COUNT = 107, LAS_OFF_LEGACY_BY_RETURN = 111,
    LAS_OFF_SCALE = 131, LAS_OFF_OFFSET = 155, LAS_OFF_BOUNDS = 179,
    LAS_OFF_WAVEFORM_START = 227, LAS_OFF_EVLR_START = 235,
    LAS_OFF_NEVLR = 243, LAS_OFF_COUNT = 247, LAS_OFF_BY_RETURN = 255,
};

/* Standard record size of each PDRF (bytes before any extra bytes). */
static const uint16_t las_pdrf_size[LAS_MAX_PDRF + 1] = {
    20, 28, 26, 34, 57, 63, 30, 36, 38, 59, 67,
};

/* Standard header size of LAS 1.<minor> (minor 0..4). */
static inline uint16_t las_standard_header_size(uint8_t minor)
{
    return minor >= 4 ? LAS_HEADER_SIZE_14 : minor == 3 ? LAS_HEADER_SIZE_13
                                                        : LAS_HEADER_SIZE_10;
}

/* Width in bits of the return number field of byte 14 of a record: PDRF 0-5
 * use 3 bits, the extended formats 6-10 use 4. */
static inline unsigned las_return_bits(uint8_t pdrf) { return pdrf >= 6 ? 4 : 3; }

/* Little-endian loads and stores at arbitrary alignment (every supported
 * host is little-endian; memcpy compiles to a single move). */
static inline uint16_t las_get_u16(const uint8_t *p) { uint16_t v; memcpy(&v, p, 2); return v; }
static inline uint32_t las_get_u32(const uint8_t *p) { uint32_t v; memcpy(&v, p, 4); return v; }
static inline uint64_t las_get_u64(const uint8_t *p) { uint64_t v; memcpy(&v, p, 8); return v; }
static inline double las_get_f64(const uint8_t *p) { double v; memcpy(&v, p, 8); return v; }
static inline void las_put_u16(uint8_t *p, uint16_t v) { memcpy(p, &v, 2); }
static inline void las_put_u32(uint8_t *p, uint32_t v) { memcpy(p, &v, 4); }
static inline void las_put_u64(uint8_t *p, uint64_t v) { memcpy(p, &v, 8); }
static inline void las_put_f64(uint8_t *p, double v) { memcpy(p, &v, 8); }

/* Copies a fixed-width text field (every byte, also those after a NUL) into
 * dst and terminates it: dst must hold width + 1 bytes. */
static inline void las_copy_text(char *dst, const uint8_t *src, size_t width)
{
    memcpy(dst, src, width);
    dst[width] = '\0';
}

/* Decodes x, y, z of the n records (len bytes each) at rec into xyz with
 * scale and offset. Records whose coordinates are not finite are removed
 * (the rest moved down, in order). Returns the number kept. With a
 * validated scale/offset nothing is ever removed, but the check keeps the
 * reader contract independent of that validation. */
size_t las_decode_xyz(const double scale[3], const double offset[3], uint32_t len,
                      uint8_t *rec, size_t n, double *xyz);

#endif
