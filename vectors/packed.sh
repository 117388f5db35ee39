#!/usr/bin/env bash
# Writes vectors/packed/ (docs/conformance.md, "Packed images"): valid vector NAME packed by
# cnerf pack for each kernel set, and broken images, with packed/expected.txt; then
# MANIFEST.sha256 again.
#   vectors/packed.sh NAME     (vectors/regenerate.sh runs it; $CNERF_BUILD or build/)
set -euo pipefail
cd "$(dirname "$0")/.."
name=$1
cnerf=${CNERF_BUILD:-build}/cnerf
out=vectors/packed
rm -rf "$out"
mkdir -p "$out"
# kernel set: a core whose decoder uses it (cnerf pack --target)
targets="c:cortex-m0plus dsp:cortex-m4 mve:cortex-m55 neon:aarch64 avx2:x86-64 simd128:wasm32"
{
  echo "# file  status on a decoder of the image's kernel set  status on any other  set  # what"
  for t in $targets; do
    set=${t%%:*} core=${t#*:}
    "$cnerf" pack "vectors/valid/$name.cnrf" --target "$core" -o "$out/$name.$set.img" > /dev/null
    echo "$name.$set.img CNERF_OK CNERF_E_IMAGE_TARGET $set  # vector $name packed for $core"
  done
} > "$out/expected.txt"

# Broken images, one edit each (docs/decoder.md, "Rendering from flash", gives the header):
# per kernel set a bit flipped in the workspace (the CRC) and the workspace's byte count
# changed with the CRC made again (contents that disagree with the stream); from the c
# image, edits every decoder refuses alike.
python3 - "$out" "$name" "$targets" >> "$out/expected.txt" <<'PY'
import struct, sys, zlib
out, name, targets = sys.argv[1], sys.argv[2], sys.argv[3].split()

def crc(b):
    return b[:44] + struct.pack("<I", zlib.crc32(bytes(b[:44] + b[48:]))) + b[48:]

def write(file, data, own, other, set_, what):
    open(f"{out}/{file}", "wb").write(bytes(data))
    print(f"{file} {own} {other} {set_}  # {what}")

for t in targets:
    s = t.split(":")[0]
    img = bytearray(open(f"{out}/{name}.{s}.img", "rb").read())
    ws_off, ws_n = struct.unpack("<II", img[28:36])
    b = bytearray(img); b[ws_off + ws_n // 2] ^= 0x10
    write(f"crc-{s}.img", b, "CNERF_E_IMAGE_CRC", "CNERF_E_IMAGE_TARGET", s,
          "a bit of the workspace flipped")
    b = bytearray(img); b[32:36] = struct.pack("<I", ws_n - 8)
    write(f"workspace-bytes-{s}.img", crc(b), "CNERF_E_IMAGE", "CNERF_E_IMAGE_TARGET", s,
          "the workspace's byte count 8 short, the CRC made again")
img = bytearray(open(f"{out}/{name}.c.img", "rb").read())
b = bytearray(img); b[4] ^= 0x40
write("version.img", b, "CNERF_E_IMAGE_VERSION", "CNERF_E_IMAGE_VERSION", "c",
      "another image version")
b = bytearray(img); b[6] = ord("B")
write("byte-order.img", b, "CNERF_E_IMAGE_TARGET", "CNERF_E_IMAGE_TARGET", "c",
      "big-endian byte order")
write("header-cut.img", img[:20], "CNERF_E_TRUNCATED", "CNERF_E_TRUNCATED", "c",
      "the header cut short")
write("a-stream.img", open(f"vectors/valid/{name}.cnrf", "rb").read(), "CNERF_E_MAGIC",
      "CNERF_E_MAGIC", "c", "a stream, not an image")
PY
(cd vectors && find valid invalid packed -type f | LC_ALL=C sort | xargs sha256sum > MANIFEST.sha256)
echo "vectors/packed.sh: $(grep -vc '^#' "$out/expected.txt") images of $name in $out" >&2
