#!/usr/bin/env python3
"""Builds the seed corpus of the spill codec fuzz target
(tests/fuzz/fuzz_spill_codec.c; input layout described there).

  make_codec_seeds.py OUT_DIR

Odd seeds (columns): each coordinate style (raw doubles, LAS grids at each
scale with a large base, floats, mixed) at 0, 1, 40 and 300 points, with
and without the one-byte damage. Even seeds (blocks): a few valid blocks
written by hand (raw, fixed-point and grid axes, halo bits), so that the
decoder's paths are reached from the first run. Nothing here is random
(a fixed generator seed): the same script gives the same seeds.
"""
import os
import random
import struct
import sys

HEAD = "<IBBxxQ"
AXIS = "<BBBxidq"


def columns(ctl, base, n, rng):
    out = bytearray([ctl]) + struct.pack("<d", base)
    x = [0, 0, 0]
    for i in range(n):
        out += struct.pack("<hB", rng.randint(1, 3), 1 if i % 5 == 0 else 0)
        for a in range(3):
            x[a] += rng.randint(-100, 100)
            style = (ctl >> 1) & 3
            if style == 0:
                out += struct.pack("<d", base + x[a] * 0.01)
            else:  # int32 X in bytes 0-3, float in bytes 4-7
                out += struct.pack("<if", x[a], x[a] * 0.37)
    return bytes(out)


def block(n, gid0, axes, gid_steps=None, halo=None, bodies=b""):
    wg = 1 if gid_steps else 0
    head = struct.pack(HEAD, n, wg, 1 if halo else 0, gid0)
    for mode, wq, wr, gexp, S, q0 in axes:
        head += struct.pack(AXIS, mode, wq, wr, gexp, S, q0)
    body = bytes(gid_steps or b"") + bodies + (halo or b"")
    return b"\x00" + head + body


def main():
    out = sys.argv[1]
    os.makedirs(out, exist_ok=True)
    rng = random.Random(1)
    seeds = {}
    for style in range(4):
        for scale in range(4):
            for n in (0, 1, 40, 300):
                for damage in (0, 0x20):
                    ctl = 1 | style << 1 | scale << 3 | damage
                    base = 639187.0 if style != 2 else 0.0
                    seeds["cols-s%d-k%d-n%d-d%d" % (style, scale, n, damage >> 5)] = \
                        columns(ctl, base, n, rng)
    raw = (0, 0, 0, 0, 0.0, 0)
    seeds["block-empty"] = block(0, 0, [raw] * 3)
    # raw axes: any 8 planes of bytes decode
    seeds["block-raw"] = block(4, 10, [raw] * 3, bytes([0, 1, 1, 2]), b"\x05",
                               bytes(rng.getrandbits(8) for _ in range(3 * 32)))
    fixed = (1, 1, 0, -33, 0.0, 5 << 33)
    grid = (2, 1, 1, -33, 0.01 * 2 ** 33, 500000)
    seeds["block-fixed-grid"] = block(8, 77, [grid, fixed, raw], bytes([0] + [1] * 7),
                                      b"\x81", bytes(8 * 2) + bytes(range(8)) + bytes(64))
    for name, data in sorted(seeds.items()):
        with open(os.path.join(out, name), "wb") as f:
            f.write(data)
    print("%d codec seeds in %s" % (len(seeds), out))


if __name__ == "__main__":
    main()
