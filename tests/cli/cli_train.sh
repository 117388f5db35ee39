#!/usr/bin/env bash
# cnerf train / eval / encode on the shared Lego at 25x25: files appear, numbers print,
# Ctrl-C saves a checkpoint and exits 130, --resume continues, bad input fails clearly.
set -euo pipefail
cnerf=$1 data=$2 work=$3 render_tile=$4
shared=$data
rm -rf "$work" && mkdir -p "$work"
# (Lego and Mic with 10 training and 10 validation views: each run reads fewer images)
data=$(bash "$(dirname "$0")/few_views.sh" "$data" "$work/data")
fail() { echo "FAIL: $*" >&2; exit 1; }
common=(--preset tiny --downscale 16 --batch 64 --coarse 8 --fine 8 --threads 2)

out=$("$cnerf" train "$data/lego" -o "$work/m.ckpt" --iters 4 --log-every 2 --eval-every 3 \
  --every 100 "${common[@]}")
grep -q "iter 4/4" <<<"$out" || fail "train printed no progress: $out"
# The end of a run: its validation PSNR (Lego's own val views) beside the training views'.
grep -q "^validation: psnr [0-9.]* dB on 10 held-out views, [0-9.]* dB on the training views (1024 fixed rays each)" \
  <<<"$out" || fail "train printed no validation: $out"
grep -q "saved $work/m.ckpt at iteration 4" <<<"$out" || fail "train summary: $out"
[ -s "$work/m.ckpt" ] || fail "no checkpoint"
# --eval-every: at iteration 3 and after the last, the test PSNR of the model so far.
grep -q "^eval: iteration 3, training [0-9.]* s, test psnr [0-9.]* dB, ssim -\?[0-9.]*, 2 views" \
  <<<"$out" || fail "train --eval-every: $out"
train_eval=$(sed -n 's/^eval: iteration 4, .* test psnr \([0-9.]*\) dB.*/\1/p' <<<"$out")

out=$("$cnerf" eval "$work/m.ckpt" "$data/lego" --downscale 16 --every 100 -o "$work/ev")
grep -q "mean over 2 test views (iteration 4)" <<<"$out" || fail "eval summary: $out"
# The last periodic evaluation is the checkpoint's.
grep -q "mean over 2 test views (iteration 4): psnr $train_eval dB" <<<"$out" ||
  fail "eval of the checkpoint differs from train's last evaluation ($train_eval): $out"
[ -s "$work/ev/r_0.png" ] && [ -s "$work/ev/r_100.png" ] || fail "eval wrote no PNGs"
# --view-width 0: no view branch (fewer parameters), the colour from the trunk; the model
# evaluates like any other.
out=$("$cnerf" train "$data/lego" -o "$work/vw.ckpt" --iters 2 --view-width 0 "${common[@]}")
p_vw=$(sed -n 's/^model: .* \([0-9]*\) parameters$/\1/p' <<<"$out")
p_m=$("$cnerf" train "$data/lego" -o "$work/vw1.ckpt" --iters 2 "${common[@]}" | sed -n 's/^model: .* \([0-9]*\) parameters$/\1/p')
[ -n "$p_vw" ] && [ -n "$p_m" ] && [ "$p_vw" -lt "$p_m" ] || fail "--view-width 0: $p_vw against $p_m parameters"
"$cnerf" eval "$work/vw.ckpt" "$data/lego" --downscale 16 --every 100 > /dev/null || fail "eval of --view-width 0"

# Ctrl-C: a checkpoint of the iterations done, exit status 130; --resume continues.
# A background job of a non-interactive shell starts with SIGINT ignored, and a training
# keeps a signal its caller ignores (as nohup asks): job control (set -m) starts it as a
# terminal's foreground job would, with SIGINT at its default.
set -m
"$cnerf" train "$data/lego" -o "$work/int.ckpt" --iters 100000 "${common[@]}" \
  > "$work/int.log" 2>&1 &
pid=$!
set +m
# (a signal before the first progress line would stop the process before it takes SIGINT:
# wait for that line, up to 5 minutes on a loaded machine)
for _ in $(seq 1500); do grep -q "iter" "$work/int.log" 2>/dev/null && break; sleep 0.2; done
sleep 1
kill -INT $pid
set +e; wait $pid; rc=$?; set -e
[ $rc -eq 130 ] || fail "interrupted train exited $rc, want 130: $(cat "$work/int.log")"
grep -q "interrupted by SIGINT: saved $work/int.ckpt at iteration" "$work/int.log" || fail "no save on Ctrl-C"
done_its=$(sed -n 's/.*interrupted by SIGINT: saved .* at iteration \([0-9]*\).*/\1/p' "$work/int.log")
out=$("$cnerf" train "$data/lego" -o "$work/int.ckpt" --iters $((done_its + 2)) --resume "${common[@]}")
grep -q "resumed $work/int.ckpt at iteration $done_its" <<<"$out" || fail "resume: $out"
grep -q "at iteration $((done_its + 2))" <<<"$out" || fail "resume did not continue: $out"
# Resuming a checkpoint that is already at --iters trains nothing and says so.
cp "$work/int.ckpt" "$work/int-before.ckpt"
out=$("$cnerf" train "$data/lego" -o "$work/int.ckpt" --iters $((done_its + 2)) --resume "${common[@]}")
grep -q "^$work/int.ckpt is at iteration $((done_its + 2)) of $((done_its + 2)): nothing to train" \
  <<<"$out" || fail "resume at --iters: $out"
