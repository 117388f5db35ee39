#!/usr/bin/env bash
# Quality against the receiver's compute and against bytes: for each scene, streams encoded at
# a few sizes and networks, each scored on the scene's test views by the fixed-point decoder
# and timed whole (its first test view) by the Cortex-M4 firmware under QEMU, with this tree's
# decoder ("after") and, when BEFORE names one, an older tree's ("before"). The streams are
# the same for both: the format did not change, only the work the decoder does for the same
# pixels (and the default t_stop, which "before" renders at 2^-12, as the older decoder did).
#
#   experiments/complexity.sh OUT NAME=DATASET[@EVERY]... [--iters N] [--threads T] [--max-size PX]
#   experiments/complexity.sh OUT --table        the markdown tables of OUT/complexity.csv
#
# Networks and sizes, for each scene (CONFIGS, "NAME:PRESET:MU:BYTES ..." overrides them):
#   tiny at 8,000, 15,000 and 30,000 bytes    PSNR against bytes with the network fixed
#   small, and tiny with --group-penalty 0.01, at 15,000 bytes
#                                             PSNR against compute with the bytes fixed
# @EVERY scores every EVERY-th test view only (Lego's 200: @20). A run that ends above or well
# below its size (cnerf encode exits 1 with the file written) is kept, with the bytes it has.
# BEFORE=DIR: a checkout of an older tree (for example `git worktree add ../before c070829`);
# its scripts/firmware.sh builds and runs its decoder. CNERF: the binary (build/cnerf). Each
# scene's firmware builds in OUT/fw-after-NAME and OUT/fw-before-NAME, so that runs of
# different scenes may share OUT side by side. Resumable: a row already in OUT/complexity.csv
# is not run again. docs/complexity.md gives the commands of its tables.
# Rows: scene,config,preset,mu,target,bytes,psnr,psnr_before,view,w,h,macs,evals,ipr,ipr_before
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:?usage: complexity.sh OUT NAME=DATASET... [options] | OUT --table}
shift
csv=$out/complexity.csv
if [ "${1:-}" = "--table" ]; then
  [ -s "$csv" ] || { echo "complexity: no rows in $csv" >&2; exit 1; }
  python3 - "$csv" <<'EOF'
import csv, sys
rows = sorted(csv.DictReader(open(sys.argv[1])),
              key=lambda r: (r['scene'], r['preset'], r['mu'], int(r['bytes'])))
def n(x): return '{:,}'.format(int(x))
def mi(ipr):  # M4 instructions of a 100x100 frame, and seconds at 168 MHz
    return '{:,.0f} M ({:.1f} s)'.format(int(ipr) * 1e4 / 1e6, int(ipr) * 1e4 / 168e6)
def gain(r):
    return '%.2fx' % (int(r['ipr_before']) / int(r['ipr'])) if r['ipr_before'] else '–'
for title, pick in (
        ('PSNR against compute, at a fixed size', lambda r: r['config'] != 'tiny' or r['target'] == '15000'),
        ('PSNR against bytes, with the network fixed (preset tiny)', lambda r: r['config'] == 'tiny')):
    print('**%s.**\n' % title)
    print('| scene | network | file (bytes) | test PSNR (dB) | multiply-accumulates per ray | '
          'evaluations per ray | M4 per 100×100 frame, after | before | fewer |')
    print('|---|---|---|---|---|---|---|---|---|')
    for r in rows:
        if not pick(r): continue
        net = r['preset'] + ('' if r['mu'] == '0' else ', group penalty ' + r['mu'])
        psnr = r['psnr'] + ('' if r['psnr_before'] in ('', r['psnr']) else ' (%s before)' % r['psnr_before'])
        print('| %s | %s | %s | %s | %s | %s | %s | %s | %s |' % (
            r['scene'], net, n(r['bytes']), psnr, n(r['macs']), r['evals'], mi(r['ipr']),
            mi(r['ipr_before']) if r['ipr_before'] else '–', gain(r)))
    print()
EOF
  exit 0
fi
scenes=() iters=1500 threads=2 max_size=100
while [ $# -gt 0 ]; do
  case $1 in
    --iters) iters=$2; shift 2 ;;
    --threads) threads=$2; shift 2 ;;
    --max-size) max_size=$2; shift 2 ;;
    *=*) scenes+=("$1"); shift ;;
    *) echo "complexity: unknown argument $1" >&2; exit 2 ;;
  esac
