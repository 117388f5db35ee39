#!/usr/bin/env bash
# Rendering from flash against rendering from RAM: the README main job's reference stream
# (experiments/data/lego-c070829.cnrf) rendered whole (view r_0, 100x100, 32 + 32 samples,
# t_stop 262144) by the Cortex-M4 firmware (QEMU's mps2-an386, -Os) twice: decoded from the
# stream into a workspace in RAM (cnerf_open), and opened in place from its packed image in
# flash (cnerf pack --target cortex-m4, cnerf_open_packed). Both must give the view's MD5
# e8516816eb358986fb227cd2beb4f48e. Prints one markdown row each: flash, RAM (with the
# stack's worst case), the open's and the render's instructions. Then the flash model: QEMU
# counts instructions and runs every load in one step; a real part stalls on flash. With
# 16-byte flash lines, W wait states a line (WAIT_STATES, 5: an STM32F4 at 168 MHz) and no
# data cache hit on the latents, which stream through once per evaluation, reading from flash
# adds W cycles per 16 bytes of latents read: the packed sums' int8 and int16 latents and the
# lists' 4-byte entries, counted by the firmware's second render of the packed row.
#   experiments/packed_cost.sh
# FW_BOARD=an547 FW_PACK_SET=mve measures the Cortex-M55 instead.
set -euo pipefail
cd "$(dirname "$0")/.."
d=experiments/data
set_=${FW_PACK_SET:-dsp}
row() { # label pack-set
  local out
  out=$(FW_PACK=$2 FW_WORK=first FW_TIMEOUT=3000 FW_EXPECT_MD5=e8516816eb358986fb227cd2beb4f48e \
        FW_BUILD_DIR=build-fw-packed-cost-${FW_BOARD:-an386} scripts/firmware.sh "$d/lego-c070829.cnrf" \
        "$d/lego-c070829.r_0.cam" "0 0 100 100" 32 32 262144 2>&1) || {
    echo "$out" >&2; exit 1; }
  local flash ram tile open ipr
  flash=$(sed -n 's/^flash \([0-9,]*\) bytes.*/\1/p' <<<"$out")
  ram=$(sed -n 's/^RAM needed with the stack.s worst case instead of the reservation: \([0-9,]*\) bytes.*/\1/p' <<<"$out")
  tile=$(sed -n 's/^RAM .* tile buffer \([0-9,]*\),.*/\1/p' <<<"$out")
  open=$(sed -n 's/.*cnerf_open \([0-9,]*\), md5.*/\1/p' <<<"$out")
  ipr=$(sed -n 's/.*: \([0-9,]*\) instructions per ray.*/\1/p' <<<"$out")
  echo "| $1 | $flash | $ram | $tile | $open | $ipr |"
  work=$(sed -n 's/.*work of the tile: \(.*\)/\1/p' <<<"$out")
}
work=
echo "| decoder reads | flash (bytes) | RAM (bytes, worst-case stack) | of which the test's tile buffer | open (instructions) | render (instructions per ray) |"
echo "|---|---|---|---|---|---|"
row "the stream, decoded into RAM (cnerf_open)" ""
row "its packed image in flash (cnerf_open_packed)" "$set_"
python3 - "$work" "${WAIT_STATES:-5}" <<'PY'
import sys
w = sys.argv[1].split()
v = {w[i]: int(w[i + 1]) for i in range(0, len(w) - 1, 2)}
packed = v["macs"] - v["list_macs"]
s8 = v["s8_macs"]
latent_bytes = s8 + 2 * (packed - s8) + 4 * v["list_nz"]
per_ray = latent_bytes / v["rays"]
stall = int(sys.argv[2]) * per_ray / 16
ipr = v["instructions"] / v["rays"] if "instructions" in v else None
print(f"\nFlash model: {per_ray:,.0f} bytes of latents read per ray; at {sys.argv[2]} wait states "
      f"per 16-byte line, {stall:,.0f} stall cycles per ray" +
      (f", {100 * stall / ipr:.0f}% of the instructions" if ipr else ""))
PY