! grep -q "train psnr" <<<"$out" || fail "resume at --iters reports a training run: $out"
cmp -s "$work/int.ckpt" "$work/int-before.ckpt" || fail "resume at --iters rewrote the checkpoint"
# The occupancy grids resume with the model; a run that asks for another grid size says
# that its grids are rebuilt.
grid=(--occupancy 8 --occupancy-start 2 "${common[@]}")
"$cnerf" train "$data/lego" -o "$work/g.ckpt" --iters 4 "${grid[@]}" > /dev/null
out=$("$cnerf" train "$data/lego" -o "$work/g.ckpt" --iters 5 --resume "${grid[@]}")
grep -q "^resumed $work/g.ckpt at iteration 4$" <<<"$out" || fail "resume with its grids: $out"
out=$("$cnerf" train "$data/lego" -o "$work/g.ckpt" --iters 6 --resume "${grid[@]}" --occupancy 16)
grep -q "^resumed $work/g.ckpt at iteration 5 (occupancy grids rebuilt from the model" \
  <<<"$out" || fail "resume with another grid size: $out"

out=$("$cnerf" encode "$data/lego" -o "$work/s.cnrf" --lambda 1e-3 --iters 3 --every 100 \
  --eval-every 2 "${common[@]}")
grep -q "wrote $work/s.cnrf: [0-9]* bytes = latent payload" <<<"$out" || fail "encode: $out"
grep -q "^eval: iteration 2, .* 2 views" <<<"$out" || fail "encode --eval-every: $out"
grep -q "^rate: prior estimate [0-9]* bytes for the integer latents, coded payload [0-9]* bytes" \
  <<<"$out" || fail "encode rate figure: $out"
grep -q "test: 2 views, psnr" <<<"$out" || fail "encode test views: $out"
grep -q "^random backgrounds: [0-9]* of [0-9]* training views have transparency" <<<"$out" \
  || fail "encode on Lego: random backgrounds line: $out"
grep -q "^dead units removed: coarse [0-9+]* of 4 x 64, view [0-9]* of 32; fine " <<<"$out" \
  || fail "encode: dead units line: $out"
# Outputs are captured before grep: with pipefail, `cnerf ... | grep -q` fails when grep exits
# at its match before cnerf has written its last line, which then dies of SIGPIPE.
grep -q "samples: 8 coarse + 8 fine" <<<"$("$cnerf" info --no-estimate "$work/s.cnrf")" || fail "info of encoded file"
# eval of a stream renders its float reference model: the same PSNR that encode printed.
enc_psnr=$(sed -n 's/^test: 2 views, psnr \([0-9.]*\) dB.*/\1/p' <<<"$out")
out=$("$cnerf" eval "$work/s.cnrf" "$data/lego" --downscale 16 --every 100)
grep -q "mean over 2 test views (stream): psnr $enc_psnr dB" <<<"$out" || fail "eval of stream ($enc_psnr): $out"

# render: the fixed-point decoder on the same file; its float reference is eval's render, so
# the reference PSNR it prints is the one encode printed. --verify checks the frames' md5.
out=$("$cnerf" render "$work/s.cnrf" --dataset "$data/lego" --downscale 16 --every 100 -o "$work/r")
grep -q "mean over 2 views (fixed point, 8+8 samples.*(float reference $enc_psnr dB)  vs float" <<<"$out" \
  || fail "render ($enc_psnr): $out"
[ -s "$work/r/r_0.png" ] && [ -s "$work/r/r_100.png" ] || fail "render wrote no PNGs"
md5=$(sed -n 's/^md5 of all frames: //p' <<<"$out")
out=$("$cnerf" render "$work/s.cnrf" --dataset "$data/lego" --downscale 16 --every 100 --verify "$md5")
grep -q "verified: $md5" <<<"$out" || fail "render --verify of its own md5"

# The occupancy grid: a forced 16^3 grid is written, shown by info, applied by
# eval (the PSNR encode printed) and counted by render, which --no-skip turns off.
out=$("$cnerf" encode "$data/lego" -o "$work/gr.cnrf" --lambda 1e-3 --iters 3 --every 100 \
  --grid 16 --prune off "${common[@]}")
! grep -q "^dead units removed" <<<"$out" || fail "encode --prune off pruned: $out"
grep -q "^occupancy grid: 16^3, [0-9.]*% of the cells occupied, [0-9]* bytes" <<<"$out" \
  || fail "encode --grid 16: $out"
info=$("$cnerf" info --no-estimate "$work/gr.cnrf")
grep -q "format version 2.3" <<<"$info" || fail "info: version of a stream with a grid: $info"
grep -q "^occupancy grid: 16^3 cells, [0-9]* bytes (by blocks: [0-9] of 8 blocks of 8^3 occupied), [0-9]* occupied" <<<"$info" \
  || fail "info: grid line: $info"
enc_psnr=$(sed -n 's/^test: 2 views, psnr \([0-9.]*\) dB.*/\1/p' <<<"$out")
out=$("$cnerf" eval "$work/gr.cnrf" "$data/lego" --downscale 16 --every 100)
grep -q "mean over 2 test views (stream): psnr $enc_psnr dB" <<<"$out" \
  || fail "eval of a stream with a grid ($enc_psnr): $out"
out=$("$cnerf" render "$work/gr.cnrf" --dataset "$data/lego" --downscale 16 --every 100)
grep -q "^network evaluations per ray: [0-9.]* ([0-9.]* without skipping)$" <<<"$out" \
  || fail "render: evaluations per ray: $out"
grep -q "^network multiply-accumulates per ray: [1-9][0-9]* ([1-9][0-9]* per evaluation)$" <<<"$out" \
  || fail "render: multiply-accumulates per ray: $out"
out=$("$cnerf" render "$work/gr.cnrf" --dataset "$data/lego" --downscale 16 --every 100 --no-skip)
grep -q "^network evaluations per ray: \([0-9.]*\) (\1 without skipping; --no-skip" <<<"$out" \
  || fail "render --no-skip: $out"
