#!/usr/bin/env bash
# The command's refusals as a table: each row is an exit status (1 a failure, 2 a bad command
# line), a fragment of the message (stderr) and a command line. Every row must fail with that status and say that fragment,
# within a few seconds (nothing reads without bound, nothing trains before it has checked
# its outputs), and leave every input as it was.
#   cli_bad_input.sh CNERF DATA WORK
set -euo pipefail
cnerf=$1 data=$2 work=$3
rm -rf "$work" && mkdir -p "$work"
# (Lego and Mic with 10 training and 10 validation views: each run reads fewer images)
data=$(bash "$(dirname "$0")/few_views.sh" "$data" "$work/data")
fail() { echo "FAIL: $*" >&2; exit 1; }

# Fixtures: a float checkpoint, a stream, a dataset copy made of hard links (a file written
# over by rename would replace the link, never the shared data), a symbolic link, a FIFO.
"$cnerf" train "$data/lego" -o "$work/t.ckpt" --preset tiny --downscale 16 --iters 2 \
  > "$work/fixture.log" || fail "fixture: train"
"$cnerf" synth -o "$work/s.cnrf" --preset tiny > /dev/null || fail "fixture: synth"
"$cnerf" pack "$work/s.cnrf" --target x86-64 -o "$work/p.bin" > /dev/null || fail "fixture: pack"
"$cnerf" synth -o "$work/small.cnrf" --preset small > /dev/null || fail "fixture: synth small"
head -c 100 "$work/p.bin" > "$work/p_cut.bin"
"$cnerf" encode "$data/lego" -o "$work/e.cnrf" --lambda 1 --preset tiny --downscale 16 --iters 2 \
  --every 200 --grid 0 > "$work/fixture-e.log" || fail "fixture: encode"
"$cnerf" encode "$data/lego" "$data/mic" -o "$work/set.cnrf" --lambda 1 --downscale 16 --iters 2 \
  --every 200 --grid 0 > "$work/fixture-set.log" || fail "fixture: encode of two scenes"
cp -al "$data/lego" "$work/ds"
cp -al "$data/lego" "$work/ds_dir" # an image that is a directory
rm "$work/ds_dir/train/r_0.png" && mkdir "$work/ds_dir/train/r_0.png"
mkdir "$work/ds_deep" # JSON nested 100,000 deep
python3 -c 'print("[" * 100000)' > "$work/ds_deep/transforms_train.json"
cp -al "$data/lego" "$work/ds_big" # an image whose header claims 100000 x 100000 pixels
rm "$work/ds_big/train/r_0.png"
python3 - "$work/ds_big/train/r_0.png" <<'PY'
import struct, sys, zlib
def chunk(t, d):
    return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d))
ihdr = struct.pack(">IIBBBBB", 100000, 100000, 8, 2, 0, 0, 0)
png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(b"\0")) + chunk(b"IEND", b"")
open(sys.argv[1], "wb").write(png)
PY
# a transforms file without "frames", one with an infinite pose entry (JSON has no NaN;
# 1e999 overflows to infinity), and an image of another size than the others
for d in nokey nanpose mism; do
  cp -al "$data/lego" "$work/ds_$d" && rm "$work/ds_$d/transforms_train.json"
done
python3 - "$data/lego/transforms_train.json" "$work" <<'PY'
import json, sys
j = json.load(open(sys.argv[1]))
k = dict(j); del k["frames"]
open(sys.argv[2] + "/ds_nokey/transforms_train.json", "w").write(json.dumps(k))
j["frames"][3]["transform_matrix"][0][3] = "INF"
s = json.dumps(j)
open(sys.argv[2] + "/ds_nanpose/transforms_train.json", "w").write(s.replace('"INF"', "1e999"))
j["frames"][3]["transform_matrix"][0][3] = 0.5
open(sys.argv[2] + "/ds_mism/transforms_train.json", "w").write(json.dumps(j))
PY
rm "$work/ds_mism/train/r_10.png" # (the second training view) a hard link: removed first, so the shared data is untouched
python3 - "$work/ds_mism/train/r_10.png" <<'PY'
import struct, sys, zlib
def chunk(t, d):
    return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d))
w, h = 40, 30
raw = b"".join(b"\0" + bytes(3 * w) for _ in range(h))
png = (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)) +
       chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))
open(sys.argv[1], "wb").write(png)
PY
# DTU layouts (IDR's cameras.npz): two cameras and three images; a camera file that is not a
# zip archive.
mkdir -p "$work/ds_dtu/image" "$work/ds_npz"
python3 - "$work" <<'PY'
import struct, sys, zipfile
def npy(m):
    d = "{'descr': '<f8', 'fortran_order': False, 'shape': (4, 4), }"
    d += " " * (-(10 + len(d) + 1) % 64) + "\n"
    return b"\x93NUMPY\x01\x00" + struct.pack("<H", len(d)) + d.encode() + struct.pack("<16d", *m)
P = [50, 0, 20, 80, 0, 50, 15, 60, 0, 0, 1, 4, 0, 0, 0, 1]  # K [I | (0, 0, 4)]
S = [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]
with zipfile.ZipFile(sys.argv[1] + "/ds_dtu/cameras.npz", "w") as z:
    for i in range(2):
        z.writestr("world_mat_%d.npy" % i, npy(P))
        z.writestr("scale_mat_%d.npy" % i, npy(S))
open(sys.argv[1] + "/ds_npz/cameras.npz", "w").write("world_mat_0\n")
PY
for i in 0 1 2; do cp "$work/ds_mism/train/r_10.png" "$work/ds_dtu/image/00000$i.png"; done
# Training views for --train-images: as written, one missing, one too many, one with alpha.
"$cnerf" views "$data/lego" -o "$work/v" --downscale 16 > /dev/null || fail "fixture: views"
for d in missing extra alpha; do cp -r "$work/v" "$work/v_$d"; done
rm "$work/v_missing/0003.png"
cp "$work/v/0000.png" "$work/v_extra/$(printf %04d "$(ls "$work/v" | grep -c "png$")").png" # the next index
python3 - "$work/v_alpha/0002.png" <<'PY'
import struct, sys, zlib
def chunk(t, d):
    return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d))
w = h = 25
raw = b"".join(b"\0" + bytes(4 * w) for _ in range(h))
png = (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 6, 0, 0, 0)) +
       chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))