done
[ ${#scenes[@]} -gt 0 ] || { echo "complexity: name at least one scene, NAME=DATASET" >&2; exit 2; }
configs=${CONFIGS:-"tiny:tiny:0:8000 tiny:tiny:0:15000 tiny:tiny:0:30000 small:small:0:15000 tiny-gp:tiny:0.01:15000"}
cnerf=${CNERF:-build/cnerf}
[ -x "$cnerf" ] || { echo "complexity: $cnerf: build it first (or set CNERF)" >&2; exit 1; }
if [ -n "${BEFORE:-}" ]; then
  [ -x "$BEFORE/scripts/firmware.sh" ] || { echo "complexity: BEFORE=$BEFORE has no scripts/firmware.sh" >&2; exit 1; }
fi
mkdir -p "$out/files" "$out/log"
out=$(cd "$out" && pwd) csv=$(cd "$out" && pwd)/complexity.csv
[ -s "$csv" ] ||
  echo "scene,config,preset,mu,target,bytes,psnr,psnr_before,view,w,h,macs,evals,ipr,ipr_before" > "$csv"
after_q30=$(sed -n 's/^#define CNERF_T_STOP_DEFAULT \([0-9]*\)u.*/\1/p' include/cnerf/cnerf.h)
ipr_of() { sed -n 's/.*: \([0-9,]*\) instructions per ray.*/\1/p' <<<"$1" | tr -d ,; }

for s in "${scenes[@]}"; do
  name=${s%%=*} data=${s#*=} every=1
  case $data in *@*) every=${data##*@} data=${data%@*} ;; esac
  for c in $configs; do
    IFS=: read -r cfg preset mu target <<<"$c"
    grep -q "^$name,$cfg,$preset,$mu,$target," "$csv" && continue
    f=$out/files/$name-$cfg-$target.cnrf
    echo "== $name $cfg $target" >&2
    gp=()
    [ "$mu" = 0 ] || gp=(--group-penalty "$mu")
    # a stream left by an interrupted run is complete (written atomically) once its
    # checkpoint is gone
    [ -s "$f" ] && [ ! -e "$f.ckpt" ] ||
    "$cnerf" encode "$data" -o "$f" --size "$target" --preset "$preset" "${gp[@]}" \
      --iters "$iters" --max-size "$max_size" --threads "$threads" --seed 1 --force \
      --log-every 500 --every "$every" > "$out/log/$name-$cfg-$target.log" 2>&1 ||
      grep -q "the target of .* (the file is written)" "$out/log/$name-$cfg-$target.log" ||
      { tail -n 5 "$out/log/$name-$cfg-$target.log" >&2; exit 1; }
    rm -f "$f.ckpt"
    bytes=$(stat -c %s "$f")
    r=$("$cnerf" render "$f" --dataset "$data" --max-size "$max_size" --split test \
        --every "$every" --save-cameras "$out/files/$name-$cfg-$target.cam")
    psnr=$(sed -n 's/^mean over .* psnr \([0-9.]*\) dB .*/\1/p' <<<"$r")
    evals=$(sed -n 's/^network evaluations per ray: \([0-9.]*\).*/\1/p' <<<"$r")
    macs=$(sed -n 's/^network multiply-accumulates per ray: \([0-9,]*\).*/\1/p' <<<"$r" | tr -d ,)
    cam1=$out/files/$name-$cfg-$target.cam1
    head -n 1 "$out/files/$name-$cfg-$target.cam" > "$cam1"
    read -r -a cam < "$cam1"
    w=${cam[16]} h=${cam[17]} view=${cam[18]}
    samples=$("$cnerf" info --no-estimate "$f" | sed -n 's/^samples: \([0-9]*\) coarse + \([0-9]*\) fine.*/\1 \2/p')
    fw=$(FW_BUILD_DIR=$out/fw-after-$name FW_TIMEOUT=6000 scripts/firmware.sh "$f" "$cam1" "0 0 $w $h" $samples \
         "$after_q30" 2>&1) || { echo "$fw" >&2; exit 1; }
    ipr=$(ipr_of "$fw")
    psnr_b="" ipr_b=""
    if [ -n "${BEFORE:-}" ]; then
      r=$("$cnerf" render "$f" --dataset "$data" --max-size "$max_size" --split test \
          --every "$every" --t-stop 0.000244140625)
      psnr_b=$(sed -n 's/^mean over .* psnr \([0-9.]*\) dB .*/\1/p' <<<"$r")
      fw=$(cd "$BEFORE" && FW_BUILD_DIR=$out/fw-before-$name FW_TIMEOUT=6000 scripts/firmware.sh "$f" "$cam1" \
           "0 0 $w $h" $samples 262144 2>&1) || { echo "$fw" >&2; exit 1; }
      ipr_b=$(ipr_of "$fw")
    fi
    echo "$name,$cfg,$preset,$mu,$target,$bytes,$psnr,$psnr_b,$view,$w,$h,$macs,$evals,$ipr,$ipr_b" >> "$csv"
  done
done