info=$("$cnerf" info --no-estimate "$work/s.cnrf")
grep -q "format version 2.0" <<<"$info" || fail "a stream without a grid is 2.0 too: $info"
# --coarse-color: off (the default) sends no colour for the coarse network, so its image
# alone (--fine 0) is refused with a reason; on sends it and renders that image.
grep -q "^network 0 (coarse): .*; no colour (density only)$" <<<"$info" \
  || fail "info: the coarse network's colour is not sent by default: $info"
grep -q "^network 1 (fine): .*linear layers$" <<<"$info" || fail "info: the fine network: $info"
set +e
msg=$("$cnerf" render "$work/s.cnrf" --dataset "$data/lego" --downscale 16 --every 100 --fine 0 2>&1)
rc=$?
[ $rc = 1 ] && grep -q "does not carry the coarse network's colour (encoded with --coarse-color off" \
  <<<"$msg" || fail "render --fine 0 of a stream without the coarse colour: $rc $msg"
msg=$("$cnerf" encode "$data/lego" -o "$work/z.cnrf" --lambda 1 --coarse-color maybe 2>&1); rc=$?
[ $rc = 2 ] && grep -q -- "--coarse-color takes off (the default" <<<"$msg" \
  || fail "--coarse-color maybe: $rc $msg"
[ ! -e "$work/z.cnrf" ] || fail "--coarse-color maybe wrote a file"
set -e
out=$("$cnerf" encode "$data/lego" -o "$work/cc.cnrf" --lambda 1e-3 --iters 3 --every 100 \
  --coarse-color on --grid 0 "${common[@]}")
! grep -q "no colour" <<<"$("$cnerf" info --no-estimate "$work/cc.cnrf")" || fail "info: --coarse-color on"
out=$("$cnerf" render "$work/cc.cnrf" --dataset "$data/lego" --downscale 16 --every 100 --fine 0)
grep -q "mean over 2 views (fixed point, 8+0 samples" <<<"$out" || fail "render --fine 0: $out"
[ "$(stat -c %s "$work/cc.cnrf")" -gt "$(stat -c %s "$work/s.cnrf")" ] \
  || fail "--coarse-color on is not larger than off"
# --precrop-iters 0 draws the first iterations' rays from the whole views (a model from
# --init needs no centre crop): the same command otherwise trains other latents.
"$cnerf" encode "$data/lego" -o "$work/pc.cnrf" --lambda 1e-3 --iters 3 --every 100 \
  --coarse-color on --grid 0 --precrop-iters 0 "${common[@]}" > /dev/null
cmp -s "$work/pc.cnrf" "$work/cc.cnrf" && fail "encode --precrop-iters 0 changed nothing"
# From --init the default is --precrop-iters 0; a crop asked for is still taken.
for pc in "" "--precrop-iters 0" "--precrop-iters 500"; do
  "$cnerf" encode "$data/lego" -o "$work/init${pc##* }.cnrf" --lambda 1e-3 --iters 3 \
    --every 100 --grid 0 --init "$work/m.ckpt" $pc "${common[@]}" > /dev/null
done
cmp -s "$work/init.cnrf" "$work/init0.cnrf" || fail "encode --init: the default is not --precrop-iters 0"
cmp -s "$work/init.cnrf" "$work/init500.cnrf" && fail "encode --init --precrop-iters 500 changed nothing"
# --average N writes the mean of the last N iterations' parameters: another file than the
# last iteration's; more iterations than the run has are refused.
"$cnerf" encode "$data/lego" -o "$work/avg.cnrf" --lambda 1e-3 --iters 3 --every 100 \
  --grid 0 --init "$work/m.ckpt" --average 2 "${common[@]}" > /dev/null
cmp -s "$work/init.cnrf" "$work/avg.cnrf" && fail "encode --average 2 changed nothing"
set +e
msg=$("$cnerf" encode "$data/lego" -o "$work/z.cnrf" --lambda 1e-3 --iters 3 --average 4 2>&1)
rc=$?
[ $rc = 2 ] && grep -q "give at most --iters" <<<"$msg" || fail "--average 4 of 3: $rc $msg"
[ ! -e "$work/z.cnrf" ] || fail "--average 4 of 3 wrote a file"
set -e
# The float phase: by default a quarter of the run trains the latents unrounded (2 of 8
# iterations here), which the stream's text records; --float-iters 0 rounds from the first
# iteration and trains other latents. Refused: a phase as long as the run, one after --init.
"$cnerf" encode "$data/lego" -o "$work/fp.cnrf" --lambda 1e-3 --iters 8 --every 100 --grid 0 \
  "${common[@]}" > /dev/null
"$cnerf" encode "$data/lego" -o "$work/fp0.cnrf" --lambda 1e-3 --iters 8 --every 100 --grid 0 \
  --float-iters 0 "${common[@]}" > /dev/null
cmp -s "$work/fp.cnrf" "$work/fp0.cnrf" && fail "encode --float-iters 0 changed nothing"
grep -q "float-iters=2;" <<<"$("$cnerf" info --no-estimate "$work/fp.cnrf")" || fail "info: no float-iters=2"
grep -q "float-iters=0;" <<<"$("$cnerf" info --no-estimate "$work/fp0.cnrf")" || fail "info: no float-iters=0"
set +e
msg=$("$cnerf" encode "$data/lego" -o "$work/z.cnrf" --lambda 1e-3 --iters 3 --float-iters 3 2>&1)
rc=$?
[ $rc = 2 ] && grep -q "leaves no iteration" <<<"$msg" || fail "--float-iters 3 of 3: $rc $msg"
msg=$("$cnerf" encode "$data/lego" -o "$work/z.cnrf" --lambda 1e-3 --iters 3 --init "$work/m.ckpt" \
  --float-iters 1 2>&1)
