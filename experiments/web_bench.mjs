// The WebAssembly decoder's speed in Node and in headless Chromium (experiments/web_bench.sh
// runs it beside the native decoder):
//   node experiments/web_bench.mjs WEBDIR RUNS NAME=STREAM:CAMFILE ...
// For each stream, each camera of its CAMFILE (`cnerf render --save-cameras` lines) and 1 and
// 2 workers: RUNS timed renders after one untimed, in Node then in Chromium; prints
// "where,name,camera,width,workers,median_ms,evals_per_ray,memory_per_worker" lines. Only the render calls are
// timed (the stream is opened before).
import { readFileSync } from 'node:fs';
import { createServer } from 'node:http';
import { join, resolve } from 'node:path';
import { pathToFileURL } from 'node:url';
import { launch } from '../tests/web/cdp.mjs';

const [, , webdir, runsArg, ...specs] = process.argv;
if (!specs.length) {
  console.error('usage: node web_bench.mjs WEBDIR RUNS NAME=STREAM:CAMFILE ...');
  process.exit(2);
}
const runs = +runsArg;
const jobs = specs.map((s) => {
  const [name, rest] = s.split('=');
  const [stream, cams] = rest.split(':');
  return { name, stream: resolve(stream), cams: readFileSync(cams, 'utf8').trim().split('\n') };
});

// The measuring function, run in Node and (as source) in the page.
async function measure(pkg, wasm, bytes, camLines, runs, workers) {
  const scene = await pkg.openScene(bytes, { wasm, workers });
  const out = [];
  for (const line of camLines) {
    const f = line.trim().split(/\s+/);
    const cam = pkg.cameraFromIntegers(f.slice(0, 18));
    const times = [];
    let epr = 0;
    for (let r = 0; r <= runs; r++) {
      const t0 = performance.now();
      const image = await scene.render(cam);
      if (r) times.push(performance.now() - t0);
      epr = image.stats.evalsPerRay;
    }
    times.sort((a, b) => a - b);
    out.push([f[18], +f[16], times[times.length >> 1], epr, scene.memoryPerWorker]);
  }
  scene.close();
  return out;
}

const print = (where, name, workers, rows) => {
  for (const [cam, width, ms, epr, mem] of rows)
    console.log(`${where},${name},${cam},${width},${workers},${ms.toFixed(1)},${epr.toFixed(2)},${mem}`);
};

const pkg = await import(pathToFileURL(join(resolve(webdir), 'js', 'index.js')));
const wasmBytes = readFileSync(join(webdir, 'cnerf.wasm'));
for (const j of jobs)
  for (const w of [1, 2])
    print('node', j.name, w, await measure(pkg, wasmBytes, readFileSync(j.stream), j.cams, runs, w));

const server = createServer((req, res) => {
  const url = new URL(req.url, 'http://x');
  const job = jobs.find((j) => url.pathname === `/stream/${j.name}`);
  const file = job ? job.stream : join(webdir, url.pathname === '/' ? 'index.html' : url.pathname);
  try {
    const body = readFileSync(file);
    const type = file.endsWith('.js') ? 'text/javascript' : file.endsWith('.wasm') ? 'application/wasm' : 'text/html';
    res.writeHead(200, { 'content-type': type }).end(body);
  } catch {
    res.writeHead(404).end();
  }
});
await new Promise((ok) => server.listen(0, '127.0.0.1', ok));
const site = `http://127.0.0.1:${server.address().port}`;
const browser = await launch(process.env.CHROMIUM || '/usr/bin/chromium');
try {
  const page = await browser.newPage();
  await page.open(`${site}/index.html`);
  await page.until('window.cnerfViewer');
  for (const j of jobs)
    for (const w of [1, 2]) {
      const rows = await page.evaluate(`(async () => {
        const measure = ${measure.toString()};
        const bytes = new Uint8Array(await (await fetch('/stream/${j.name}')).arrayBuffer());
        return measure(window.cnerfViewer, new URL('/cnerf.wasm', location.href), bytes,
                       ${JSON.stringify(j.cams)}, ${runs}, ${w});
      })()`);
      print('chromium', j.name, w, rows);
    }
} finally {
  server.close();
  await browser.close();
}