open(sys.argv[1], "wb").write(png)
PY
ln -s "$work/s.cnrf" "$work/link.cnrf"
ln -s "$work/loop" "$work/loop"
mkfifo "$work/fifo"
# Hostile files inside output folders: a link to an input, a FIFO, and (as root, as CI runs)
# a device node made here (c 1 3, the null device: nothing is lost if it were written).
mkdir "$work/evd" "$work/vwd" "$work/rdir"
ln -s "$work/s.cnrf" "$work/evd/r_0.png"
mkfifo "$work/vwd/0000.png"
have_dev=0
if mknod "$work/dev" c 1 3 2> /dev/null && mknod "$work/rdir/orbit_000.png" c 1 3; then
  have_dev=1
fi
# Cameras as users bring them, each broken one way: a COLMAP text model and an instant-ngp
# transforms.json of 8 Lego views (400x400, focal 1111.1), made from Lego's own poses.
python3 - "$data/lego" "$work" <<'PY'
import json, math, os, struct, sys
src, work = sys.argv[1], sys.argv[2]
j = json.load(open(src + "/transforms_train.json"))
F = 0.5 * 800 / math.tan(0.5 * j["camera_angle_x"]) / 2  # the 400x400 files' focal length
frames = j["frames"][:8]
def quat(R):  # rotation matrix -> (w, x, y, z)
    t = R[0][0] + R[1][1] + R[2][2]
    if t > 0:
        s = 0.5 / math.sqrt(t + 1)
        return (0.25 / s, (R[2][1] - R[1][2]) * s, (R[0][2] - R[2][0]) * s, (R[1][0] - R[0][1]) * s)
    i = max(range(3), key=lambda k: R[k][k]); a, b = (i + 1) % 3, (i + 2) % 3
    s = 2 * math.sqrt(1 + R[i][i] - R[a][a] - R[b][b])
    q = [0, 0, 0, 0]; q[0] = (R[b][a] - R[a][b]) / s; q[1 + i] = 0.25 * s
    q[1 + a] = (R[a][i] + R[i][a]) / s; q[1 + b] = (R[b][i] + R[i][b]) / s
    return tuple(q)
def colmap_rows():
    rows = []
    for f in frames:
        M = f["transform_matrix"]
        R = [[M[r][0], -M[r][1], -M[r][2]] for r in range(3)]  # OpenGL -> OpenCV camera axes
        C = [M[r][3] for r in range(3)]
        Rt = [[R[c][r] for c in range(3)] for r in range(3)]  # world -> camera
        t = [-sum(Rt[r][k] * C[k] for k in range(3)) for r in range(3)]
        rows.append([*quat(Rt), *t])
    return rows
def colmap(name, cam="1 PINHOLE 400 400 %r %r 200 200" % (F, F), edit=None, bin_cam=None):
    d = "%s/%s" % (work, name)
    os.makedirs(d + "/sparse/0", exist_ok=True); os.makedirs(d + "/images", exist_ok=True)
    rows = colmap_rows()
    names = [os.path.basename(f["file_path"]) + ".png" for f in frames]
    for n in names:
        if not os.path.exists(d + "/images/" + n):
            os.link(src + "/train/" + n, d + "/images/" + n)
    ids = list(range(1, 9))
    fields = [[repr(v) for v in r] for r in rows]
    if edit:
        edit(ids, fields, names)
    img = "".join("%d %s 1 %s\n\n" % (i, " ".join(f), n) for i, f, n in zip(ids, fields, names))
    open(d + "/sparse/0/images.txt", "w").write(img)
    if bin_cam:
        open(d + "/sparse/0/cameras.bin", "wb").write(bin_cam)
    else:
        open(d + "/sparse/0/cameras.txt", "w").write("# cameras\n" + cam + "\n")
colmap("col_ok")
colmap("col_nan", cam="1 PINHOLE 400 400 nan %r 200 200" % F)
colmap("col_inf", edit=lambda i, f, n: f[2].__setitem__(4, "inf"))
colmap("col_q0", edit=lambda i, f, n: f[3].__setitem__(slice(0, 4), ["0", "0", "0", "0"]))
colmap("col_dupname", edit=lambda i, f, n: n.__setitem__(5, n[0]))
colmap("col_dupid", edit=lambda i, f, n: i.__setitem__(5, 3))
colmap("col_radial", cam="1 SIMPLE_RADIAL 400 400 %r 200 200 -5" % F)
colmap("col_aspect", cam="1 PINHOLE 400 300 %r %r 200 150" % (F, F))
# two cameras: views 1 and 2 (r_1, r_10) are 200x200 files with a camera of their own
def two_sizes(ids, fields, names):
    import zlib
    def png(path, w, h):
        def chunk(t, d):
            return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d))
        raw = b"".join(b"\0" + bytes([128]) * (3 * w) for _ in range(h))
        open(path, "wb").write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)) +
                               chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))
    for k in (1, 2):
        os.remove(work + "/col_sizes/images/" + names[k])
        png(work + "/col_sizes/images/" + names[k], 200, 200)
colmap("col_sizes", cam="1 PINHOLE 400 400 %r %r 200 200\n2 PINHOLE 200 200 %r %r 100 100"
       % (F, F, F / 2, F / 2), edit=two_sizes)
import re
imgs = open(work + "/col_sizes/sparse/0/images.txt").read()
open(work + "/col_sizes/sparse/0/images.txt", "w").write(
    re.sub(r" 1 (r_[12]\.png)$", r" 2 \1", imgs, flags=re.M))
# a camera of 2^40 x 2^40 pixels whose focal length and centre are those of the 400x400 files
colmap("col_huge", bin_cam=struct.pack("<QIiQQ4d", 1, 1, 1, 2**40, 2**40, F, F, 200, 200))
def ngp(name, **cam):
    d = "%s/%s" % (work, name)
    os.makedirs(d + "/train", exist_ok=True)
    for f in frames:
        n = os.path.basename(f["file_path"]) + ".png"
        if not os.path.exists(d + "/train/" + n):
            os.link(src + "/train/" + n, d + "/train/" + n)
    t = {"fl_x": F, "fl_y": F, "cx": 200, "cy": 200, "w": 400, "h": 400}
    t.update(cam)
    t["frames"] = [{"file_path": "train/" + os.path.basename(f["file_path"]) + ".png",
                    "transform_matrix": f["transform_matrix"]} for f in frames]
    open(d + "/transforms.json", "w").write(json.dumps(t).replace('"INF"', "1e999"))
