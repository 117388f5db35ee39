// The viewer and the package in a real browser: Debian's Chromium, headless, driven over the
// DevTools protocol on a pipe (no npm package, no download).
//   node tests/web/browser.mjs WEBDIR VECTORS STREAM CAMS PNG SINGLE_HTML [SCREENSHOT]
// WEBDIR: platform/web/build.sh's site (index.html, js/, cnerf.wasm). STREAM: a stream,
// CAMS: a camera `cnerf render STREAM --save-cameras` wrote, PNG: that render's image of it.
// SINGLE_HTML: `cnerf html STREAM`'s file. Checks:
//  - every valid vector's tiles, rendered in the page through the package (two workers): the
//    manifest's MD5s;
//  - STREAM at CAMS's camera, rendered by the viewer's package: the same pixels as PNG;
//  - the viewer's error messages: an invalid vector, a file that is not a stream, a ?src=
//    download that fails (HTTP 404) or breaks off, a file over the size the page accepts, a
//    workspace the page cannot allocate (?memory=);
//  - the viewer: ?src= opens a stream, orbiting (a key) changes the picture, a second camera
//    given mid-render cancels the first;
//  - SINGLE_HTML opened through file:// renders the scene, with no error.
// SCREENSHOT, when given, gets a PNG of the viewer with STREAM loaded.
import { createHash } from 'node:crypto';
import { createServer } from 'node:http';
import { readFileSync, readdirSync, writeFileSync, existsSync } from 'node:fs';
import { extname, join, resolve } from 'node:path';
import { inflateSync } from 'node:zlib';
import { launch } from './cdp.mjs';

const [, , webdir, vectors, stream, camsPath, pngPath, singleHtml, screenshot] = process.argv;
if (!singleHtml) {
  console.error('usage: node browser.mjs WEBDIR VECTORS STREAM CAMS PNG SINGLE_HTML [SCREENSHOT]');
  process.exit(2);
}
const chromium = process.env.CHROMIUM || '/usr/bin/chromium';
let failed = 0, checked = 0;
const check = (ok, what) => {
  checked++;
  if (!ok) {
    failed++;
    console.log(`FAIL ${what}`);
  }
};
const md5 = (b) => createHash('md5').update(b).digest('hex');

// ---- a PNG's RGB888 pixels (8-bit RGB or RGBA, not interlaced: what cnerf render writes) ----
function readPng(path) {
  const b = readFileSync(path);
  let at = 8, w = 0, h = 0, type = 0;
  const idat = [];
  while (at < b.length) {
    const len = b.readUInt32BE(at), tag = b.toString('latin1', at + 4, at + 8);
    const body = b.subarray(at + 8, at + 8 + len);
    if (tag === 'IHDR') {
      w = body.readUInt32BE(0);
      h = body.readUInt32BE(4);
      type = body[9];
      if (body[8] !== 8 || (type !== 2 && type !== 6) || body[12] !== 0) throw new Error(`${path}: not 8-bit RGB`);
    } else if (tag === 'IDAT') idat.push(body);
    at += 12 + len;
  }
  const bpp = type === 6 ? 4 : 3, row = w * bpp, raw = inflateSync(Buffer.concat(idat));
  const out = Buffer.alloc(w * h * 3), prev = Buffer.alloc(row), cur = Buffer.alloc(row);
  for (let y = 0; y < h; y++) {
    const f = raw[y * (row + 1)], src = raw.subarray(y * (row + 1) + 1, (y + 1) * (row + 1));
    for (let i = 0; i < row; i++) {
      const a = i >= bpp ? cur[i - bpp] : 0, u = prev[i], c = i >= bpp ? prev[i - bpp] : 0;
      const p = a + u - c, pa = Math.abs(p - a), pb = Math.abs(p - u), pc = Math.abs(p - c);
      const pred = [0, a, u, (a + u) >> 1, pa <= pb && pa <= pc ? a : pb <= pc ? u : c][f];
      cur[i] = (src[i] + pred) & 255;
    }
    for (let x = 0; x < w; x++) cur.copy(out, 3 * (y * w + x), bpp * x, bpp * x + 3);
    cur.copy(prev);
  }
  return { width: w, height: h, rgb: out };
}

const { send, newPage, close: closeBrowser, log: chromeLog } = await launch(chromium);

