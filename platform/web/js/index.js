// cnerf in JavaScript: open a .cnrf stream and render views of it with the bit-exact
// WebAssembly decoder, in workers (one per core), in a browser or in Node.
//
//   import { openScene } from 'cnerf';
//   const scene = await openScene(bytes);               // Uint8Array or ArrayBuffer
//   const image = await scene.render(scene.startCamera(), { width: 200, height: 200 });
//   scene.close();
import { CnerfError, STATUS, FIELDS, defineEngine, statusError, workerSource } from './core.js';

export { CnerfError, STATUS };

const Engine = defineEngine();
const isNode = typeof process !== 'undefined' && !!(process.versions && process.versions.node);
const TILE = 32; // the side of the tiles a render is split into

// The compiled module, from what the caller gave (a Module, bytes or a URL), else cnerf.wasm
// beside this file.
async function loadModule(wasm) {
  if (wasm instanceof WebAssembly.Module) return wasm;
  if (wasm instanceof ArrayBuffer || ArrayBuffer.isView(wasm)) return WebAssembly.compile(wasm);
  const url = wasm ? new URL(String(wasm), import.meta.url) : new URL('./cnerf.wasm', import.meta.url);
  if (isNode && url.protocol === 'file:') {
    const { readFile } = await import('node:fs/promises');
    return WebAssembly.compile(await readFile(url));
  }
  const r = await fetch(url);
  if (!r.ok) throw new CnerfError('CNERF_E_FETCH', `${url}: HTTP ${r.status}`);
  return WebAssembly.compile(await r.arrayBuffer());
}

// A worker running workerSource(), behind one interface: post, listen, terminate.
async function startWorker() {
  if (isNode) {
    const { Worker } = await import('node:worker_threads');
    const w = new Worker(workerSource(), { eval: true });
    return { post: (m, t) => w.postMessage(m, t), listen: (f) => w.on('message', f),
             terminate: () => w.terminate() };
  }
  const url = URL.createObjectURL(new Blob([workerSource()], { type: 'text/javascript' }));
  const w = new Worker(url);
  URL.revokeObjectURL(url);
  return { post: (m, t) => w.postMessage(m, t), listen: (f) => { w.onmessage = (e) => f(e.data); },
           terminate: () => w.terminate() };
}

function describe(values, stream) {
  const info = {};
  let k = 0;
  for (const [name, n] of FIELDS) {
    info[name] = n === 1 ? values[k] : values.slice(k, k + n);
    k += n;
  }
  info.kind = ['360', 'forward-facing', '360 with background'][info.coord] || 'unknown';
  info.bounds = info.aabbQ16.map((v) => v / 65536);
  info.near = info.nearQ16 / 65536;
  info.far = info.farQ16 / 65536;
  info.meta = info.metaLength
    ? new TextDecoder().decode(stream.subarray(info.metaOffset, info.metaOffset + info.metaLength))
    : '';
  return info;
}

// The fixed-point camera of a line of 18 integers (a vector's .cam line: rot[9] in Q30, pos[3]
// in Q32, fx fy cx cy in Q16, width, height), as render() takes it.
export function cameraFromIntegers(values) {
  const v = values.map((x) => BigInt(x));
  if (v.length < 18) throw new CnerfError('CNERF_E_ARG', 'a camera is 18 integers');
  const words = v.slice(0, 9).map(Number);
  for (let a = 0; a < 3; a++) {
    const u = BigInt.asUintN(64, v[9 + a]);
    words.push(Number(BigInt.asIntN(32, u & 0xffffffffn)), Number(BigInt.asIntN(32, u >> 32n)));
  }
  words.push(...v.slice(12, 18).map(Number));
  return { words };
}

const q16 = (x) => Math.round(x * 65536);

export class Scene {
  constructor(engine, stream, info, options) {
    this.engine = engine;
    this.stream = stream;
    this.info = info;
    this.options = options;
    this.workers = [];
    this.job = 0;
    this.pending = null;
  }

