#!/usr/bin/env bash
# Which preset is on the rate-distortion frontier at each size, and where the larger preset
# takes over: the rule behind `cnerf encode --preset auto` (CN_AUTO_BITS, encoder/nerf/cn_train.h).
#   experiments/preset_frontier.sh CSV LATENTS FLOOR
# CSV: preset,how,file_bytes,test_psnr_db rows of two presets, "tiny" and "small" (rows
# copied from experiments/rate_control.sh's and experiments/quality.sh's CSVs; docs/img/
# preset_frontier.csv). LATENTS and FLOOR: the small preset's latent count and floor in bytes
# (test_ratectl prints them). Both curves are read linearly in PSNR against log bytes
# between their points; beyond its last point tiny keeps its best (it cannot use more
# bytes). Prints the crossing in bytes and in the small preset's bits per latent beyond
# its floor.
set -euo pipefail
[ $# -eq 3 ] || { echo "usage: experiments/preset_frontier.sh CSV LATENTS FLOOR" >&2; exit 2; }
tail -n +2 "$1" | sort -t, -k3 -n | awk -F, -v lat="$2" -v fl="$3" '
  # tiny(x): the tiny curve at x bytes, linear in PSNR against log bytes between its points,
  # its best beyond its last point (it cannot use more bytes), -1 below its first.
  function tiny(x,   k) {
    if (nt == 0 || x < tb[1]) return -1
    for (k = 1; k < nt; k++)
      if (x <= tb[k + 1])
        return tq[k] + (tq[k + 1] - tq[k]) * (log(x) - log(tb[k])) / (log(tb[k + 1]) - log(tb[k]))
    return tbest
  }
  { p[NR] = $1; b[NR] = $3; q[NR] = $4; n = NR
    if ($1 == "tiny") { nt++; tb[nt] = $3; tq[nt] = $4; if ($4 > tbest) tbest = $4 } }
  END {
    print "| file (bytes) | preset | test PSNR (dB) | tiny at this size (dB) | frontier |"
    print "|---|---|---|---|---|"
    for (i = 1; i <= n; i++) {
      t = tiny(b[i])
      printf "| %d | %s | %.2f | %s | %s |\n", b[i], p[i], q[i], t < 0 ? "–" : sprintf("%.2f", t),
             p[i] == "tiny" || q[i] <= t ? "tiny" : "small"
    }
    prev = 0
    for (i = 1; i <= n; i++) {
      if (p[i] != "small") continue
      if (prev && q[prev] <= tiny(b[prev]) && q[i] > tiny(b[i])) {
        lo = b[prev]; hi = b[i]  # bisect small(x) - tiny(x) on [lo, hi]
        for (k = 0; k < 60; k++) {
          x = sqrt(lo * hi)
          s = q[prev] + (q[i] - q[prev]) * (log(x) - log(b[prev])) / (log(b[i]) - log(b[prev]))
          if (s > tiny(x)) hi = x; else lo = x
        }
        printf "\nsmall overtakes tiny at %.0f bytes: %.2f bits per latent beyond its floor\n", hi, 8 * (hi - fl) / lat
        exit
      }
      prev = i
    }
    print "\nsmall does not overtake tiny within these points"
  }'