ngp("ngp_ok")
ngp("ngp_k1", camera_model="OPENCV", k1=-5)
ngp("ngp_fisheye", camera_model="OPENCV_FISHEYE", k1=-5, k2=3)
ngp("ngp_tangential", camera_model="OPENCV", p1=3, p2=-3)
ngp("ngp_big", w=1e12, h=1e12)
ngp("ngp_cx", cx=1e6)
ngp("ngp_focal", fl_x=1e300, fl_y=1e300)
ngp("ngp_aabb", aabb_scale=1e30)
# opaque photos (no alpha channel), as a camera takes them
import zlib
def opaque_png(path, w, h, v):
    def chunk(t, d):
        return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d))
    raw = b"".join(b"\0" + bytes([v]) * (3 * w) for _ in range(h))
    open(path, "wb").write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)) +
                           chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))
ngp("ngp_opaque")
for k, f in enumerate(frames):
    p = work + "/ngp_opaque/train/" + os.path.basename(f["file_path"]) + ".png"
    os.remove(p)
    opaque_png(p, 400, 400, 60 + 20 * k)
PY
# A transforms file of 100 MB (sparse: no disk used): more than any capture's cameras need.
cp -al "$data/lego" "$work/ds_hugejson" && rm "$work/ds_hugejson/transforms_train.json"
truncate -s 100M "$work/ds_hugejson/transforms_train.json"
sums() { md5sum "$work/t.ckpt" "$work/s.cnrf" "$work/e.cnrf.ckpt" "$work/ds/transforms_train.json" \
         "$work/ds/test/r_0.png"; }
before=$(sums)

