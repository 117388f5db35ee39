// experiments/web_profile.sh's two halves:
//   node --cpu-prof experiments/web_profile.mjs render WEBDIR WASM STREAM CAMFILE RUNS
//     renders the first camera of CAMFILE RUNS times after one untimed (one worker) and
//     prints each render's milliseconds;
//   node experiments/web_profile.mjs report PROFDIR TOP
//     prints the TOP functions by self time in the profile of the thread that spent the most
//     outside idle (the render worker), as percentages of that thread's samples.
import { readFileSync, readdirSync } from 'node:fs';
import { join, resolve } from 'node:path';
import { pathToFileURL } from 'node:url';

const [, , what, ...args] = process.argv;
if (what === 'render') {
  const [webdir, wasmFile, stream, camFile, runs] = args;
  const pkg = await import(pathToFileURL(join(resolve(webdir), 'js', 'index.js')));
  const scene = await pkg.openScene(readFileSync(stream), { wasm: readFileSync(wasmFile), workers: 1 });
  const f = readFileSync(camFile, 'utf8').trim().split('\n')[0].trim().split(/\s+/);
  const cam = pkg.cameraFromIntegers(f.slice(0, 18));
  const ms = [];
  for (let r = 0; r <= +runs; r++) {
    const t0 = performance.now();
    await scene.render(cam);
    if (r) ms.push((performance.now() - t0).toFixed(1));
  }
  scene.close();
  console.log(`renders (ms): ${ms.join(' ')}`);
} else if (what === 'report') {
  const [dir, top] = args;
  let best = null;
  for (const name of readdirSync(dir).filter((n) => n.endsWith('.cpuprofile'))) {
    const p = JSON.parse(readFileSync(join(dir, name), 'utf8'));
    const nodes = new Map(p.nodes.map((n) => [n.id, n]));
    const self = new Map();
    let busy = 0, total = 0;
    p.samples.forEach((id, i) => {
      const fn = nodes.get(id).callFrame.functionName || '(anonymous)';
      const dt = p.timeDeltas[i];
      self.set(fn, (self.get(fn) || 0) + dt);
      total += dt;
      if (fn !== '(idle)') busy += dt;
    });
    if (!best || busy > best.busy) best = { self, busy, total };
  }
  if (!best) throw new Error(`no profile in ${dir}`);
  console.log(`the render worker: ${(best.busy / 1000).toFixed(0)} ms sampled`);
  const rows = [...best.self].filter(([f]) => f !== '(idle)').sort((a, b) => b[1] - a[1]);
  for (const [fn, t] of rows.slice(0, +top))
    console.log(`${(100 * t / best.busy).toFixed(1).padStart(6)}%  ${fn}`);
} else {
  console.error('usage: node web_profile.mjs render WEBDIR WASM STREAM CAMFILE RUNS | report PROFDIR TOP');
  process.exit(2);
}
