#!/usr/bin/env python3
"""Carries the fuzz corpus over a format change of LAYR: every input whose stream says
major version 1 becomes a 2.0 stream with an input scale byte (f_in = 12) after each layer's
shape, the chunk's length and CRC recomputed. Chunks are walked as far as they are whole; the
rest of an input (a mutation's leftovers) is kept as it is. Files are renamed to the SHA-1 of
their new content, as libFuzzer names them.

    tests/fuzz/upgrade_corpus.py tests/fuzz/corpus/open 0 tests/fuzz/corpus/render 32
(the number is where the stream starts in each input of that directory)."""
import hashlib, os, struct, sys, zlib


def upgrade(data, base):
    s = data[base:]
    if len(s) < 8 or s[:4] != b"\x89CNF" or struct.unpack_from("<H", s, 4)[0] != 1:
        return None
    out = bytearray(data[:base]) + s[:4] + struct.pack("<HH", 2, 0)
    p = 8
    while len(s) - p >= 12:
        tag = s[p:p + 4]
        n = struct.unpack_from("<I", s, p + 4)[0]
        if len(s) - p - 12 < n:
            break
        payload = s[p + 8:p + 8 + n]
        if tag == b"LAYR" and n >= 6:
            payload = payload[:6] + bytes([12]) + payload[6:]
        out += tag + struct.pack("<I", len(payload)) + payload
        out += struct.pack("<I", zlib.crc32(tag + payload) & 0xFFFFFFFF)
        p += 12 + n
    out += s[p:]
    return bytes(out)


def main(argv):
    for d, base in zip(argv[1::2], argv[2::2]):
        done = 0
        for name in sorted(os.listdir(d)):
            path = os.path.join(d, name)
            new = upgrade(open(path, "rb").read(), int(base))
            if new is None:
                continue
            os.remove(path)
            with open(os.path.join(d, hashlib.sha1(new).hexdigest()), "wb") as f:
                f.write(new)
            done += 1
        print(f"{d}: {done} inputs upgraded")


main(sys.argv)