rc=$?
[ $rc = 2 ] && grep -q "leave out --float-iters" <<<"$msg" || fail "--init --float-iters: $rc $msg"
[ ! -e "$work/z.cnrf" ] || fail "a refused --float-iters wrote a file"
set -e
# quantize sends the coarse colour unless --coarse-color off; without it every image with
# fine samples is the same bits, and the file is smaller.
"$cnerf" quantize "$work/m.ckpt" -o "$work/q1.cnrf" --bits 6 > /dev/null
"$cnerf" quantize "$work/m.ckpt" -o "$work/q0.cnrf" --bits 6 --coarse-color off > /dev/null
! grep -q "no colour" <<<"$("$cnerf" info --no-estimate "$work/q1.cnrf")" || fail "quantize: coarse colour"
grep -q "no colour" <<<"$("$cnerf" info --no-estimate "$work/q0.cnrf")" || fail "quantize --coarse-color off"
[ "$(stat -c %s "$work/q0.cnrf")" -lt "$(stat -c %s "$work/q1.cnrf")" ] \
  || fail "quantize --coarse-color off is not smaller"
for q in q0 q1; do
  out=$("$cnerf" render "$work/$q.cnrf" --dataset "$data/lego" --downscale 16 --every 100)
  sed -n 's/^md5 of all frames: //p' <<<"$out" > "$work/$q.md5"
done
[ -s "$work/q0.md5" ] && cmp -s "$work/q0.md5" "$work/q1.md5" \
  || fail "quantize --coarse-color off changed the images"
set +e
msg=$("$cnerf" encode "$data/lego" -o "$work/z.cnrf" --lambda 1 --grid 12 2>&1); rc=$?
[ $rc = 2 ] && grep -q "\-\-grid takes 16, 32, 64 or 128" <<<"$msg" || fail "--grid 12: $rc $msg"
[ ! -e "$work/z.cnrf" ] || fail "--grid 12 wrote a file"
msg=$("$cnerf" synth -o "$work/z.cnrf" --grid 16 --grid-shape cube 2>&1); rc=$?
[ $rc = 2 ] && grep -q "\-\-grid-shape takes ball, full or empty, not 'cube'" <<<"$msg" \
  || fail "synth --grid-shape cube: $rc $msg"
[ ! -e "$work/z.cnrf" ] || fail "synth --grid-shape cube wrote a file"
msg=$("$cnerf" encode "$data/lego" -o "$work/z.cnrf" --lambda 1 --random-bg sometimes 2>&1); rc=$?
[ $rc = 2 ] && grep -q "\-\-random-bg takes auto, on or off, not 'sometimes'" <<<"$msg" \
  || fail "--random-bg sometimes: $rc $msg"
msg=$("$cnerf" encode "$data/lego" -o "$work/z.cnrf" --lambda 1 --prune yes 2>&1); rc=$?
[ $rc = 2 ] && grep -q "\-\-prune takes on (remove dead units) or off, not 'yes'" <<<"$msg" \
  || fail "--prune yes: $rc $msg"
msg=$("$cnerf" encode "$data/lego" -o "$work/z.cnrf" --lambda 1 --background far 2>&1); rc=$?
[ $rc = 2 ] && grep -q -- "--background takes auto, constant or contract, not 'far'" <<<"$msg" ||
  fail "--background far: $rc $msg"
msg=$("$cnerf" encode "$data/fern" -o "$work/z.cnrf" --lambda 1 --background contract \
  "${common[@]}" 2>&1); rc=$?
[ $rc = 1 ] && grep -q "forward-facing scene is rendered in NDC" <<<"$msg" ||
  fail "--background contract on Fern: $rc $msg"
msg=$("$cnerf" synth -o "$work/z.cnrf" --ndc --contract 2>&1); rc=$?
[ $rc = 2 ] && grep -q -- "--ndc and --contract exclude each other" <<<"$msg" ||
  fail "synth --ndc --contract: $rc $msg"
msg=$("$cnerf" synth -o "$work/z.cnrf" --units 8,8 2>&1); rc=$?
[ $rc = 2 ] && grep -q "2 trunk layers given, the networks have 4" <<<"$msg" \
  || fail "synth --units 8,8: $rc $msg"
msg=$("$cnerf" synth -o "$work/z.cnrf" --units 8,8,99,8 2>&1); rc=$?
[ $rc = 2 ] && grep -q "99 units in trunk layer 2, more than the width 64" <<<"$msg" \
  || fail "synth --units 8,8,99,8: $rc $msg"
[ ! -e "$work/z.cnrf" ] || fail "a refused option wrote a file"
"$cnerf" synth -o "$work/u.cnrf" --units 8,3,16,64:5 > /dev/null
info=$("$cnerf" info --no-estimate "$work/u.cnrf")
grep -q "format version 2.0" <<<"$info" && grep -q "^units per layer (UNIT chunk, 32 bytes): network 0 trunk 8 3 16 64, view 5; network 1 trunk 8 3 16 64, view 5$" <<<"$info" \
  || fail "info of a stream with narrower layers: $info"
set -e
set +e
msg=$("$cnerf" render "$work/s.cnrf" --dataset "$data/lego" --downscale 16 --every 100 \
      --verify 00000000000000000000000000000000 2>&1); rc=$?
set -e
[ $rc -ne 0 ] && grep -q "verification failed" <<<"$msg" || fail "render --verify mismatch: $rc $msg"
# --save-cameras writes the fixed-point camera of every view, one line each; render_tile
# renders the same bytes from it with nothing but the decoder.
out=$("$cnerf" render "$work/s.cnrf" --dataset "$data/lego" --downscale 16 --every 100 \
      --save-cameras "$work/cams.txt")
