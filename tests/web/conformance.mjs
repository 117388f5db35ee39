// The JavaScript package against the reference vectors, under Node:
//   node tests/web/conformance.mjs WEBDIR VECTORS CNERF_H
// WEBDIR is platform/web/build.sh's output. Checks, through the package in WEBDIR/js
// (openScene and render with two workers):
//  - every valid vector's tiles (NAME.md5, and NAME.s<m>.md5 for the other scenes of a stream
//    of several) and its RGB565 tiles (valid/RGB565): the manifest's MD5s;
//  - every invalid vector: openScene fails with the status of expected.txt (cnerf_peek's, or
//    cnerf_open's where peek passes);
//  - the package's status table against include/cnerf/cnerf.h, its summary fields against
//    the module's count;
//  - errors: a file over maxBytes, a workspace over memoryLimit;
//  - cancelling: a second render cancels the first (which rejects, CNERF_E_ABORTED), an
//    AbortSignal cancels a render, and the second render's pixels are still right.
import { createHash } from 'node:crypto';
import { readFile, readdir } from 'node:fs/promises';
import { join, resolve } from 'node:path';
import { pathToFileURL } from 'node:url';

const [, , webdir, vectors, header] = process.argv;
if (!header) {
  console.error('usage: node conformance.mjs WEBDIR VECTORS CNERF_H');
  process.exit(2);
}
// the package as build.sh ships it (WEBDIR/js: the module, its types and cnerf.wasm)
const here = pathToFileURL(join(resolve(webdir), 'js') + '/');
const { openScene, cameraFromIntegers, STATUS, CnerfError } = await import(new URL('index.js', here));
const { FIELDS } = await import(new URL('core.js', here));
const wasm = await WebAssembly.compile(await readFile(join(webdir, 'cnerf.wasm')));
let failed = 0, checked = 0;
const fail = (msg) => {
  console.log(`FAIL ${msg}`);
  failed++;
};
const md5 = (b) => createHash('md5').update(b).digest('hex');

async function readLines(path) {
  try {
    return (await readFile(path, 'utf8')).split('\n').filter((l) => l.trim() && !l.startsWith('#'));
  } catch {
    return null;
  }
}

async function cameras(path) {
  const cams = new Map();
  for (const line of (await readLines(path)) || []) {
    const f = line.trim().split(/\s+/);
    cams.set(f[18], cameraFromIntegers(f.slice(0, 18)));
  }
  return cams;
}

// One tile's bytes through the package.
async function tile(scene, cam, knobs, x, y, w, h) {
  let bytes = null;
  await scene.render(cam, { knobs, tiles: [[x, y, w, h]], onTile: (t) => { bytes = t.rgb; } });
  return bytes;
}

// The status table and the summary's fields.
{
  const h = await readFile(header, 'utf8');
  const names = [...h.matchAll(/^\s+(CNERF_E_[A-Z0-9_]+) = (-\d+),?\s/gm)];
  for (const [, name, value] of names)
    if (!STATUS[name] || STATUS[name][0] !== Number(value)) fail(`status ${name} = ${value}: not in the package's table`);
  if (names.length !== Object.keys(STATUS).length) fail(`the package has ${Object.keys(STATUS).length} statuses, the header ${names.length}`);
  const inst = await WebAssembly.instantiate(wasm, {});
  const n = FIELDS.reduce((s, [, k]) => s + k, 0);
  if (n !== inst.exports.cw_fields()) fail(`core.js has ${n} summary fields, the module ${inst.exports.cw_fields()}`);
  checked += names.length + 1;
}

// Valid vectors.
const valid = join(vectors, 'valid');
const rgb565 = (await readLines(join(valid, 'RGB565'))) || [];
let tiles = 0;
for (const md5file of (await readdir(valid)).filter((f) => f.endsWith('.md5')).sort()) {
  {
    // NAME.md5 (scene 0) or NAME.s<m>.md5 (scene m of a stream of several)
    const [, name, sm] = /^(.*?)(?:\.s(\d+))?\.md5$/.exec(md5file);
    const m = sm ? +sm : 0, sfx = sm ? `.s${sm}` : '';
    const bytes = await readFile(join(valid, `${name}.cnrf`));
    const lines = await readLines(join(valid, md5file));
    const cams = await cameras(join(valid, `${name}${sfx}.cam`));
    let scene;
    try {
      scene = await openScene(bytes, { wasm, workers: 2, scene: m });
    } catch (e) {
      fail(`${name}${sfx}: ${e.message}`);
      continue;
    }
    for (const line of lines) {
      const [cname, x, y, w, h, nc, nf, ts, want] = line.trim().split(/\s+/);
      const got = md5(await tile(scene, cams.get(cname), [+nc, +nf, +ts, 0], +x, +y, +w, +h));
      if (got !== want) fail(`${name}${sfx} ${cname} tile (${x}, ${y}): md5 ${got}, want ${want}`);
      tiles++;
    }
    for (const line of rgb565) {
      const [vname, cname, x, y, w, h, nc, nf, ts, fl, want] = line.trim().split(/\s+/);
      if (vname !== `${name}${sfx}`) continue;
      const got = md5(await tile(scene, cams.get(cname), [+nc, +nf, +ts, +fl], +x, +y, +w, +h));
      if (got !== want) fail(`${name}${sfx} ${cname} RGB565 tile (${x}, ${y}) flags ${fl}: md5 ${got}, want ${want}`);
      tiles++;
    }
    scene.close();
  }
}
console.log(`valid vectors: ${tiles} tiles`);
checked += tiles;

