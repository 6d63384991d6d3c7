#!/usr/bin/python3
"""Rewrites a LAS file of point format 3 as LAS 1.4 point format 7, every
attribute carried over (bench/laz.sh: the end-to-end run on a layered LAZ).

    make_format7.py IN.las OUT.las

Format 3 (34 bytes): X Y Z, intensity, return number (3 bits) and number
of returns (3 bits) with the scan direction and edge flags, classification,
scan angle rank (int8, degrees), user data, point source ID, GPS time, RGB.
Format 7 (36 bytes, LAS 1.4 R15 table 13): X Y Z, intensity, return number
and number of returns (4 bits each), classification flags, scanner channel,
scan direction and edge flags, classification, user data, scan angle
(int16, 0.006 degrees), point source ID, GPS time, RGB. The header is LAS
1.4's (375 bytes, 64-bit counts, the WKT bit set as formats 6-10 require);
VLRs are not carried over. Streams 4 M points at a time."""
import struct
import sys

import numpy as np

CHUNK = 4 << 20


def main(src, dst):
    with open(src, "rb") as f:
        head = f.read(375)
        assert head[:4] == b"LASF", "not a LAS file"
        header_size, offset_to_points = struct.unpack_from("<HI", head, 94)
        pdrf, reclen = head[104] & 0x3F, struct.unpack_from("<H", head, 105)[0]
        assert pdrf == 3 and reclen >= 34, "point format 3 expected, got %d" % pdrf
        n = struct.unpack_from("<I", head, 107)[0]
        if head[25] >= 4 and header_size >= 375:
            n = struct.unpack_from("<Q", head, 247)[0]
        scale_offset_bounds = head[131:227]
        out = bytearray(375)
        out[0:4] = b"LASF"
        struct.pack_into("<H", out, 6, 0x10)  # global encoding: WKT
        out[24], out[25] = 1, 4
        out[26:58] = head[26:58]
        out[58:90] = b"wpd bench/make_format7.py".ljust(32, b"\0")
        out[90:94] = head[90:94]  # creation day and year
        struct.pack_into("<HI", out, 94, 375, 375)
        out[104] = 7
        struct.pack_into("<H", out, 105, 36)
        out[131:227] = scale_offset_bounds
        struct.pack_into("<Q", out, 247, n)
        by_return = np.zeros(15, np.uint64)
        f.seek(offset_to_points)
        with open(dst, "wb") as g:
            g.write(bytes(out))
            left = n
            while left:
                k = min(left, CHUNK)
                a = np.frombuffer(f.read(k * reclen), np.uint8).reshape(k, reclen)
                b = np.zeros((k, 36), np.uint8)
                b[:, 0:14] = a[:, 0:14]                      # X Y Z intensity
                ret, nret = a[:, 14] & 7, (a[:, 14] >> 3) & 7
                b[:, 14] = ret | (nret << 4)
                b[:, 15] = a[:, 14] & 0xC0                   # scan direction, edge
                b[:, 16] = a[:, 15]                          # classification
                b[:, 17] = a[:, 17]                          # user data
                angle = (a[:, 16].view(np.int8).astype(np.float64) / 0.006).round()
                b[:, 18:20] = angle.astype("<i2").view(np.uint8).reshape(k, 2)
                b[:, 20:22] = a[:, 18:20]                    # point source ID
                b[:, 22:30] = a[:, 20:28]                    # GPS time
                b[:, 30:36] = a[:, 28:34]                    # RGB
                by_return += np.bincount(ret[ret > 0] - 1, minlength=15)[:15].astype(np.uint64)
                g.write(b.tobytes())
                left -= k
            g.seek(255)
            g.write(by_return.astype("<u8").tobytes())


if __name__ == "__main__":
    main(*sys.argv[1:3])