// ---- the site, the vectors, and downloads that fail ----
const types = { '.html': 'text/html', '.js': 'text/javascript', '.wasm': 'application/wasm' };
const server = createServer((req, res) => {
  const url = new URL(req.url, 'http://x');
  if (url.pathname === '/broken.cnrf') { // promises more than it sends, then hangs up
    const b = readFileSync(stream);
    res.writeHead(200, { 'content-length': b.length, 'content-type': 'application/octet-stream' });
    res.write(b.subarray(0, b.length >> 1));
    setTimeout(() => res.destroy(), 50);
    return;
  }
  if (url.pathname === '/huge.cnrf') {
    res.writeHead(200, { 'content-length': 100 << 20 });
    res.end();
    return;
  }
  const roots = { '/vectors/': vectors, '/stream/': resolve(stream, '..') };
  let file = null;
  for (const [p, dir] of Object.entries(roots))
    if (url.pathname.startsWith(p)) file = join(dir, decodeURIComponent(url.pathname.slice(p.length)));
  if (!file) file = join(webdir, url.pathname === '/' ? 'index.html' : decodeURIComponent(url.pathname));
  if (!existsSync(file) || file.includes('..')) {
    res.writeHead(404).end('not found');
    return;
  }
  res.writeHead(200, { 'content-type': types[extname(file)] || 'application/octet-stream' });
  res.end(readFileSync(file));
});
await new Promise((ok) => server.listen(0, '127.0.0.1', ok));
const site = `http://127.0.0.1:${server.address().port}`;
const streamUrl = `${site}/stream/${encodeURIComponent(stream.split('/').pop())}`;