D=$work/ds
T=(--preset tiny --downscale 16 --iters 100000)
T2=(--preset tiny --downscale 16 --iters 2) # a row that the binary before its fix runs through
rows=(
  # status|message fragment|arguments (split on spaces)
  "1|is a device, not a regular file|info /dev/zero"
  "1|is a device, not a regular file|render /dev/zero --orbit 1 --size 8"
  "1|is a directory, not a file|info $work"
  "1|$work/missing: No such file or directory|train $work/missing -o $work/x.ckpt ${T[*]}"
  "1|$work/loop: Too many levels of symbolic links|train $work/loop -o $work/x.ckpt ${T[*]}"
  "1|$work/s.cnrf: not a directory|train $work/s.cnrf -o $work/x.ckpt ${T[*]}"
  "1|r_0.png: a directory, not a file (frames[0].file_path|train $work/ds_dir -o $work/x.ckpt ${T[*]}"
  "1|(nested 100000 deep; the parser stops at 1000)|train $work/ds_deep -o $work/x.ckpt ${T[*]}"
  "1|transforms_train.json: frames: missing|train $work/ds_nokey -o $work/x.ckpt ${T[*]}"
  "1|frames[3].transform_matrix: non-finite entry [0][3]|train $work/ds_nanpose -o $work/x.ckpt ${T[*]}"
  "1|images differ in size: $work/ds_mism/train/r_0.png is 400x400 but $work/ds_mism/train/r_10.png is 40x30|train $work/ds_mism -o $work/x.ckpt ${T[*]}"
  "1|r_0.png: 100000 x 100000 pixels, more than the 268435456 that cnerf loads|train $work/ds_big -o $work/x.ckpt ${T[*]}"
  "1|ds_dtu/image: 3 images (PNG, JPEG) for 2 poses in $work/ds_dtu/cameras.npz|train $work/ds_dtu -o $work/x.ckpt ${T[*]}"
  "1|ds_npz/cameras.npz: not a zip archive|train $work/ds_npz -o $work/x.ckpt ${T[*]}"
  "1|cannot write $work/nodir/x.cnrf|encode $D -o $work/nodir/x.cnrf --lambda 1 ${T[*]}"
  "1|cannot write $work/nodir/x.ckpt|train $D -o $work/nodir/x.ckpt ${T[*]}"
  "1|cannot write /proc/x.ckpt|train $D -o /proc/x.ckpt ${T[*]}"
  "1|is also the input $work/t.ckpt|quantize $work/t.ckpt -o $work/t.ckpt"
  "1|focal lengths in (0, 32768)|render $work/s.cnrf --orbit 1 --size 65535"
  "1|is also the input $work/s.cnrf|render $work/s.cnrf --orbit 1 --size 8 --save-cameras $work/s.cnrf"
  "1|lies inside the dataset|train $D -o $D/transforms_train.json ${T[*]}"
  "1|lies inside the dataset|encode $D -o $D/test/x.cnrf --lambda 1 ${T[*]}"
  "1|lies inside the dataset|eval $work/t.ckpt $D -o $D/test --downscale 16 --every 200"
  "1|lies inside the dataset|render $work/s.cnrf --dataset $D --downscale 16 --every 200 -o $D"
  "1|$work/t.ckpt is a regular file, not a directory|eval $work/t.ckpt $D -o $work/t.ckpt --downscale 16 --every 200"
  "1|is a device; cnerf writes regular files only|quantize $work/t.ckpt -o /dev/null"
  "1|is a symbolic link; cnerf writes regular files only|quantize $work/t.ckpt -o $work/link.cnrf"
  "1|is a directory; cnerf writes regular files only|quantize $work/t.ckpt -o $work"
  "1|is a FIFO; cnerf writes regular files only|quantize $work/t.ckpt -o $work/fifo"
  "2|--width: expected an integer in [1, 1024]|train $D -o $work/x.ckpt --width 100000"
  "2|--no-reference leaves it out|render $work/s.cnrf --orbit 1 --size 8 --float --no-reference"
  "2|--downscale: expected an integer in [1, 64]|train $D -o $work/x.ckpt --downscale 0"
  "2|--max-size: expected an integer in [1, 1048576]|views $D -o $work --max-size 0"
  "1|give --downscale or --max-size, not both|eval $work/s.cnrf $D --downscale 2 --max-size 50"
  "2|--lambda: expected a number in [0, 1000]|encode $D -o $work/x.cnrf --lambda -1"
  "2|--lambda: expected a number in [0, 1000]|encode $D -o $work/x.cnrf --lambda nan"
  "2|--lambda: expected a number in [0, 1000]|encode $D -o $work/x.cnrf --lambda inf"
  "2|--group-penalty: expected a number in [0, 1000]|encode $D -o $work/x.cnrf --lambda 1 --group-penalty -1"
  "2|--group-penalty: expected a number in [0, 1000]|train $D -o $work/x.ckpt --group-penalty nan"
  "2|unknown option '--bogus'|train $D -o $work/x.ckpt --bogus"
  "2|need one stream file|info --bogus"
  "2|need a checkpoint and -o FILE|quantize $work/t.ckpt"
  "2|need a stream and -o FILE|html $work/s.cnrf"
  "1|is also the input $work/s.cnrf|html $work/s.cnrf -o $work/s.cnrf"
  "1|the decoder refuses the stream: CNERF_E_MAGIC|html $work/t.ckpt -o $work/h.html"
  "2|--coarse-color takes on (the default: the coarse network's colour is sent) or off|quantize $work/t.ckpt -o $work/q.cnrf --coarse-color none"
  "2|--coarse-weight: expected a number in [0.001, 10]|encode $D -o $work/x.cnrf --lambda 1 --coarse-weight 0"
  "2|--grid takes 16, 32, 64 or 128|encode $D -o $work/x.cnrf --lambda 1 --grid 17"
  "1|t.ckpt was trained with --seed 1: resume with that seed|train $D -o $work/t.ckpt --resume --seed 7 ${T[*]}"
  "1|t.ckpt was trained on another dataset (10 training views with other camera poses|train $data/mic -o $work/t.ckpt --resume ${T[*]}"
  "1|t.ckpt was trained on 25x25 images and this run has 50x50: resume with that --downscale|train $D -o $work/t.ckpt --resume --preset tiny --downscale 8 --iters 100000"
  "1|e.cnrf.ckpt was encoded with --lambda 1: resume with that lambda (this run has 2)|encode $D -o $work/e2.cnrf --resume $work/e.cnrf.ckpt --lambda 2 ${T[*]}"
  "1|e.cnrf.ckpt was encoded with a fixed --lambda 1: resume with that lambda|encode $D -o $work/e2.cnrf --resume $work/e.cnrf.ckpt --size 20000 ${T[*]}"
  "1|e.cnrf.ckpt was encoded with a fixed --lambda 1: resume with that lambda|encode $D -o $work/e2.cnrf --resume $work/e.cnrf.ckpt --quality 50 ${T[*]}"
  "2|--init starts a run from a float model and --resume goes on|encode $D -o $work/x.cnrf --lambda 1 --init $work/t.ckpt --resume $work/e.cnrf.ckpt"
  "2|--init takes the model of its checkpoint: leave out --preset auto|encode $D -o $work/x.cnrf --size 20000 --init $work/t.ckpt --preset auto"
  "1|$work/nope.ckpt: no such checkpoint|encode $D -o $work/x.cnrf --size 20000 --init $work/nope.ckpt"
  "1|e.cnrf.ckpt is a compressed model (from cnerf encode): --init takes a float model|encode $D -o $work/x.cnrf --lambda 1 --init $work/e.cnrf.ckpt ${T[*]}"
  "1|t.ckpt is a model of depth 4, width 64 and 32+32 samples; this encode asks for depth 4, width 128|encode $D -o $work/x.cnrf --lambda 1 --init $work/t.ckpt --preset small --downscale 16 --every 200"
  "1|t.ckpt was trained on another dataset|encode $data/mic -o $work/x.cnrf --lambda 1 --init $work/t.ckpt ${T[*]}"
  "1|is also the input $work/t.ckpt|encode $D -o $work/t --lambda 1 --init $work/t.ckpt ${T[*]}"
  "2|need a dataset directory, -o FILE and one of --lambda L, --quality Q, --size BYTES or --bits-per-param X|encode $D -o $work/x.cnrf"
  "2|--lambda, --quality, --size and --bits-per-param each set the rate: give one of them|encode $D -o $work/x.cnrf --lambda 1 --size 9000"
  "2|--lambda, --quality, --size and --bits-per-param each set the rate: give one of them|encode $D -o $work/x.cnrf --size 9000 --bits-per-param 1"
  "2|--lambda, --quality, --size and --bits-per-param each set the rate: give one of them|encode $D -o $work/x.cnrf --quality 50 --lambda 0"
  "2|--quality: expected a number in [0, 100]|encode $D -o $work/x.cnrf --quality 101"
  "2|--quality: expected a number in [0, 100]|encode $D -o $work/x.cnrf --quality nan"
  "2|--size: expected a number in [1, 1e+09]|encode $D -o $work/x.cnrf --size 0"
  "2|--bits-per-param: expected a number in [0.001, 32]|encode $D -o $work/x.cnrf --bits-per-param nan"
  "2|--rate-control takes dual (dual ascent, the default) or pi (log-lambda PI control), not 'p'|encode $D -o $work/x.cnrf --size 9000 --rate-control p"
  "1|a 2500-byte file is too small for preset tiny on this scene: its headers, affine decoders and biases alone take|encode $D -o $work/x.cnrf --size 2500 ${T[*]}"
  "1|a 2500-byte file is too small for preset tiny on this scene|encode $D -o $work/x.cnrf --size 2500 --downscale 16 --iters 100000"
  "1|a 1000000-byte file is more than preset tiny can use on this scene: 193618 bytes hold its 47936 latents at 32 bits each, as float32 weights|encode $D -o $work/x.cnrf --size 1000000 ${T[*]}"
  "1|a 900000000-byte file is more than preset small can use on this scene|encode $D -o $work/x.cnrf --size 9e8 --downscale 16 --iters 100000"
  "1|the model is over level 1 before any training: workspace 189376 bytes > 73728, render scratch 4744 bytes > 4096, multiply-accumulates per evaluation 86848 > 32768|encode $D -o $work/x.cnrf --lambda 1 --preset small --level 1 --downscale 16"
  "1|the model is over level 1 before any training: render scratch 6472 bytes > 4096, samples per ray 192 > 128|encode $D -o $work/x.cnrf --lambda 1 --preset tiny --coarse 96 --fine 96 --level 1 --downscale 16"
  "2|--grid 128 is finer than level 1 allows (64 cells per axis)|encode $D -o $work/x.cnrf --lambda 1 --grid 128 --level 1"
  "2|--level: expected|encode $D -o $work/x.cnrf --lambda 1 --level 4"
  "2|--level and --no-level together|recode $work/s.cnrf -o $work/y.cnrf --level 1 --no-level"
  "2|--grid-coding takes blocks or cells, not 'octree'|recode $work/s.cnrf -o $work/y.cnrf --grid-coding octree"
  "1|does not fit level 1: workspace|recode $work/small.cnrf -o $work/y.cnrf --level 1"
  "1|the stream does not fit level 1: workspace 189376 bytes > 73728, render scratch 4744 bytes > 4096, multiply-accumulates per evaluation 86848 > 32768|synth -o $work/x.cnrf --preset small --level 1"
  "2|--level: expected|synth -o $work/x.cnrf --level 0"
  "2|--preset auto chooses the model from the file's size: give --size BYTES|encode $D -o $work/x.cnrf --preset auto --lambda 1"
  "2|--preset auto chooses the model from the file's size: give --size BYTES|encode $D -o $work/x.cnrf --preset auto --bits-per-param 2"
  "2|--preset auto chooses depth, width and samples itself|encode $D -o $work/x.cnrf --size 9000 --width 32"
  "2|unknown preset 'huge' (tiny, small, paper, auto)|encode $D -o $work/x.cnrf --size 9000 --preset huge"
  "1|ask for at least|encode $D -o $work/x.cnrf --bits-per-param 0.05 ${T[*]}"
  "2|--lr: expected a number in [1e-08, 1]|encode $D -o $work/x.cnrf --lambda 1 --lr 0"
  "2|--lr-decay: expected a number in [1, 1e+12]|train $D -o $work/x.ckpt --lr-decay 0"
  "2|--precrop-iters: expected|encode $D -o $work/x.cnrf --lambda 1 --precrop-iters -1"
  "2|--iters 0 trains nothing|train $D -o $work/x.ckpt --iters 0"
  "2|--iters 0 trains nothing|encode $D -o $work/x.cnrf --lambda 1 --iters 0"
  "1|v_missing/0003.png|train $D -o $work/x.ckpt --train-images $work/v_missing ${T[*]}"
  "1|v/0000.png is 25x25 and training view 0 (r_0) 50x50: give the same --downscale as to \`cnerf views\`|train $D -o $work/x.ckpt --train-images $work/v --preset tiny --downscale 8 --iters 100000"
  "1|v_extra has more views than the dataset's 10 training views|train $D -o $work/x.ckpt --train-images $work/v_extra ${T[*]}"
  "1|v_alpha/0002.png has an alpha channel|train $D -o $work/x.ckpt --train-images $work/v_alpha ${T[*]}"
  "2|need a dataset directory and -o DIR|views $D"
  "1|lies inside the dataset|views $D -o $D/v --downscale 16"
  "1|unknown split 'x' (test, val, train)|views $D -o $work/vv --split x --downscale 16"
  "2|unknown command 'nope'|help nope"
  "2|no --target|pack $work/s.cnrf -o $work/x.bin"
  "2|unknown --target 'cortex-m9'|pack $work/s.cnrf --target cortex-m9 -o $work/x.bin"
  "2|no output file|pack $work/s.cnrf --target cortex-m4"
  "1|no scene 1: the stream has 1|pack $work/s.cnrf --target cortex-m4 --scene 1 -o $work/x.bin"
  "1|CNERF_E_MAGIC|pack $work/t.ckpt --target cortex-m4 -o $work/x.bin"
  "1|is a device, not a regular file|pack /dev/zero --target cortex-m4 -o $work/x.bin"
  "1|a packed image whose parts lie outside its 100 bytes|info $work/p_cut.bin"
  "2|unknown command 'nope'|nope"
  # Every file a command writes is checked, -o and the files inside an output folder alike.
  "1|$work/link.cnrf is a symbolic link; cnerf writes regular files only|synth -o $work/link.cnrf"
  "1|$work/fifo is a FIFO; cnerf writes regular files only|synth -o $work/fifo"
  "1|cannot write $work/nodir/x.cnrf: No such file or directory|synth -o $work/nodir/x.cnrf"
  "1|$work/evd/r_0.png is a symbolic link; cnerf writes regular files only|eval $work/t.ckpt $D -o $work/evd --downscale 16 --every 200"
  "1|$work/vwd/0000.png is a FIFO; cnerf writes regular files only|views $D -o $work/vwd --downscale 16"
  "1|$work/v/0000.png lies inside the input $work/v|train $D --train-images $work/v -o $work/v/0000.png ${T[*]}"
  "2|$D and $work/ds/../ds are one dataset|encode $D $work/ds/../ds -o $work/x.cnrf --lambda 1"
  "2|--init encodes one scene; a stream of several scenes does not take it|encode $D $data/mic -o $work/x.cnrf --lambda 1 --init $work/t.ckpt"
  "1|set.cnrf.ckpt: a checkpoint of an encode of several scenes: resume it with the same datasets|encode $D -o $work/x.cnrf --lambda 1 --resume $work/set.cnrf.ckpt ${T[*]}"
  # Cameras validated at load: each message names the file, the entry and the rule.
  "1|col_nan/sparse/0/cameras.txt:2: camera 1: PINHOLE parameter 1 (fx) is 'nan', not a finite number|train $work/col_nan -o $work/x.ckpt --force ${T2[*]}"
  "1|col_inf/sparse/0/images.txt:5: image 3: TX is 'inf', not a finite number|train $work/col_inf -o $work/x.ckpt --force ${T2[*]}"
  "1|col_q0/sparse/0/images.txt:7: image 4: the rotation quaternion QW QX QY QZ is zero|train $work/col_q0 -o $work/x.ckpt --force ${T2[*]}"
  "1|col_dupname/sparse/0/images.txt: images 1 and 6 are both named r_0.png|train $work/col_dupname -o $work/x.ckpt --force ${T2[*]}"
  "1|col_dupid/sparse/0/images.txt:11: image 3: the id is used twice|train $work/col_dupid -o $work/x.ckpt --force ${T2[*]}"
  "1|col_radial/sparse/0/cameras.txt, camera 1: the SIMPLE_RADIAL lens folds the image|train $work/col_radial -o $work/x.ckpt --force ${T2[*]}"
  "1|col_huge/sparse/0/cameras.bin, camera 1: a field of view of 180.0 degrees across the image|train $work/col_huge -o $work/x.ckpt --force ${T2[*]}"
  "1|ngp_k1/transforms.json: the OPENCV lens folds the image|train $work/ngp_k1 -o $work/x.ckpt --force ${T2[*]}"
  "1|ngp_fisheye/transforms.json: the OPENCV_FISHEYE lens folds the image|train $work/ngp_fisheye -o $work/x.ckpt --force ${T2[*]}"
  "1|ngp_tangential/transforms.json: the OPENCV lens folds the image|train $work/ngp_tangential -o $work/x.ckpt --force ${T2[*]}"
  "1|ngp_big/transforms.json: a field of view of 180.0 degrees across the image|train $work/ngp_big -o $work/x.ckpt --force ${T2[*]}"
  "1|ngp_cx/transforms.json: the principal point (1e+06, 200) lies outside the 400x400 image|train $work/ngp_cx -o $work/x.ckpt --force ${T2[*]}"
  "1|ngp_focal/transforms.json: a field of view of 0.0 degrees across the image|train $work/ngp_focal -o $work/x.ckpt --force ${T2[*]}"
  "1|ds_hugejson/transforms_train.json: 104857600 bytes, more than the 67108864 that a camera file can need|train $work/ds_hugejson -o $work/x.ckpt --force ${T2[*]}"
  "1|ngp_aabb/transforms.json: aabb_scale: 1e+30 is not a scene scale (1/64 to 128)|train $work/ngp_aabb -o $work/x.ckpt --force ${T2[*]}"
  "1|r_0.png is 400x400, but its camera ($work/col_aspect/sparse/0/cameras.txt, camera 1) is for 400x300 images (another shape): give it a camera of its own size in the COLMAP model|train $work/col_aspect -o $work/x.ckpt --force ${T2[*]}"
  "1|scene 1 ($data/fern): a forward-facing scene is rendered in NDC|encode $D $data/fern -o $work/x.cnrf --lambda 1 --background contract ${T2[*]}"
  # A run never starts over a checkpoint without being told: hours of training are not one
  # typo away.
  "1|$work/t.ckpt is a checkpoint at iteration 2: --resume continues it, --force starts over in its place|train $D -o $work/t.ckpt ${T[*]}"
  "1|$work/e.cnrf.ckpt is a checkpoint at iteration 2: --resume $work/e.cnrf.ckpt continues it, --force starts over in its place|encode $D -o $work/e.cnrf --lambda 1 ${T[*]}"
  "1|$work/e.cnrf.ckpt is a checkpoint at iteration 2: --resume $work/e.cnrf.ckpt continues it, --force starts over in its place|encode $D -o $work/e.cnrf --lambda 1 --init $work/t.ckpt ${T[*]}"
  "1|$work/set.cnrf.ckpt is a checkpoint of 2 scenes at iteration 2: --resume $work/set.cnrf.ckpt continues it, --force starts over in its place|encode $D $data/mic -o $work/set.cnrf --lambda 1 --downscale 16 --iters 100000"
  "1|$work/s.cnrf exists and is not a cnerf checkpoint: --force replaces it|train $D -o $work/s.cnrf ${T[*]}"
  "2|--resume continues a checkpoint and --force replaces it: give one of them|train $D -o $work/t.ckpt --resume --force ${T[*]}"
  "2|--resume continues a checkpoint and --force replaces it: give one of them|encode $D -o $work/x.cnrf --lambda 1 --resume $work/e.cnrf.ckpt --force ${T[*]}"
)
if [ $have_dev = 1 ]; then
  rows+=(
    "1|$work/dev is a device; cnerf writes regular files only|synth -o $work/dev"
    "1|$work/rdir/orbit_000.png is a device; cnerf writes regular files only|render $work/s.cnrf --orbit 1 --size 8 -o $work/rdir"
  )
