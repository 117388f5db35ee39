#!/usr/bin/env python3
"""The layer rules of the source tree (docs/architecture.md), checked on what the compiler
and the linker saw, not on the text of the #include lines: includes resolve through include
directories, so a grep for "../" would miss most crossings.

  tools/check_layers.py BUILD_DIR          the build's depfiles (CMakeFiles/*.dir/**/*.o.d)
                                           and the host program's objects (nm)
  tools/check_layers.py --depfiles F...    depfiles only (the test's bad fixtures)
  tools/check_layers.py --nm F...          `nm -A` listings of objects only (rules 5 to 7)

Rules:
  1. decoder/ includes nothing of the project outside decoder/, common/ and include/
     (its freestanding link, scripts/build-m4.sh, keeps it off the C library);
  2. common/ includes nothing of the project outside common/ and include/;
  3. encoder/ never includes decoder/ (what both need is in common/ or include/);
  4. an encoder room includes only its own headers and those of the rooms below it:
     base < data, stream < nerf < compress (the trainer never calls compression);
  5. a command file (platform/host/cmd_*.c) uses no function another command file defines:
     what commands share lives in the host program's other files;
  6. one encode pipeline: the export, the scale choice, the pruning and the stream writer are
     called only from encoder/compress/pipeline.c (and the scale choice writes the stream it
     measures: encoder/compress/scales.c);
  7. one way to write: only encoder/base/fileio.c creates, renames, removes or locks a file
     (open, creat, rename, unlink, remove, mkdir, flock, png_init_io, ...; fopen elsewhere
     only with a read mode), so that every write gets its checks (encoder/base/cn_file.h).
Exit status 1 and one line per crossing when a rule is broken.
"""
import glob
import re
import os
import subprocess
import sys

ROOT = os.path.realpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), '..'))
ROOMS = {  # room: the rooms it may include
    'base': {'base'},
    'data': {'base', 'data'},
    'stream': {'base', 'stream'},
    'nerf': {'base', 'data', 'stream', 'nerf'},
    'compress': {'base', 'data', 'stream', 'nerf', 'compress'},
}


def part(path):
    """('decoder'|'common'|'include'|'encoder/<room>'|'platform/...'|None) of a path."""
    p = os.path.realpath(path)
    if not p.startswith(ROOT + os.sep):
        return None  # the system's headers
    rel = os.path.relpath(p, ROOT).split(os.sep)
    if rel[0] == 'encoder' and len(rel) > 2:
        return 'encoder/' + rel[1]
    return rel[0]


def parse_depfile(path):
    """(source, [dependencies]) of a make-style depfile."""
    text = open(path).read().replace('\\\n', ' ')
    target, _, deps = text.partition(': ')
    deps = deps.split()
    return (deps[0] if deps else None), deps[1:]


def depfile_violations(files, root_override=None):
    bad = []
    for f in files:
        src, deps = parse_depfile(f)
        if not src:
            continue
        s = part(src)
        for d in deps:
            t = part(d)
            if t is None or t == s:
                continue
            rel = os.path.relpath(os.path.realpath(d), ROOT)
            why = None
            if s == 'decoder' and t not in ('common', 'include'):
                why = 'the decoder includes %s' % rel
            elif s == 'common' and t != 'include':
                why = 'common/ includes %s' % rel
            elif s and s.startswith('encoder/'):
                if t == 'decoder':
                    why = 'the encoder includes decoder internals (%s)' % rel
                elif t.startswith('encoder/'):
                    room, other = s.split('/')[1], t.split('/')[1]
                    if room in ROOMS and other not in ROOMS[room]:
                        why = 'encoder/%s includes encoder/%s (%s): the rooms point %s' % (
                            room, other, rel, ' < '.join(['base', 'data|stream', 'nerf',
                                                          'compress']))
                elif t not in ('common', 'include'):
                    why = 'the encoder includes %s' % rel
            if why:
                bad.append('%s: %s' % (os.path.relpath(os.path.realpath(src), ROOT), why))
    return bad


def nm_violations(listing):
    """Rule 5 from `nm -A` lines of the command objects (file: [addr] type name)."""
    defined, used = {}, {}
    for line in listing.splitlines():
        if ':' not in line:
            continue
        obj, _, rest = line.rpartition(':')
        fields = rest.split()
        if len(fields) < 2:
            continue
        kind, name = fields[-2], fields[-1]
        cmd = os.path.basename(obj).split('.')[0]
        if not cmd.startswith('cmd_'):
            continue
        if kind in ('T', 'D', 'B', 'R'):
            defined[name] = cmd
        elif kind == 'U':
            used.setdefault(cmd, set()).add(name)
    bad = []
    for cmd, names in sorted(used.items()):
        for n in sorted(names):
            if n in defined and defined[n] != cmd:
                bad.append('platform/host/%s.c: uses %s of platform/host/%s.c' %
                           (cmd, n, defined[n]))
    return bad


PIPELINE_STEPS = {'cn_model_snap', 'cn_export_compressed', 'cn_export_quantized',
                  'cn_export_drop_color', 'cn_choose_scales', 'cn_choose_scales_points',
                  'cn_choose_scales_set', 'cn_export_prune', 'cn_write_stream', 'cn_write_set'}
PIPELINE_CALLERS = {'pipeline': PIPELINE_STEPS, 'scales': {'cn_write_set'}}