[ "$(wc -l < "$work/cams.txt")" -eq 2 ] || fail "--save-cameras: $(cat "$work/cams.txt")"
read -r -a cam < <(sed -n 2p "$work/cams.txt")
[ "${#cam[@]}" -eq 19 ] && [ "${cam[18]}" = r_100 ] || fail "camera line: ${cam[*]}"
sed -n 2p "$work/cams.txt" > "$work/cam_r100.txt"
want=$(sed -n 's/^  r_100 .* md5 \([0-9a-f]*\)$/\1/p' <<<"$out")
got=$("$render_tile" "$work/s.cnrf" "$work/cam_r100.txt" 0 0 "${cam[16]}" "${cam[17]}" | md5sum | cut -c1-32)
[ -n "$want" ] && [ "$got" = "$want" ] || fail "render_tile from the saved camera: $got, want $want"
set +e
msg=$("$cnerf" render "$work/s.cnrf" --orbit 1 --size 4 --save-cameras "$work/no/such/c.txt" 2>&1); rc=$?
set -e
[ $rc -ne 0 ] && grep -q "no/such/c.txt" <<<"$msg" || fail "--save-cameras to a bad path: $rc $msg"
out=$("$cnerf" render "$work/s.cnrf" --orbit 2 --size 12)
grep -q "mean over 2 views (fixed point" <<<"$out" || fail "render --orbit: $out"
# --no-reference: the same pixels, no float reference
nr=$("$cnerf" render "$work/s.cnrf" --orbit 2 --size 12 --no-reference)
[ "$(grep '^md5 of all' <<<"$nr")" = "$(grep '^md5 of all' <<<"$out")" ] &&
  grep -q "ms/frame$" <<<"$nr" && ! grep -Eq "float|cost model" <<<"$nr" &&
  grep -q "cost model" <<<"$out" || fail "render --no-reference: $nr"
set +e
msg=$("$cnerf" render "$work/s.cnrf" --orbit 2 --coarse 9 2>&1); rc=$?
set -e
[ $rc -ne 0 ] && grep -q "asks for more" <<<"$msg" || fail "render with too many samples: $rc $msg"

# quantize: the baseline stream of a float checkpoint, readable by eval and info.
out=$("$cnerf" quantize "$work/m.ckpt" -o "$work/q.cnrf" --bits 6)
grep -q "wrote $work/q.cnrf: [0-9]* bytes" <<<"$out" || fail "quantize: $out"
"$cnerf" info --no-estimate "$work/q.cnrf" > /dev/null || fail "info of quantized file"
out=$("$cnerf" eval "$work/q.cnrf" "$data/lego" --downscale 16 --every 100)
grep -q "mean over 2 test views (stream)" <<<"$out" || fail "eval of quantized file"

# --skip-saturated: the fine network skips samples behind the coarse surface from
# --occupancy-start on; the run trains and saves as usual.
out=$("$cnerf" train "$data/lego" -o "$work/sat.ckpt" --iters 3 --occupancy-start 1 \
  --skip-saturated 1e-3 "${common[@]}")
grep -q "saved $work/sat.ckpt at iteration 3" <<<"$out" || fail "train --skip-saturated: $out"

# Bad input: clear messages, non-zero exits, nothing written.
set +e
msg=$("$cnerf" encode "$data/lego" -o "$work/y.cnrf" --lambda 1 --prior-lr 2 2>&1); rc=$?
set -e
[ $rc -ne 0 ] && grep -q -- "--prior-lr: expected a number in \[0, 1\]" <<<"$msg" ||
  fail "encode --prior-lr 2: $rc $msg"
set +e
msg=$("$cnerf" train "$data/lego" -o "$work/y.ckpt" --skip-saturated -1 2>&1); rc=$?
set -e
[ $rc -ne 0 ] && grep -q -- "--skip-saturated" <<<"$msg" || fail "train --skip-saturated -1: $rc $msg"
[ ! -e "$work/y.ckpt" ] || fail "a checkpoint was written for a bad option"
set +e
mkdir -p "$work/notds"
msg=$("$cnerf" train "$work/notds" -o "$work/x.ckpt" 2>&1); rc=$?
set -e
[ $rc -ne 0 ] && grep -q "unknown dataset layout" <<<"$msg" || fail "bad dataset: $rc $msg"
[ ! -e "$work/x.ckpt" ] || fail "a checkpoint was written for a bad dataset"
set +e
msg=$("$cnerf" encode "$data/lego" -o "$work/y.cnrf" 2>&1); rc=$?
set -e
[ $rc -ne 0 ] && grep -q "lambda" <<<"$msg" || fail "encode without lambda: $rc $msg"
set +e
msg=$("$cnerf" encode "$data/lego" -o "$work/y.cnrf" --lambda 1 --latent-lr fast 2>&1); rc=$?
set -e
[ $rc -ne 0 ] && grep -q "latent-lr takes" <<<"$msg" || fail "encode --latent-lr fast: $rc $msg"
[ ! -e "$work/y.cnrf" ] || fail "a stream was written for a bad option"
set +e
msg=$("$cnerf" train "$data/lego" -o "$work/z.ckpt" --iters -5 2>&1); rc=$?
set -e
[ $rc -ne 0 ] && grep -q -- "--iters" <<<"$msg" || fail "negative iters: $rc $msg"
set +e
msg=$("$cnerf" quantize "$work/s.cnrf" -o "$work/q2.cnrf" 2>&1); rc=$?
set -e
[ $rc -ne 0 ] && grep -q "not a cnerf checkpoint" <<<"$msg" || fail "quantize of a stream: $rc $msg"
[ ! -e "$work/q2.cnrf" ] || fail "quantize wrote a file for bad input"
set +e
msg=$("$cnerf" quantize "$work/m.ckpt" -o "$work/q3.cnrf" --bits 1 2>&1); rc=$?
set -e
[ $rc -ne 0 ] && grep -q -- "--bits" <<<"$msg" || fail "quantize --bits 1: $rc $msg"
printf 'garbage' > "$work/bad.cnrf"
set +e
msg=$("$cnerf" eval "$work/bad.cnrf" "$data/lego" --downscale 16 2>&1); rc=$?
set -e
[ $rc -ne 0 ] && grep -q "bad.cnrf" <<<"$msg" || fail "eval of garbage: $rc $msg"
head -c 100 "$work/s.cnrf" > "$work/cut.cnrf"
set +e
msg=$("$cnerf" eval "$work/cut.cnrf" "$data/lego" --downscale 16 2>&1); rc=$?
set -e
[ $rc -ne 0 ] && grep -q "cut.cnrf: the decoder refuses the stream: CNERF_E_TRUNCATED" <<<"$msg" \
  || fail "eval of a truncated stream: $rc $msg"