  // The workers, each with its own instance and its own copy of the decoded model (a page
  // opened from file:// has no shared memory).
  async start(module, count) {
    const opened = [];
    for (let i = 0; i < count; i++) {
      const w = await startWorker();
      this.workers.push(w);
      opened.push(new Promise((resolve) => {
        w.listen((m) => (w.onMessage ? w.onMessage(m) : resolve(m)));
      }));
      w.post({ type: 'open', module, stream: this.stream, scene: this.info.scene,
               limit: this.options.memoryLimit || 0 });
    }
    const replies = await Promise.all(opened);
    for (const r of replies) {
      if (r.type === 'error') throw new CnerfError(r.status, r.message);
      if (r.status !== 0) throw statusError(r.status, 'cnerf_open');
    }
    this.memoryPerWorker = replies[0].memory;
  }

  // A camera at `eye` looking at `target` (scene units), `up` up, fovX degrees across, made
  // in integers by the decoder (the same camera as cnerf_camera_look_at on any device).
  lookAt({ eye, target, up = [0, 0, 1], fovX = 50 }, width, height) {
    const r = this.engine.lookAt(eye.map(q16), target.map(q16), up.map(q16), q16(fovX),
                                 width, height);
    if (typeof r === 'number') throw statusError(r, 'cnerf_camera_look_at');
    return { words: r };
  }

  // A camera that looks at the scene: for a 360-degree scene from outside its bounds, for a
  // forward-facing one from the capture's side (the origin, looking down -z).
  startCamera(width = 100, height = 100) {
    return this.lookAt(this.orbit(0, 0.35, 1), width, height);
  }

  // The look-at parameters of an orbit: azimuth and elevation in radians, distance as a
  // multiple of the default (the bounds' half diagonal times 2.2, or 1.2 for a scene with a
  // background). A forward-facing scene is seen from within its capture instead: azimuth
  // and elevation move the eye sideways and up, distance 1 is the capture's plane.
  orbit(azimuth, elevation, distance) {
    const b = this.info.bounds;
    if (this.info.kind === 'forward-facing') {
      // within the capture: a step of at most 0.3 units from its centre, looking down -z
      const eye = [0.3 * Math.sin(azimuth), 0.3 * Math.sin(elevation), 0.5 * (distance - 1)];
      return { eye, target: [0, 0, eye[2] - 2], up: [0, 1, 0], fovX: 50 };
    }
    const c = [0, 1, 2].map((a) => (b[a] + b[a + 3]) / 2);
    const half = Math.hypot(b[3] - b[0], b[4] - b[1], b[5] - b[2]) / 2;
    const r = (this.info.kind === '360' ? 2.2 : 1.2) * half * distance;
    const eye = [c[0] + r * Math.cos(elevation) * Math.cos(azimuth),
                 c[1] + r * Math.cos(elevation) * Math.sin(azimuth),
                 c[2] + r * Math.sin(elevation)];
    return { eye, target: c, up: [0, 0, 1], fovX: 40 };
  }