fi
n=0
for row in "${rows[@]}"; do
  IFS='|' read -r want frag args <<< "$row"
  read -r -a argv <<< "$args"
  set +e
  timeout 60 "$cnerf" "${argv[@]}" > "$work/out.txt" 2> "$work/err.txt" < /dev/null
  rc=$?
  set -e
  [ $rc -ne 124 ] || fail "'$args' did not finish within 60 s"
  [ $rc -eq "$want" ] || fail "'$args' exited $rc, want $want: $(head -3 "$work/err.txt")"
  grep -qF -- "$frag" "$work/err.txt" ||
    fail "'$args': no '$frag' in: $(head -3 "$work/err.txt")"
  n=$((n + 1))
done

# An LLFF capture as imgs2poses leaves it: only images/, poses_bounds.npy's cameras for a
# larger size of the same shape. It loads from images/, scaled, and says so.
mkdir -p "$work/llff_images" && cp "$data/fern/poses_bounds.npy" "$work/llff_images/"
cp -al "$data/fern/images_8" "$work/llff_images/images"
out=$("$cnerf" train "$work/llff_images" -o "$work/llff.ckpt" --preset tiny --downscale 8 --iters 1 2>&1) ||
  fail "LLFF with images/ only: $out"
grep -q "^images: $work/llff_images/images (504x378 files; poses_bounds.npy's cameras are for 4032x3024), downscaled by 8$" <<<"$out" ||
  fail "LLFF with images/ only: $out"
