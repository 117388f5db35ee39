#!/usr/bin/env bash
# The scene suite: public scenes that are not in ../shared/, each trained and encoded as a user
# would, to see that the defaults hold on any scene (docs/results.md, "Every scene a user
# brings"). Resumable: a run whose row is in OUT/suite.csv is not run again.
#
#   experiments/scene_suite.sh OUT SCENES.tsv [--iters "2000 6000"] [--sizes "15000 30000 60000"]
#                              [--only NAME] [--max-size 100] [--threads 2] [--seed 1]
#   experiments/scene_suite.sh OUT --table      the markdown table of OUT/suite.csv
#   experiments/scene_suite.sh ROWS.csv --table the same of a rows file
#     (either with --views VIEWS.csv: the default's lead over the other preset's encode with
#     its standard error over the test views, from each view's PSNR in both encodes)
#   experiments/scene_suite.sh OUT --views  each run's PSNR per test view from OUT/log, as CSV
#     (scene,iters,run,target,view,psnr); experiments/data/scene_suite_views.csv holds those of
#     the rows docs/results.md reports, where the logs were kept.
#   experiments/scene_suite.sh OUT --trajectories  each encode's course from OUT/log, as CSV
#     (scene,iters,run,target,build,iter,size_kb,plan_kb,val_psnr): a row per log line
#     "iter N" (its size and plan, and the latest validation, made at the last multiple of
#     --every before N), and per race line (run race-tiny or race-small: the validation made
#     at iteration N, the preset's size then, no plan). experiments/data/scene_suite_trajectories.csv
#     holds those of the rows docs/results.md reports, where the logs were kept.
# experiments/data/scene_suite.csv holds the rows docs/results.md reports; copied to
# OUT/suite.csv, it makes a run go on from them (rows already there are not run again).
# CNERF=path runs that binary instead of ./build/cnerf (a copy keeps a long run apart from
# rebuilds of the tree; SUITE_BUILD=COMMIT names the commit it was built from in the rows).
#
# SCENES.tsv: one scene a line, tab-separated: name, kind, the folder holding it (a layout
# cnerf reads), then anything (its source: repository, commit, path; docs/results.md lists
# them). Lines starting with # are skipped. The scenes are not shipped (size, licences):
# fetch them as docs/results.md says.
#
# For each scene and iteration count: the float models of presets tiny and small (cnerf
# train), then at each size the default encode (cnerf encode --size, which picks its preset)
# and the encode with the other preset; every one scored on the scene's test views by cnerf
# eval. Rows: scene,iters,run,preset,target,bytes,test_psnr,val_psnr,fit_psnr,seconds,status,build
# (build: the commit the binary was built from, SUITE_BUILD or the tree's HEAD).
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:?usage: scene_suite.sh OUT SCENES.tsv [options] | OUT --table}
shift
csv=$out/suite.csv
# --table also reads a rows file itself (experiments/data/scene_suite.csv, the rows measured so far)
[ "${1:-}" = "--table" ] && [ -f "$out" ] && csv=$out
if [ "${1:-}" = "--trajectories" ]; then
  [ -s "$csv" ] && [ -d "$out/log" ] || { echo "scene_suite: no rows or logs in $out" >&2; exit 1; }
  python3 - "$csv" "$out/log" <<'EOF'
import csv, os, re, sys
rows, logs = sys.argv[1], sys.argv[2]
w = csv.writer(sys.stdout, lineterminator='\n')
w.writerow(['scene', 'iters', 'run', 'target', 'build', 'iter', 'size_kb', 'plan_kb', 'val_psnr'])
it = re.compile(r'^iter (\d+)/\d+ .* size ([0-9.]+) kB, plan ([0-9.]+),.* val ([0-9.]+) dB')
race = re.compile(r'^race (\d+)/\d+: validation psnr tiny ([0-9.]+) dB, small ([0-9.]+) dB '
                  r'\(([0-9.]+) kB, ([0-9.]+) kB\)')