# cnerf views writes the training views as the trainer sees them, and --train-images trains
# on such files: Fern's 8-bit views at full size come back exactly, so the run is the same
# to the bit; a path through every view, each once, for a video coder. Of Fern's 17
# training views one is held out for validation by every command alike (views, train, eval).
out=$("$cnerf" views "$data/fern" -o "$work/fv")
grep -q "^views: 16 train views of $data/fern, 504x378" <<<"$out" || fail "views: $out"
out=$("$cnerf" views "$data/fern" -o "$work/fvv" --split val)
grep -q "^views: 1 val views of $data/fern, 504x378" <<<"$out" || fail "views --split val: $out"
[ "$(sort "$work/fv/order.txt" | tr '\n' ' ')" = "$(cd "$work/fv" && ls 0*.png | tr '\n' ' ')" ] ||
  fail "views: order.txt is not a path through every view: $(cat "$work/fv/order.txt")"
fern=(--preset tiny --batch 64 --coarse 8 --fine 8 --threads 2 --iters 2)
"$cnerf" train "$data/fern" -o "$work/f1.ckpt" "${fern[@]}" > /dev/null
out=$("$cnerf" train "$data/fern" -o "$work/f2.ckpt" --train-images "$work/fv" "${fern[@]}")
grep -q "^training views: the 16 images in $work/fv instead of the dataset's" <<<"$out" ||
  fail "train --train-images: $out"
cmp -s "$work/f1.ckpt" "$work/f2.ckpt" || fail "train --train-images on the views as written differs"
# Other pixels train another model.
cp -r "$work/fv" "$work/fvx" && cp "$work/fv/0001.png" "$work/fvx/0000.png"
"$cnerf" train "$data/fern" -o "$work/f3.ckpt" --train-images "$work/fvx" "${fern[@]}" > /dev/null
cmp -s "$work/f1.ckpt" "$work/f3.ckpt" && fail "train --train-images: another view 0 changed nothing"
# A contracted scene (format 2.2): encoded, described, its float reference evaluated and its
# fixed-point render within a few grey levels of it.
out=$("$cnerf" encode "$data/lego" -o "$work/c.cnrf" --lambda 1e-3 --iters 3 --every 100 \
  --background contract "${common[@]}")
info=$("$cnerf" info --no-estimate "$work/c.cnrf")
grep -q "format version 2.2" <<<"$info" && grep -q "^render: contracted" <<<"$info" ||
  fail "info of a contracted stream: $info"
c_psnr=$(sed -n 's/^test: .* psnr \([0-9.]*\) dB.*/\1/p' <<<"$out")
out=$("$cnerf" render "$work/c.cnrf" --dataset "$data/lego" --downscale 16 --every 100)
grep -q "^mean over 2 views .*(float reference $c_psnr dB)" <<<"$out" ||
  fail "render of a contracted stream ($c_psnr): $out"

# Several scenes in one stream: Lego and Mic encoded jointly, each scene read back, rendered
# and evaluated by index; the options that encode one scene only are refused.
out=$("$cnerf" encode "$data/lego" "$data/mic" -o "$work/set.cnrf" --lambda 1e-3 --iters 3 \
  --every 100 "${common[@]}")
grep -q "^encoding 2 scenes jointly, shifts shared" <<<"$out" || fail "encode a set: $out"
grep -q "^wrote $work/set.cnrf: [0-9]* bytes, 2 scenes, shared shifts [0-9]* bytes" <<<"$out" ||
  fail "encode a set: wrote line: $out"
grep -q "^scene 1: [0-9]* bytes of its own, test: 2 views, psnr" <<<"$out" ||
  fail "encode a set: scene 1's test line: $out"
set_psnr=$(sed -n 's/^scene 1: [0-9]* bytes of its own.* psnr \([0-9.]*\) dB.*/\1/p' <<<"$out")
for m in 0 1; do # each scene measured on its own held-out views
  grep -q "^scene $m: validation: psnr [0-9.]* dB on [0-9]* held-out views, [0-9.]* dB on the training views" \
    <<<"$out" || fail "encode a set: scene $m's validation line: $out"