def pipeline_violations(listing):
    """Rule 6 from `nm -A` lines of the encoder's and the host program's objects."""
    bad = []
    for line in listing.splitlines():
        obj, _, rest = line.rpartition(':')
        fields = rest.split()
        if len(fields) < 2 or fields[-2] != 'U' or fields[-1] not in PIPELINE_STEPS:
            continue
        base = os.path.basename(obj).split('.')[0]
        if fields[-1] in PIPELINE_CALLERS.get(base, ()):
            continue
        bad.append('%s: calls %s outside the encode pipeline (encoder/compress/pipeline.c)' %
                   (os.path.basename(obj).rsplit('.', 1)[0], fields[-1]))
    return bad


WRITE_CALLS = {'open', 'open64', 'openat', 'openat64', 'creat', 'creat64', 'rename',
               'renameat', 'renameat2', 'unlink', 'unlinkat', 'remove', 'mkdir', 'mkdirat',
               'rmdir', 'link', 'linkat', 'symlink', 'symlinkat', 'truncate', 'truncate64',
               'mkstemp', 'mkstemp64', 'mkostemp', 'tmpfile', 'fdopen', 'freopen', 'flock',
               'png_init_io', 'mknod', 'mkfifo'}
WRITER = 'fileio'  # encoder/base/fileio.c


def source_of(obj):
    """The source file of an object (CMakeFiles/T.dir/encoder/base/fileio.c.o), or None."""
    rel = obj.split('.dir' + os.sep, 1)[-1] if '.dir' + os.sep in obj else obj
    rel = rel[:-2] if rel.endswith('.o') else rel
    path = os.path.join(ROOT, rel)
    return path if os.path.exists(path) else None


def write_violations(listing):
    """Rule 7 from `nm -A` lines: the calls that write files outside the write module, and
    fopen with a mode other than "r"/"rb" (read from the object's source)."""
    bad = []
    for line in listing.splitlines():
        obj, _, rest = line.rpartition(':')
        fields = rest.split()
        if len(fields) < 2 or fields[-2] != 'U':
            continue
        name, base = fields[-1], os.path.basename(obj).split('.')[0]
        if base == WRITER:
            continue
        shown = os.path.basename(obj).rsplit('.', 1)[0]
        if name in WRITE_CALLS:
            bad.append('%s: calls %s outside the write module (encoder/base/fileio.c)' %
                       (shown, name))
        elif name in ('fopen', 'fopen64'):
            src = source_of(obj)
            text = open(src).read() if src else ''
            modes = re.findall(r'fopen(?:64)?\s*\([^;]*?,\s*"([^"]*)"', text)
            for m in modes:
                if m not in ('r', 'rb'):
                    bad.append('%s: fopen with mode "%s" outside the write module '
                               '(encoder/base/fileio.c)' % (shown, m))
            if src and not modes:
                bad.append('%s: fopen with a mode that is not a literal "r" or "rb"' % shown)
    return bad


def live_objects(build, target):
    """The objects of a target whose source still exists (a build directory keeps others)."""
    top = os.path.join(build, 'CMakeFiles', target + '.dir')
    objs = []
    for o in glob.glob(os.path.join(top, '**', '*.c.o'), recursive=True):
        if os.path.exists(os.path.join(ROOT, os.path.relpath(o, top)[:-2])):
            objs.append(o)
    return sorted(objs)


def main(argv):
    bad = []
    if len(argv) >= 2 and argv[0] == '--depfiles':
        bad = depfile_violations(argv[1:])
    elif len(argv) >= 2 and argv[0] == '--nm':
        listing = ''.join(open(f).read() for f in argv[1:])
        bad = nm_violations(listing) + pipeline_violations(listing) + write_violations(listing)
    elif len(argv) == 1:
        build = argv[0]
        deps = [f for f in glob.glob(os.path.join(build, 'CMakeFiles', '*.dir', '**', '*.o.d'),
                                     recursive=True)]
        lib_deps = [f for f in deps if os.sep + 'cnerf_enc.dir' + os.sep in f or
                    os.sep + 'cnerf_dec.dir' + os.sep in f or os.sep + 'cnerf.dir' + os.sep in f]
        if not any(os.sep + 'cnerf_enc.dir' + os.sep in f for f in lib_deps):
            print('check_layers: no encoder depfiles under %s (build it first)' % build,
                  file=sys.stderr)
            return 2
        # A build directory keeps the objects of sources since moved or removed: skip them.
        lib_deps = [f for f in lib_deps if os.path.exists(parse_depfile(f)[0] or '')]
        bad = depfile_violations(lib_deps)
        host = live_objects(build, 'cnerf')
        objs = [o for o in host if os.path.basename(o).startswith('cmd_')]
        if not objs:
            print('check_layers: no command objects under %s' % build, file=sys.stderr)
            return 2
        out = subprocess.run(['nm', '-A'] + objs, check=True, capture_output=True, text=True)
        bad += nm_violations(out.stdout)
        every = live_objects(build, 'cnerf_enc') + host
        out = subprocess.run(['nm', '-A'] + every, check=True, capture_output=True, text=True)
        bad += pipeline_violations(out.stdout) + write_violations(out.stdout)
        print('check_layers: %d depfiles, %d objects' % (len(lib_deps), len(every)))
    else:
        print(__doc__, file=sys.stderr)
        return 2
    for b in bad:
        print(b)
    return 1 if bad else 0


if __name__ == '__main__':
    sys.exit(main(sys.argv[1:]))