for r in csv.DictReader(open(rows)):
    if not r['run'].startswith('encode'):
        continue
    log = os.path.join(logs, '%s-%s-%s-%s.log' % (r['scene'], r['iters'], r['run'], r['target']))
    if not os.path.exists(log):
        continue
    key = [r['scene'], r['iters'], r['run'], r['target'], r.get('build', '')]
    for line in open(log):
        m = it.match(line)
        if m:
            w.writerow(key + list(m.groups()))
        m = race.match(line)
        if m:
            n, vt, vs, st, ss = m.groups()
            w.writerow(key[:2] + ['race-tiny'] + key[3:] + [n, st, '', vt])
            w.writerow(key[:2] + ['race-small'] + key[3:] + [n, ss, '', vs])
EOF
  exit 0
fi
if [ "${1:-}" = "--views" ]; then
  [ -s "$csv" ] && [ -d "$out/log" ] || { echo "scene_suite: no rows or logs in $out" >&2; exit 1; }
  python3 - "$csv" "$out/log" <<'EOF'
import csv, os, sys
sys.path.insert(0, 'experiments')
from eval_views import eval_views
rows, logs = sys.argv[1], sys.argv[2]
w = csv.writer(sys.stdout, lineterminator='\n')
w.writerow(['scene', 'iters', 'run', 'target', 'view', 'psnr'])
for r in csv.DictReader(open(rows)):
    ev = os.path.join(logs, '%s-%s-%s-%s.eval' % (r['scene'], r['iters'], r['run'], r['target']))
    if not os.path.exists(ev):
        continue
    for v in eval_views(ev):
        w.writerow([r['scene'], r['iters'], r['run'], r['target']] + list(v))
EOF
  exit 0
fi
if [ "${1:-}" = "--table" ]; then
  [ -s "$csv" ] || { echo "scene_suite: no rows in $csv" >&2; exit 1; }
  views=""
  if [ "${2:-}" = "--views" ]; then
    views=${3:?--views needs a file}
    [ -s "$views" ] || { echo "scene_suite: $views: no such file" >&2; exit 1; }
  fi
  python3 - "$csv" "$views" <<'EOF'
import csv, sys, collections
sys.path.insert(0, 'experiments')
from eval_views import paired
rows = list(csv.DictReader(open(sys.argv[1])))
# Each run's PSNR per test view (--views), for the standard error of a difference of means.
per_view = collections.defaultdict(dict)
if sys.argv[2]:
    for v in csv.DictReader(open(sys.argv[2])):
        per_view[(v['scene'], v['iters'], v['run'], v['target'])][v['view']] = float(v['psnr'])
by = collections.OrderedDict()
for r in rows:
    by.setdefault((r['scene'], r['iters']), []).append(r)
def f(r):
    if r is None: return '–'
    if r['status'] not in ('ok', 'missed-size'): return r['status']
    return '%s dB' % r['test_psnr'] + ('' if r['bytes'] in ('', '0') else ', %s B' % r['bytes']) + \
        (' (short of the size)' if r['status'] == 'missed-size' else '')
sizes = sorted({int(r['target']) for r in rows if r['target'] not in ('', '0')})
print('| scene | iters | float tiny | float small | ' +
      ' | '.join('%d B: default (preset) | tiny | small' % s for s in sizes) + ' |')
print('|' + '---|' * (4 + 3 * len(sizes)))
for (scene, iters), rs in by.items():
    get = lambda run, t='0': next((r for r in rs if r['run'] == run and r['target'] == t), None)
    cells = [scene, iters, f(get('train-tiny')), f(get('train-small'))]
    for s in sizes:
        d = get('encode-default', str(s))
        cells.append(f(d) + (' (%s)' % d['preset'] if d else ''))
        cells.append(f(get('encode-tiny', str(s))) if not (d and d['preset'] == 'tiny') else 'as default')
        cells.append(f(get('encode-small', str(s))) if not (d and d['preset'] == 'small') else 'as default')
    print('| ' + ' | '.join(cells) + ' |')
# The three bounds, per scene, length and size: the default within 0.3 dB of the better of
# --preset tiny and small at the size; the default within 3 dB of the float tiny model; the
# float small model within 3 dB of float tiny. A file written short of its size counts (it
# is what the encoder delivered).
def psnr(r):
    ok = r and r['status'] in ('ok', 'missed-size') and r['test_psnr']
    return float(r['test_psnr']) if ok else None