done
info=$("$cnerf" info --no-estimate --check --scene 1 "$work/set.cnrf")
grep -q "^scenes: 2, sharing one topology" <<<"$info" || fail "info of a set: $info"
grep -q "file: [0-9]* bytes)$" <<<"$info" || fail "info of a set: totals: $info"
out=$("$cnerf" eval "$work/set.cnrf" "$data/mic" --scene 1 --every 100 --downscale 16 --threads 2)
grep -q "mean over 2 test views .* psnr $set_psnr dB" <<<"$out" || fail "eval --scene 1 ($set_psnr): $out"
# A set sends no coarse colour either by default (neither the scenes' layers nor the shared
# shifts of them): each scene's coarse image alone is refused; --coarse-color on sends it.
for m in 0 1; do
  grep -q "^network 0 (coarse): .*; no colour (density only)$" \
    <<<"$("$cnerf" info --no-estimate --scene $m "$work/set.cnrf")" || fail "info of a set's scene $m: colour"
done
grep -q "coarse-color=off; coarse-weight=0.1" <<<"$("$cnerf" info --no-estimate "$work/set.cnrf")" \
  || fail "set meta: coarse colour"
"$cnerf" encode "$data/lego" "$data/mic" -o "$work/setc.cnrf" --lambda 1e-3 --iters 3 \
  --every 100 --coarse-color on --grid 0 "${common[@]}" > /dev/null
! grep -q "no colour" <<<"$("$cnerf" info --no-estimate --scene 1 "$work/setc.cnrf")" || fail "set: --coarse-color on"
[ "$(stat -c %s "$work/setc.cnrf")" -gt "$(stat -c %s "$work/set.cnrf")" ] \
  || fail "set: --coarse-color on is not larger than off"
set +e
msg=$("$cnerf" render "$work/set.cnrf" --scene 1 --dataset "$data/mic" --downscale 16 --every 100 \
  --fine 0 2>&1); rc=$?
[ $rc = 1 ] && grep -q "does not carry the coarse network's colour" <<<"$msg" \
  || fail "render --fine 0 of a set's scene: $rc $msg"
msg=$("$cnerf" encode "$data/lego" "$data/mic" -o "$work/z.cnrf" --lambda 1 --coarse-color maybe \
  2>&1); rc=$?
[ $rc = 2 ] && grep -q -- "--coarse-color takes off" <<<"$msg" || fail "set --coarse-color maybe: $rc $msg"
msg=$("$cnerf" render "$work/set.cnrf" --orbit 1 --size 8 --scene 2 2>&1); rc=$?
[ $rc = 1 ] && grep -q "no scene 2: the stream has 2" <<<"$msg" || fail "render --scene 2: $rc $msg"
msg=$("$cnerf" encode "$data/lego" "$data/mic" -o "$work/z.cnrf" --size 9000 2>&1); rc=$?
[ $rc = 2 ] && grep -q "takes --lambda L or --quality Q" <<<"$msg" || fail "set --size: $rc $msg"
msg=$("$cnerf" encode "$data/lego" "$data/mic" -o "$work/z.cnrf" --lambda 1 --prune on 2>&1); rc=$?
[ $rc = 2 ] && grep -q "keeps every unit" <<<"$msg" || fail "set --prune on: $rc $msg"
msg=$("$cnerf" encode "$data/lego" "$data/mic" -o "$work/z.cnrf" --lambda 1 --average 2 2>&1); rc=$?
[ $rc = 2 ] && grep -q -- "--average encodes one scene" <<<"$msg" || fail "set --average: $rc $msg"
msg=$("$cnerf" encode "$data/lego" "$data/mic" -o "$work/z.cnrf" --lambda 1 --float-iters 2 2>&1); rc=$?
[ $rc = 2 ] && grep -q -- "--float-iters encodes one scene" <<<"$msg" || fail "set --float-iters: $rc $msg"
msg=$("$cnerf" encode "$data/lego" -o "$work/z.cnrf" --lambda 1 --shift-lr 0.01 2>&1); rc=$?
[ $rc = 2 ] && grep -q "this encode has one" <<<"$msg" || fail "one scene --shift-lr: $rc $msg"
msg=$("$cnerf" encode "$data/lego" "$data/lego" -o "$work/z.cnrf" --lambda 1 2>&1); rc=$?
[ $rc = 2 ] && grep -q "is given twice" <<<"$msg" || fail "set of one dataset twice: $rc $msg"
msg=$("$cnerf" encode "$data/lego" "$data/fern" -o "$work/z.cnrf" --lambda 1 --iters 1 \
  --every 100 "${common[@]}" 2>&1); rc=$?
[ $rc = 0 ] || fail "a 360-degree and a forward-facing scene in one set: $rc $msg"
# --bits-per-param X asks for X bits per latent the stream sends, the whole file counted: the
# coarse colour's latents count only when they are sent. Two iterations cannot reach the
# target (exit status 1 after writing the file); the target is what is checked.
latents() { sed -n 's/^encoding .*, \([0-9]*\) latents, checkpoint.*/\1/p' <<<"$1"; }
target() { sed -n 's/^rate control (dual): a file of \([0-9]*\) bytes (3.000 bits per latent).*/\1/p' <<<"$1"; }
for cc in off on; do
  msg=$("$cnerf" encode "$data/lego" -o "$work/bpp-$cc.cnrf" --bits-per-param 3 --coarse-color $cc \
    --iters 2 --every 100 "${common[@]}" 2>&1); rc=$?
  [ $rc -le 1 ] && [ -n "$(latents "$msg")" ] && [ -n "$(target "$msg")" ] ||
    fail "--bits-per-param 3 --coarse-color $cc: $rc $msg"
  [ "$(target "$msg")" = "$(awk -v n="$(latents "$msg")" 'BEGIN { printf "%.0f", 3 * n / 8 }')" ] ||
    fail "--bits-per-param 3 --coarse-color $cc: the target is not 3 bits per latent sent: $msg"
  eval "n_$cc=$(latents "$msg")"