  // Renders `camera` ({words} of lookAt or cameraFromIntegers: its own width and height) into
  // an ImageData (in Node an object of the same shape). Options: signal (an AbortSignal),
  // onTile({x, y, width, height, rgba, done, total}) as tiles arrive (from the centre
  // outwards), knobs [nCoarse, nFine, tStop, flags] (the stream's defaults when absent),
  // tiles: a list of [x, y, w, h] instead of the whole image (every side at most 64).
  // A render in progress is cancelled by the next one (its promise rejects, CNERF_E_ABORTED).
  render(camera, options = {}) {
    const width = camera.words[19], height = camera.words[20];
    if (this.pending) this.pending.abort();
    const job = ++this.job;
    let tiles = options.tiles;
    if (!tiles) {
      tiles = [];
      for (let y = 0; y < height; y += TILE)
        for (let x = 0; x < width; x += TILE)
          tiles.push([x, y, Math.min(TILE, width - x), Math.min(TILE, height - y)]);
      const cx = width / 2, cy = height / 2;
      const d = (t) => Math.hypot(t[0] + t[2] / 2 - cx, t[1] + t[3] / 2 - cy);
      tiles.sort((a, b) => d(a) - d(b));
    }
    const rgba = new Uint8ClampedArray(width * height * 4);
    const total = tiles.length;
    let done = 0, next = 0, rays = 0, evals = 0;
    return new Promise((resolve, reject) => {
      const finish = (err) => {
        for (const w of this.workers) w.onMessage = null;
        if (this.pending && this.pending.job === job) this.pending = null;
        if (options.signal) options.signal.removeEventListener('abort', onAbort);
        if (err) reject(err);
      };
      const abort = () => finish(new CnerfError('CNERF_E_ABORTED', 'the render was cancelled'));
      const onAbort = () => abort();
      this.pending = { job, abort };
      if (options.signal) {
        if (options.signal.aborted) return abort();
        options.signal.addEventListener('abort', onAbort);
      }
      const knobs = options.knobs || [0, 0, 0, 0];
      const rgb565 = (knobs[3] & 12) !== 0; // the tiles' bytes to onTile only
      const give = (w) => {
        if (next >= total) return;
        const [x, y, tw, th] = tiles[next++];
        w.post({ type: 'tile', job, camera: camera.words, knobs, x, y, w: tw, h: th });
      };
      const onMessage = (w) => (m) => {
        if (m.job !== job || !this.pending || this.pending.job !== job) return;
        if (m.type === 'error') return finish(new CnerfError(m.status, m.message));
        if (m.status !== 0) return finish(statusError(m.status, `tile (${m.x}, ${m.y})`));
        for (let r = 0; r < m.h && !rgb565; r++)
          for (let c = 0; c < m.w; c++) {
            const s = 3 * (r * m.w + c), d = 4 * ((m.y + r) * width + m.x + c);
            rgba[d] = m.rgb[s];
            rgba[d + 1] = m.rgb[s + 1];
            rgba[d + 2] = m.rgb[s + 2];
            rgba[d + 3] = 255;
          }
        rays += m.rays;
        evals += m.evals;
        done++;
        if (options.onTile)
          options.onTile({ x: m.x, y: m.y, width: m.w, height: m.h, rgb: m.rgb, done, total });
        if (done === total) {
          finish(null);
          const image = typeof ImageData !== 'undefined'
            ? new ImageData(rgba, width, height)
            : { width, height, data: rgba, colorSpace: 'srgb' };
          image.stats = { rays, evals, evalsPerRay: rays ? evals / rays : 0 };
          resolve(image);
        } else {
          give(w);
        }
      };
      for (const w of this.workers) {
        w.onMessage = onMessage(w);
        give(w);
      }
    });
  }

  close() {
    if (this.pending) this.pending.abort();
    for (const w of this.workers) w.terminate();
    this.workers = [];
  }
}

// Opens `source` (the bytes of a .cnrf stream). Options: wasm (a WebAssembly.Module, its
// bytes or a URL; default cnerf.wasm beside this file), workers (default
// navigator.hardwareConcurrency, or Node's available parallelism), scene (of a stream of
// several, default 0), maxBytes (the largest stream accepted, default 64 MiB), memoryLimit
// (the bytes of stream, workspace and scratch one instance may lay out, default: what the
// platform gives; over it, CNERF_E_MEMORY).
export async function openScene(source, options = {}) {
  const stream = source instanceof Uint8Array ? source : new Uint8Array(source);
  const maxBytes = options.maxBytes || 64 << 20;
  if (stream.length > maxBytes)
    throw new CnerfError('CNERF_E_TOO_LARGE', `${stream.length} bytes, over the ${maxBytes} accepted`);
  const module = await loadModule(options.wasm);
  let engine, st, values;
  try {
    engine = await Engine.create(module, options.memoryLimit);
    [st, values] = engine.peek(stream, options.scene || 0);
  } catch (e) {
    throw e.status ? new CnerfError(e.status, e.message) : e;
  }
  if (st !== 0) throw statusError(st, 'cnerf_peek');
  const info = describe(values, stream);
  let count = options.workers;
  if (!count) {
    if (isNode) count = (await import('node:os')).availableParallelism();
    else count = (typeof navigator !== 'undefined' && navigator.hardwareConcurrency) || 2;
  }
  const scene = new Scene(engine, stream, info, options);
  try {
    await scene.start(module, Math.max(1, count));
  } catch (e) {
    scene.close();
    throw e;
  }
  return scene;
}