fmt = lambda v: '–' if v is None else '%+.2f dB' % v
print()
print('| scene | iters | size | default − other preset (± standard error, views) | '
      'default − better preset | default − float tiny | float small − float tiny | bounds |')
print('|---|---|---|---|---|---|---|---|')
worst, slowest = None, None
for (scene, iters), rs in by.items():
    get = lambda run, t='0': next((r for r in rs if r['run'] == run and r['target'] == t), None)
    ft, fs = psnr(get('train-tiny')), psnr(get('train-small'))
    secs = sum(int(r['seconds'] or 0) for r in rs)
    if slowest is None or secs > slowest[1]:
        slowest = ('%s at %s iterations' % (scene, iters), secs)
    for size in sizes:
        d = get('encode-default', str(size))
        dp = psnr(d)
        pre = [dp if d and d['preset'] == p else psnr(get('encode-' + p, str(size)))
               for p in ('tiny', 'small')]
        # a preset that the encoder refused at this size (collapse) is no candidate: the
        # bound is against the presets it accepts
        refused = [p for p in ('tiny', 'small')
                   if (get('encode-' + p, str(size)) or {}).get('status') == 'refused']
        pre = [-1e9 if p in refused else v for p, v in zip(('tiny', 'small'), pre)]
        a = dp - max(pre) if dp is not None and None not in pre else None
        # the lead over the other preset, with its standard error over the test views
        lead = '–'
        if dp is not None and None not in pre:
            k = 1 if d['preset'] == 'tiny' else 0
            if ('tiny', 'small')[k] in refused:
                lead = 'the other refused'
            else:
                lead = fmt(dp - pre[k])
                pv = paired(per_view.get((scene, iters, 'encode-' + ('tiny', 'small')[k], str(size))),
                            per_view.get((scene, iters, 'encode-default', str(size))))
                if pv is not None:
                    lead = lead.replace(' dB', ' ± %.2f dB (%d)' % pv[1:])
        b = dp - ft if dp is not None and ft is not None else None
        c = fs - ft if fs is not None and ft is not None else None
        broken = [n for n, v, lim in (('preset', a, -0.3), ('float tiny', b, -3),
                                      ('float small', c, -3)) if v is not None and v < lim - 1e-9]
        verdict = ('breaks: ' + ', '.join(broken)) if broken else \
            'hold' if None not in (a, b, c) else 'not all measured'
        print('| %s | %s | %d | %s | %s | %s | %s | %s |' % (scene, iters, size, lead, fmt(a),
                                                            fmt(b), fmt(c), verdict))
        if a is not None and (worst is None or a < worst[1]):
            worst = ('%s at %s iterations, %d B' % (scene, iters, size), a)
print()
if worst:
    print('worst against the preset bound: %s (%+.2f dB)' % worst)
if slowest:
    print('slowest: %s (%d s over its runs)' % slowest)
EOF
  exit 0
fi
scenes=${1:?usage: scene_suite.sh OUT SCENES.tsv [options]}
shift
iters_list="2000 6000" sizes="15000 30000 60000" only="" max_size=100 threads=2 seed=1
while [ $# -gt 0 ]; do
  case $1 in
    --iters) iters_list=$2; shift 2 ;;
    --sizes) sizes=$2; shift 2 ;;
    --only) only=$2; shift 2 ;;
    --max-size) max_size=$2; shift 2 ;;
    --threads) threads=$2; shift 2 ;;
    --seed) seed=$2; shift 2 ;;
    *) echo "scene_suite: unknown option $1" >&2; exit 2 ;;
  esac
done
[ -f "$scenes" ] || { echo "scene_suite: $scenes: no such file" >&2; exit 1; }
cnerf=${CNERF:-./build/cnerf}
build=${SUITE_BUILD:-$(git rev-parse --short HEAD 2>/dev/null || echo unknown)}
[ -x "$cnerf" ] || { cmake -S . -B build -DCMAKE_BUILD_TYPE=RelWithDebInfo && cmake --build build -j2; }
mkdir -p "$out/log" "$out/files"
[ -s "$csv" ] || echo "scene,iters,run,preset,target,bytes,test_psnr,val_psnr,fit_psnr,seconds,status,build" > "$csv"
done_row() { grep -q "^$1,$2,$3,[^,]*,$4," "$csv"; }
common=(--max-size "$max_size" --threads "$threads" --seed "$seed")