grep -q "^dataset $work/llff_images: 16 train, 1 val, 3 test views, 63x47, forward-facing" <<<"$out" ||
  fail "LLFF with images/ only: $out"

# A hostile file put at the checkpoint's path while a run goes on (a link to a file outside,
# a FIFO, a device node): the next periodic save refuses it and the run fails, and what the
# link points to stays as it was.
echo keep > "$work/outside.txt"
kinds=(link fifo)
[ $have_dev = 1 ] && kinds+=(dev)
for cmd in train encode; do
  for kind in "${kinds[@]}"; do
    o=$work/hostile-$cmd-$kind.x
    ck=$o
    extra=()
    [ $cmd = encode ] && { ck=$o.ckpt; extra=(--lambda 1 --every 200); }
    "$cnerf" $cmd "$D" -o "$o" --preset tiny --downscale 16 --iters 100000 --ckpt-every 3 \
      "${extra[@]}" > "$o.log" 2>&1 &
    pid=$!
    for _ in $(seq 600); do [ -s "$ck" ] && break; sleep 0.1; done
    [ -s "$ck" ] || fail "$cmd: no periodic checkpoint"
    case $kind in
      link) ln -s "$work/outside.txt" "$ck.new" ;;
      fifo) mkfifo "$ck.new" ;;
      dev) mknod "$ck.new" c 1 3 ;;
    esac
    mv -T "$ck.new" "$ck"
    set +e; timeout 120 tail --pid=$pid -f /dev/null; wait $pid; rc=$?; set -e
    want=$([ $kind = link ] && echo "a symbolic link" || { [ $kind = fifo ] && echo "a FIFO" || echo "a device"; })
    [ $rc -eq 1 ] && grep -q "$ck is $want; cnerf writes regular files only" "$o.log" ||
      fail "$cmd: a $kind put at its checkpoint mid-run: status $rc, $(tail -2 "$o.log")"
    [ "$(cat "$work/outside.txt")" = keep ] || fail "$cmd: the file a link pointed to was written"
    rm -f "$ck"
  done
done