done
[ "$n_off" -lt "$n_on" ] || fail "--bits-per-param counts the unsent coarse colour: $n_off, $n_on"
# --size without --preset: --preset auto gives the bits per latent sent beyond the floor.
for size in 12000 40000; do
  msg=$("$cnerf" encode "$data/lego" -o "$work/auto-$size.cnrf" --size $size --iters 2 --every 100 \
    --downscale 16 --batch 64 --threads 2 2>&1); rc=$?
  bits=$(sed -n 's/^preset auto: [a-z]* (\([0-9.]*\) bits per latent beyond.*/\1/p' <<<"$msg")
  floor=$(sed -n 's/^rate control .* the topology alone takes \([0-9]*\)$/\1/p' <<<"$msg")
  [ $rc -le 1 ] && [ -n "$bits" ] && [ -n "$floor" ] || fail "--size $size, preset auto: $rc $msg"
  awk -v b="$bits" -v f="$floor" -v n="$(latents "$msg")" -v s=$size \
    'BEGIN { d = b - 8 * (s - f) / n; exit !(d < 0.006 && d > -0.006) }' ||
    fail "--preset auto's bits are not per latent sent beyond the floor: $msg"
  want=tiny && [ $size = 12000 ] || want=small
  grep -q "^preset auto: $want " <<<"$msg" || fail "--size $size did not take $want: $msg"
done
# --preset auto resumes the preset its checkpoint holds, whichever the rule would take: an
# encode that stepped down to tiny (its trials, or fog) and was interrupted goes on with
# the command it printed. Here the checkpoint is tiny's, at a size where the rule takes small.
"$cnerf" encode "$data/lego" -o "$work/ar.cnrf" --preset tiny --size 40000 --iters 2 \
  --every 100 --downscale 16 --batch 64 --threads 2 > /dev/null 2>&1
[ -s "$work/ar.cnrf.ckpt" ] || fail "encode --preset tiny --size 40000 left no checkpoint"
msg=$("$cnerf" encode "$data/lego" -o "$work/ar.cnrf" --size 40000 --iters 3 --every 100 \
  --downscale 16 --batch 64 --threads 2 --resume "$work/ar.cnrf.ckpt" 2>&1); rc=$?
[ $rc -le 1 ] && grep -q "^resumed $work/ar.cnrf.ckpt at iteration 2" <<<"$msg" ||
  fail "--preset auto did not resume a tiny checkpoint at a size where the rule takes small: $rc $msg"
grep -q "^preset auto: tiny, the preset of $work/ar.cnrf.ckpt (the rule: small" <<<"$msg" ||
  fail "--preset auto's resume did not say it took the checkpoint's preset: $msg"
# --preset auto races tiny and small in a run of 1000 iterations or more: both train as
# whole encodes until the validation views rank them, and the winner goes on as if it had
# run alone: the file is byte for byte the encode of that preset.
# (On the shared Lego's 100 views the validations rank the presets by iteration 200; on the
# 10 views of the other checks only at half the run, which took longer than reading the rest.)
race=(--size 40000 --iters 1000 --every 100 --downscale 16 --batch 16 --threads 2)
# (a run this short may end a few per cent off its size: exit 1, the file written)
if [ -z "${CNERF_TEST_SANITIZED:-}" ]; then
  msg=$("$cnerf" encode "$shared/lego" -o "$work/race.cnrf" "${race[@]}" 2>&1); rc=$?
  [ $rc -le 1 ] && [ -s "$work/race.cnrf" ] || fail "encode with a race: $rc $msg"
else
  # (under the sanitizers, which check the race's memory: SIGTERM once the race has its
  # verdict, about iteration 200, which saves the winner's checkpoint; its 800 iterations
  # more, the most of this test's time instrumented, are a training run as the others)
  "$cnerf" encode "$shared/lego" -o "$work/race.cnrf" "${race[@]}" > "$work/race.log" 2>&1 &
  pid=$!
  for _ in $(seq 2400); do
    grep -q "^preset auto: [a-z]*, by the race" "$work/race.log" && break
    kill -0 $pid 2> /dev/null || break
    sleep 0.5
  done
  kill -TERM $pid 2> /dev/null
  wait $pid; rc=$?
  msg=$(cat "$work/race.log")
  { [ $rc = 143 ] && grep -q "^interrupted by SIGTERM: saved $work/race.cnrf.ckpt at iteration [1-9]" <<<"$msg"; } ||
    { [ $rc -le 1 ] && [ -s "$work/race.cnrf" ]; } || fail "encode with a race, SIGTERM after its verdict: $rc $msg"
fi
won=$(sed -n 's/^preset auto: \([a-z]*\), by the race (.*/\1/p' <<<"$msg")
[ -n "$won" ] && grep -q "^race 100/1000: validation psnr tiny [0-9.]* dB, small [0-9.]* dB" <<<"$msg" ||
  fail "encode --size 40000 --iters 1000 did not race tiny and small: $msg"
# (Under the sanitizers, which check the race's memory, the plain build checks the identity.)
if [ -z "${CNERF_TEST_SANITIZED:-}" ]; then
  "$cnerf" encode "$shared/lego" -o "$work/race-$won.cnrf" --preset "$won" "${race[@]}" > /dev/null 2>&1
  [ $? -le 1 ] && [ -s "$work/race-$won.cnrf" ] || fail "encode --preset $won"
  cmp -s "$work/race.cnrf" "$work/race-$won.cnrf" ||
    fail "the race's winner ($won) wrote another file than an encode of $won alone"
fi
set -e
[ ! -e "$work/z.cnrf.ckpt.tmp" ] || fail "a set left a temporary checkpoint"
echo "cli_train: all checks passed"