// Invalid vectors: the status openScene reports.
let invalid = 0;
for (const line of await readLines(join(vectors, 'invalid', 'expected.txt'))) {
  const [file, peek, open, ...rest] = line.split('#')[0].trim().split(/\s+/);
  const opt = rest.find((o) => o.startsWith('scene='));
  const want = peek !== 'CNERF_OK' ? peek : open;
  let got = 'CNERF_OK';
  try {
    const s = await openScene(await readFile(join(vectors, 'invalid', file)),
                              { wasm, workers: 1, scene: opt ? +opt.slice(6) : 0 });
    s.close();
  } catch (e) {
    got = e instanceof CnerfError ? e.status : `not a CnerfError: ${e}`;
  }
  if (got !== want) fail(`invalid/${file}: ${got}, want ${want}`);
  invalid++;
}
console.log(`invalid vectors: ${invalid} statuses`);
checked += invalid;

// The package's own errors, and cancelling.
{
  const bytes = await readFile(join(valid, '001-lego-encode-tiny.cnrf'));
  const expectError = async (what, status, f) => {
    try {
      await f();
      fail(`${what}: no error`);
    } catch (e) {
      if (!(e instanceof CnerfError) || e.status !== status) fail(`${what}: ${e.status || e}, want ${status}`);
    }
    checked++;
  };
  await expectError('a stream over maxBytes', 'CNERF_E_TOO_LARGE',
                    () => openScene(bytes, { wasm, maxBytes: bytes.length - 1 }));
  await expectError('a workspace over memoryLimit', 'CNERF_E_MEMORY',
                    () => openScene(bytes, { wasm, memoryLimit: bytes.length + 65536 }));
  // the module the package finds by itself (cnerf.wasm beside index.js)
  const own = await openScene(bytes, { workers: 1 });
  if (own.info.fileBytes !== bytes.length) fail(`the package's own module: fileBytes ${own.info.fileBytes}`);
  own.close();
  checked++;
  await expectError('a file that is not a stream', 'CNERF_E_MAGIC',
                    () => openScene(new TextEncoder().encode('<html>not a stream</html>'), { wasm }));

  const scene = await openScene(bytes, { wasm, workers: 2 });
  const cam = (await cameras(join(valid, '001-lego-encode-tiny.cam'))).get('r_0');
  const want = md5(await tile(scene, cam, [0, 0, 0, 0], 0, 0, 50, 50).then((b) => b));
  const first = scene.render(cam);
  const second = scene.render(cam);
  await expectError('the first of two renders', 'CNERF_E_ABORTED', () => first);
  const image = await second;
  const rgb = Buffer.alloc(50 * 50 * 3);
  for (let i = 0; i < 50 * 50; i++)
    for (let c = 0; c < 3; c++) rgb[3 * i + c] = image.data[4 * i + c];
  if (md5(rgb) !== want) fail('the second render: its pixels differ from one tile of the whole view');
  if (!(image.stats.evalsPerRay > 0)) fail('the render reports no evaluations');
  const ctl = new AbortController();
  const third = scene.render(cam, { signal: ctl.signal });
  ctl.abort();
  await expectError('a render whose signal aborts', 'CNERF_E_ABORTED', () => third);
  const look = scene.lookAt({ eye: [4, 0, 2], target: [0, 0, 0], up: [0, 0, 1], fovX: 40 }, 20, 10);
  const other = await scene.render(look);
  if (other.width !== 20 || other.height !== 10) fail('a look-at camera: the image is not 20x10');
  scene.close();
  checked++;
}

console.log(`${checked} checks, ${failed} failed`);
process.exit(failed ? 1 : 0);