# The background by default: contracted for opaque photos of a 360-degree capture, the
# constant colour for views with transparency or a forward-facing scene; a background given
# is kept.
out=$("$cnerf" train "$work/ngp_opaque" -o "$work/bg1.ckpt" "${T2[@]}") || fail "background auto: $out"
grep -q "^background: contracted (auto: the 7 training views are opaque and see beyond the object" \
  <<<"$out" || fail "background auto, opaque: $out"
out=$("$cnerf" train "$work/ngp_opaque" -o "$work/bg2.ckpt" "${T2[@]}" --background constant) ||
  fail "background constant: $out"
! grep -q "^background:" <<<"$out" || fail "background constant given, auto spoke: $out"
out=$("$cnerf" train "$D" -o "$work/bg3.ckpt" "${T2[@]}") || fail "background auto, Lego: $out"
grep -q "^background: the constant colour (auto: 10 of 10 training views have transparency)" \
  <<<"$out" || fail "background auto, Lego: $out"
out=$("$cnerf" train "$data/fern" -o "$work/bg4.ckpt" "${T2[@]}") || fail "background auto, Fern: $out"
grep -q "^background: the constant colour (auto: a forward-facing scene, in NDC)" <<<"$out" ||
  fail "background auto, Fern: $out"

# Views of several sizes say so, not the first view's size alone.
out=$("$cnerf" views "$work/col_sizes" -o "$work/vsz" --split train --downscale 16) ||
  fail "views of two sizes: $out"
grep -q "^views: 7 train views of $work/col_sizes, from 12x12 to 25x25, in " <<<"$out" ||
  fail "views of two sizes: $out"

# A payload damaged under a recomputed CRC passes the structural check and fails --check.
v=$(dirname "$0")/../../vectors
damaged=$(ls "$v"/invalid/[0-9][0-9][0-9]-payload-byte-changed-crc-fixed.cnrf)
"$cnerf" info "$damaged" > /dev/null || fail "info: the structure of $damaged should pass"
set +e
"$cnerf" info --check "$damaged" > /dev/null 2> "$work/err.txt"
rc=$?
set -e
[ $rc -eq 1 ] && grep -q "CNERF_E_PAYLOAD" "$work/err.txt" || fail "info --check $damaged: $rc $(cat "$work/err.txt")"
# (grep reads the whole output: with pipefail, `cnerf ... | grep -q` fails when grep exits
# at its match before cnerf has written its last line, which then dies of SIGPIPE)
grep -q "^check: every payload decodes" <<<"$("$cnerf" info --check "$work/s.cnrf")" ||
  fail "info --check of a good stream"
# a packed image: its header, its CRC, whether this machine opens it, then its stream
out=$("$cnerf" info "$work/p.bin") || fail "info of a packed image"
grep -q "packed image (cnerf pack), version 2, kernels avx2, little-endian, scene 0: .* CRC-32 ok" \
  <<<"$out" && grep -q "this machine's decoder: CNERF_" <<<"$out" &&
  grep -q "cnerf stream, format version" <<<"$out" || fail "info of a packed image: $out"
n=$((n + 1))

# Two runs never write one output: the second is refused while the first holds OUT.lock.
"$cnerf" train "$D" -o "$work/busy.ckpt" "${T[@]}" --log-every 1 > "$work/busy.log" 2>&1 &
pid=$!
for _ in $(seq 600); do
  grep -q "^iter " "$work/busy.log" && break
  kill -0 $pid 2> /dev/null || fail "lock: the first run exited: $(tail -3 "$work/busy.log")"
  sleep 0.1
done
set +e
"$cnerf" train "$D" -o "$work/busy.ckpt" "${T[@]}" > /dev/null 2> "$work/err.txt"
rc=$?
kill -TERM $pid
wait $pid
rc1=$?
set -e
[ $rc -eq 1 ] && grep -q "busy.ckpt is being written by another cnerf" "$work/err.txt" ||
  fail "lock: the second run exited $rc: $(cat "$work/err.txt")"
[ $rc1 -eq 143 ] || fail "lock: the first run exited $rc1 after SIGTERM"
[ ! -e "$work/busy.ckpt.lock" ] || fail "lock: the lock file was left behind"
n=$((n + 1))

# The lock covers every file a run writes: while an encode runs, its checkpoint is refused to
# a train, and to another encode that would --resume from it.
"$cnerf" encode "$D" -o "$work/busy2.cnrf" --lambda 1 "${T[@]}" --log-every 1 > "$work/busy2.log" 2>&1 &
pid=$!
for _ in $(seq 600); do
  grep -q "^iter " "$work/busy2.log" && break
  kill -0 $pid 2> /dev/null || fail "lock: the encode exited: $(tail -3 "$work/busy2.log")"
  sleep 0.1
done
set +e
timeout 60 "$cnerf" train "$D" -o "$work/busy2.cnrf.ckpt" "${T[@]}" > /dev/null 2> "$work/err.txt"
rc=$?
timeout 60 "$cnerf" encode "$D" -o "$work/busy3.cnrf" --resume "$work/busy2.cnrf.ckpt" --lambda 1 "${T[@]}" \
  > /dev/null 2> "$work/err3.txt"
rc3=$?
kill -TERM $pid
wait $pid
set -e
[ $rc -eq 1 ] && grep -q "busy2.cnrf.ckpt is being written by another cnerf" "$work/err.txt" ||
  fail "lock: train over an encode's checkpoint exited $rc: $(cat "$work/err.txt")"
[ $rc3 -eq 1 ] && grep -q "busy2.cnrf.ckpt is being written by another cnerf" "$work/err3.txt" ||
  fail "lock: an encode resuming a running encode's checkpoint exited $rc3: $(cat "$work/err3.txt")"
[ ! -e "$work/busy2.cnrf.lock" ] && [ ! -e "$work/busy2.cnrf.ckpt.lock" ] ||
  fail "lock: the lock files were left behind"
n=$((n + 1))

# A FIFO as the stream is read to its end (what a writer sends), not forever.
( printf 'not a stream' > "$work/fifo" ) &
set +e
timeout 60 "$cnerf" info "$work/fifo" > /dev/null 2> "$work/err.txt"
rc=$?
set -e
wait
[ $rc -eq 1 ] && grep -q "not a valid cnerf stream" "$work/err.txt" ||
  fail "info FIFO: exit $rc: $(cat "$work/err.txt")"
n=$((n + 1))

# A frame whose image is missing is skipped with one warning on stderr, and the rest loads.
mkdir -p "$work/ngp"
cp "$work/v/0000.png" "$work/v/0001.png" "$work/v/0002.png" "$work/ngp/"
python3 - "$work/ngp/transforms.json" <<'PY'
import json, sys
frames = [{"file_path": f, "transform_matrix": [[1, 0, 0, 0.1 * i], [0, 1, 0, 0], [0, 0, 1, 4], [0, 0, 0, 1]]}
          for i, f in enumerate(["0000.png", "0001.png", "gone.png", "0002.png"])]