# score NAME FILE DATASET LOG: appends the test PSNR of FILE (a checkpoint or a stream).
score() {
  "$cnerf" eval "$2" "$3" --max-size "$max_size" > "$out/log/$1.eval" 2>&1 &&
    sed -n 's/^mean over [0-9]* test views.*: psnr \([0-9.]*\) dB.*/\1/p' "$out/log/$1.eval"
}
val_of() { sed -n 's/^validation: psnr \([0-9.]*\) dB on .*, \([0-9.]*\) dB on the training views.*/\1,\2/p' "$1"; }

# run SCENE DIR ITERS RUN PRESET TARGET -- cnerf-args...
run() {
  local scene=$1 dir=$2 iters=$3 runname=$4 preset=$5 target=$6
  shift 7
  done_row "$scene" "$iters" "$runname" "$target" && return 0
  local tag=$scene-$iters-$runname-$target log=$out/log/$scene-$iters-$runname-$target.log
  local file=$out/files/$tag
  echo "== $tag"
  local t0=$SECONDS status=ok rc=0
  "$@" --force -o "$file.$([ "${runname#train}" != "$runname" ] && echo ckpt || echo cnrf)" \
    > "$log" 2>&1 || rc=$?
  local secs=$((SECONDS - t0)) bytes=0 psnr="" vals=","
  local f=$file.ckpt
  [ "${runname#encode}" != "$runname" ] && f=$file.cnrf
  local chosen=$preset
  if [ "$runname" = encode-default ]; then
    # the rule's choice, then the race's verdict when it ran (the last line wins)
    chosen=$(sed -n 's/^preset auto: \([a-z]*\), by the race .*/\1/p; s/^preset auto: \([a-z]*\) (.*/\1/p' \
      "$log" | tail -n 1)
    grep -q "encoding again with preset tiny" "$log" && { chosen=tiny; status=stepped-down; }
  fi
  if [ $rc -ne 0 ]; then
    if grep -q "too small for this scene" "$log"; then status=refused; else status=failed; fi
    [ -s "$f" ] && [ "$status" = failed ] && status="missed-size"
  fi
  if [ -s "$f" ] && { [ $rc -eq 0 ] || [ "$status" = missed-size ]; }; then
    [ "$f" = "$file.cnrf" ] && bytes=$(stat -c %s "$f")
    psnr=$(score "$tag" "$f" "$dir" || true)
    vals=$(val_of "$log")
    [ -n "$vals" ] || vals=","
  fi
  echo "$scene,$iters,$runname,$chosen,$target,$bytes,$psnr,$vals,$secs,$status,$build" >> "$csv"
}

while IFS=$'\t' read -r name kind dir _rest; do
  case "$name" in ''|\#*) continue ;; esac
  [ -z "$only" ] || [ "$only" = "$name" ] || continue
  [ -d "$dir" ] || { echo "scene_suite: $name: $dir is not a folder (fetch it first)" >&2; continue; }
  for iters in $iters_list; do
    for p in tiny small; do
      run "$name" "$dir" "$iters" "train-$p" "$p" 0 -- "$cnerf" train "$dir" --preset "$p" \
        --iters "$iters" "${common[@]}"
    done
    for s in $sizes; do
      run "$name" "$dir" "$iters" encode-default auto "$s" -- "$cnerf" encode "$dir" --size "$s" \
        --iters "$iters" "${common[@]}"
      chosen=$(grep "^$name,$iters,encode-default,[^,]*,$s," "$csv" | tail -n 1 | cut -d, -f4)
      for p in tiny small; do
        [ "$p" = "$chosen" ] && continue
        run "$name" "$dir" "$iters" "encode-$p" "$p" "$s" -- "$cnerf" encode "$dir" --size "$s" \
          --preset "$p" --iters "$iters" "${common[@]}"
      done
    done
  done
done < "$scenes"
echo "scene_suite: rows in $csv; the table: $0 $out --table"