const t0 = Date.now();
try {
  await send('Target.setDiscoverTargets', { discover: false });
  const page = await newPage();

  // 1. Every valid vector's tiles, through the package in the page.
  await page.open(`${site}/index.html`);
  await page.until('window.cnerfViewer');
  const valid = join(vectors, 'valid');
  let tiles = 0;
  for (const md5file of readdirSync(valid).filter((f) => f.endsWith('.md5')).sort()) {
    {
      // NAME.md5 (scene 0) or NAME.s<m>.md5 (scene m of a stream of several)
      const [, name, sm] = /^(.*?)(?:\.s(\d+))?\.md5$/.exec(md5file);
      const m = sm ? +sm : 0, sfx = sm ? `.s${sm}` : '', file = `${name}.cnrf`;
      const cams = readFileSync(join(valid, `${name}${sfx}.cam`), 'utf8');
      const lines = readFileSync(join(valid, `${name}${sfx}.md5`), 'utf8').trim().split('\n');
      const got = await page.evaluate(`(async () => {
        const v = window.cnerfViewer;
        const bytes = new Uint8Array(await (await fetch('/vectors/valid/${file}')).arrayBuffer());
        const scene = await v.openScene(bytes, { wasm: new URL('/cnerf.wasm', location.href), workers: 2, scene: ${m} });
        const cams = {};
        for (const l of ${JSON.stringify(cams)}.trim().split('\\n')) {
          const f = l.trim().split(/\\s+/);
          cams[f[18]] = v.cameraFromIntegers(f.slice(0, 18));
        }
        const out = [];
        for (const l of ${JSON.stringify(lines)}) {
          const [c, x, y, w, h, nc, nf, ts] = l.trim().split(/\\s+/);
          let rgb = null;
          await scene.render(cams[c], { knobs: [+nc, +nf, +ts, 0], tiles: [[+x, +y, +w, +h]], onTile: (t) => { rgb = t.rgb; } });
          out.push(btoa(String.fromCharCode(...rgb)));
        }
        scene.close();
        return out;
      })()`);
      lines.forEach((l, i) => {
        const f = l.trim().split(/\s+/);
        check(md5(Buffer.from(got[i], 'base64')) === f[8], `${name}${sfx} tile ${f.slice(0, 5).join(' ')} in the browser`);
        tiles++;
      });
    }
  }
  console.log(`browser: ${tiles} vector tiles checked`);

  // 2. The stream at `cnerf render`'s camera: the same pixels as its PNG.
  const png = readPng(pngPath);
  const cam = readFileSync(camsPath, 'utf8').trim().split('\n')[0];
  const rgb = await page.evaluate(`(async () => {
    const v = window.cnerfViewer;
    const bytes = new Uint8Array(await (await fetch(${JSON.stringify(streamUrl)})).arrayBuffer());
    const scene = await v.openScene(bytes, { wasm: new URL('/cnerf.wasm', location.href) });
    const image = await scene.render(v.cameraFromIntegers(${JSON.stringify(cam)}.trim().split(/\\s+/).slice(0, 18)));
    scene.close();
    const rgb = [];
    for (let i = 0; i < image.width * image.height; i++) rgb.push(image.data[4 * i], image.data[4 * i + 1], image.data[4 * i + 2]);
    return btoa(String.fromCharCode(...rgb));
  })()`);
  check(Buffer.from(rgb, 'base64').equals(png.rgb), `${stream} in the browser: the pixels of ${pngPath}`);

  // 3. The viewer's errors.
  const viewerError = async (url, setup, status) => {
    await page.open(url);
    await page.until('window.cnerfViewer');
    if (setup) await page.evaluate(setup);
    const text = await page.until(`!document.getElementById('error').hidden && document.getElementById('error').textContent`, 30000);
    check(text.startsWith(status), `the viewer at ${url.replace(site, '')}: "${text}", want ${status}`);
  };
  const openBytes = (b64) => `window.cnerfViewer.open(Uint8Array.from(atob('${b64}'), (c) => c.charCodeAt(0)), 'x.cnrf')`;
  const bad = readFileSync(join(vectors, 'invalid', '024-kmin-kmax.cnrf')).toString('base64');
  await viewerError(`${site}/index.html`, openBytes(bad), 'CNERF_E_RANGE');
  await viewerError(`${site}/index.html`, openBytes(Buffer.from('<html>not a stream</html>').toString('base64')), 'CNERF_E_MAGIC');
  await viewerError(`${site}/index.html?src=/missing.cnrf`, null, 'CNERF_E_FETCH');
  await viewerError(`${site}/index.html?src=/broken.cnrf`, null, 'CNERF_E_FETCH');
  await viewerError(`${site}/index.html?src=/huge.cnrf`, null, 'CNERF_E_TOO_LARGE');
  await viewerError(`${site}/index.html?memory=65536&src=${encodeURIComponent(streamUrl)}`, null, 'CNERF_E_MEMORY');

  // 4. The viewer: ?src= opens; a key orbits and changes the picture; a second camera
  //    mid-render cancels the first.
  await page.open(`${site}/index.html?src=${encodeURIComponent(streamUrl)}`);
  await page.until('window.cnerfViewer && window.cnerfViewer.state.last');
  const picture = `(() => { const l = window.cnerfViewer.state.last; let h = 0; for (const v of l.image.data) h = (h * 31 + v) >>> 0; return [l.frame, h, l.width]; })()`;
  const before = await page.evaluate(picture);
  await send('Input.dispatchKeyEvent', { type: 'keyDown', key: 'ArrowLeft', code: 'ArrowLeft' }, page.sessionId);
  await page.until(`window.cnerfViewer.state.last.frame > ${before[0]} && window.cnerfViewer.state.last.width === ${before[2]}`);
  const after = await page.evaluate(picture);
  check(after[1] !== before[1], 'orbiting with a key changes the picture');
  const cancelled = await page.evaluate(`(async () => {
    const s = window.cnerfViewer.state.scene;
    const a = s.render(s.startCamera(200, 200)).then(() => 'finished', (e) => e.status);
    const b = s.render(s.startCamera(50, 50)).then((i) => i.width, (e) => e.status);
    return [await a, await b];
  })()`);
  check(cancelled[0] === 'CNERF_E_ABORTED' && cancelled[1] === 50, `a second camera mid-render: ${cancelled}`);
  if (screenshot) {
    await page.evaluate(`document.getElementById('resolution').value = '512'; window.cnerfViewer.moved()`);
    await page.until(`window.cnerfViewer.state.last && window.cnerfViewer.state.last.width === 512`, 120000);
    await send('Emulation.setDeviceMetricsOverride', { width: 1000, height: 560, deviceScaleFactor: 1, mobile: false }, page.sessionId);
    const shot = await send('Page.captureScreenshot', { format: 'png' }, page.sessionId);
    writeFileSync(screenshot, Buffer.from(shot.data, 'base64'));
  }
  check(page.logs.length === 0, `the page's console: ${page.logs.join('; ')}`);

  // 5. The single file, from file://.
  const single = await newPage();
  await single.open(`file://${resolve(singleHtml)}`);
  const last = await single.until('window.cnerfViewer && (window.cnerfViewer.state.last || window.cnerfViewer.errors.length) && [window.cnerfViewer.state.last && window.cnerfViewer.state.last.width, window.cnerfViewer.errors.join()]', 120000);
  check(last[0] > 0 && last[1] === '', `${singleHtml} from file://: ${JSON.stringify(last)}`);
  check(single.logs.length === 0, `${singleHtml}'s console: ${single.logs.join('; ')}`);
} catch (e) {
  console.log(`FAIL ${e.stack || e}`);
  if (chromeLog()) console.log(`chromium said: ${chromeLog()}`);
  failed++;
} finally {
  server.close();
  await closeBrowser();
}
console.log(`browser: ${checked} checks, ${failed} failed, ${((Date.now() - t0) / 1000).toFixed(1)} s`);
process.exit(failed ? 1 : 0);