json.dump({"camera_angle_x": 0.69, "frames": frames}, open(sys.argv[1], "w"))
PY
"$cnerf" views "$work/ngp" -o "$work/ngp_views" --split train > /dev/null 2> "$work/err.txt" ||
  fail "missing frame: $(cat "$work/err.txt")"
grep -q "^cnerf views: warning: .*gone.png: missing, frame skipped$" "$work/err.txt" &&
  [ "$(wc -l < "$work/err.txt")" -eq 1 ] || fail "missing frame: $(cat "$work/err.txt")"
[ "$(ls "$work/ngp_views"/*.png | wc -l)" -eq 2 ] || fail "missing frame: $(ls "$work/ngp_views")"
n=$((n + 1))

# Every command that writes, against each kind of hostile output: a link to a file outside
# the command's files, a FIFO, a device node (as root; made here, c 1 3) and one of the
# command's own inputs (a hard link to it inside an output folder). Each is refused before
# any work (status 1, within the table's time), and the special file stays what it was.
# OUT is a file the command writes; DIR/NAME a file it writes inside an output folder.
matrix=(
  "train $D -o OUT ${T2[*]} --force"
  "encode $D -o OUT --lambda 1 ${T2[*]} --force"
  "synth -o OUT --preset tiny"
  "quantize $work/t.ckpt -o OUT"
  "html $work/s.cnrf -o OUT"
  "pack $work/s.cnrf --target cortex-m4 -o OUT"
  "render $work/s.cnrf --orbit 1 --size 8 --save-cameras OUT"
  "eval $work/t.ckpt $D -o DIR/r_0.png --downscale 16 --every 200"
  "views $D -o DIR/0000.png --downscale 16"
  "render $work/s.cnrf --orbit 1 --size 8 -o DIR/orbit_000.png"
  "eval $work/t.ckpt $D -o DIR/r_0.png --downscale 16 --every 200"
)
# (for train, encode and views the input is an image of the dataset, linked outside its
# folder: known as an input only once the dataset is loaded)
input_of=("$D/train/r_0.png" "$D/train/r_10.png" "" "$work/t.ckpt" "$work/s.cnrf" "$work/s.cnrf" "$work/s.cnrf" "$work/t.ckpt"
          "$D/train/r_20.png" "$work/s.cnrf" "$D/test/r_0.png")
kinds=(link fifo input)
[ $have_dev = 1 ] && kinds+=(dev)
m=0
for i in "${!matrix[@]}"; do
  for kind in "${kinds[@]}"; do
    [ $kind = input ] && [ -z "${input_of[$i]}" ] && continue
    h=$work/hm$m
    m=$((m + 1))
    mkdir -p "$h"
    args=${matrix[$i]}
    if [[ $args == *" DIR/"* ]]; then
      name=$(sed 's|.* DIR/\([^ ]*\).*|\1|' <<<"$args")
      target=$h/d/$name
      mkdir -p "$h/d"
      args=$(sed "s| DIR/[^ ]*| $h/d|" <<<"$args")
    else
      target=$h/out
      args=${args/OUT/$target}
    fi
    case $kind in
      link) ln -s "$work/outside.txt" "$target" ;;
      fifo) mkfifo "$target" ;;
      dev) mknod "$target" c 1 3 ;;
      input) ln "${input_of[$i]}" "$target" ;;
    esac
    read -r -a argv <<< "$args"
    set +e
    timeout 60 "$cnerf" "${argv[@]}" > "$work/out.txt" 2> "$work/err.txt" < /dev/null
    rc=$?
    set -e
    [ $rc -eq 1 ] || fail "hostile $kind: '$args' exited $rc: $(head -2 "$work/err.txt")"
    case $kind in
      link) [ -L "$target" ] ;;
      fifo) [ -p "$target" ] ;;
      dev) [ -c "$target" ] ;;
      input) [ "$target" -ef "${input_of[$i]}" ] ;;
    esac || fail "hostile $kind: '$args' replaced $target"
    [ "$(cat "$work/outside.txt")" = keep ] || fail "hostile $kind: '$args' wrote through a link"
  done
done
echo "# hostile outputs: $m cases, ${#matrix[@]} commands x ${kinds[*]}"

# A stream or a checkpoint read from a pipe fed without end (zeros): refused from its first
# block with the parser's own message, not read to the 4 GiB limit.
mkfifo "$work/zero.fifo"
for c in "info $work/zero.fifo|CNERF_E_MAGIC (-6): not a valid cnerf stream" \
         "quantize $work/zero.fifo -o $work/zq.cnrf|zero.fifo: not a cnerf checkpoint"; do
  IFS='|' read -r args frag <<< "$c"
  read -r -a argv <<< "$args"
  ( exec cat /dev/zero > "$work/zero.fifo" ) 2> /dev/null &
  feeder=$!
  set +e
  timeout 60 "$cnerf" "${argv[@]}" > /dev/null 2> "$work/err.txt"
  rc=$?
  set -e
  kill $feeder 2> /dev/null || true
  wait $feeder 2> /dev/null || true
  [ $rc -eq 1 ] && grep -qF -- "$frag" "$work/err.txt" ||
    fail "'$args' on a pipe of zeros: status $rc, $(head -2 "$work/err.txt")"
done

# Help is not an error: on standard output, status 0.
for args in "help encode" "encode --help" "info -h" "help"; do
  read -r -a argv <<< "$args"
  "$cnerf" "${argv[@]}" > "$work/out.txt" || fail "'$args' exited $?"
  grep -q "^usage: cnerf" "$work/out.txt" || fail "'$args' printed no usage"
done

[ "$(sums)" = "$before" ] || fail "an input changed"
[ -L "$work/link.cnrf" ] && [ -p "$work/fifo" ] && [ -L "$work/evd/r_0.png" ] &&
  [ -p "$work/vwd/0000.png" ] || fail "a special file was replaced"
[ $have_dev = 0 ] || { [ -c "$work/dev" ] && [ -c "$work/rdir/orbit_000.png" ]; } ||
  fail "a device node was replaced"
leftover=$(find "$work" -name '*.tmp.*' | head -1)
[ -z "$leftover" ] || fail "a temporary file was left: $leftover"
echo "cli_bad_input: $n refusals, every input unchanged"
