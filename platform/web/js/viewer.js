// The viewer: open a stream (drop, pick, or ?src=URL), orbit it, rendered by the decoder in
// workers. No framework: the page's elements are found by id (platform/web/index.html).
import { openScene, cameraFromIntegers, CnerfError } from './index.js';

const MAX_BYTES = 64 << 20; // the largest stream the page accepts
const IDLE_MS = 200; // the camera at rest this long: refine to full resolution

export function startViewer(options = {}) {
  const $ = (id) => document.getElementById(id);
  const canvas = $('view'), ctx = canvas.getContext('2d');
  const params = new URLSearchParams(location.search);
  const state = { scene: null, bytes: null, name: '', azimuth: 0.6, elevation: 0.35,
                  distance: 1, pan: [0, 0], last: null, frames: 0, busy: null };
  const viewer = { state, openScene, cameraFromIntegers, CnerfError, errors: [] };
  window.cnerfViewer = viewer;

  const showError = (e) => {
    const text = e instanceof CnerfError || e.status ? e.message : `error: ${e.message || e}`;
    viewer.errors.push(text);
    $('error').textContent = text;
    $('error').hidden = false;
  };
  const clearError = () => { $('error').hidden = true; };

  const progress = (done, total) => {
    const p = $('progress');
    p.hidden = done === total;
    if (total) p.value = done / total;
  };

  // The camera for the state at w x h pixels.
  const camera = (w, h) => {
    const s = state.scene;
    const o = s.orbit(state.azimuth, state.elevation, state.distance);
    const right = [-Math.sin(state.azimuth), Math.cos(state.azimuth), 0];
    const up = s.info.kind === 'forward-facing' ? [0, 1, 0] : [0, 0, 1];
    const d = s.info.kind === 'forward-facing' ? [1, 0, 0] : right;
    for (let a = 0; a < 3; a++) {
      const off = state.pan[0] * d[a] + state.pan[1] * up[a];
      o.eye[a] += off;
      o.target[a] += off;
    }
    return s.lookAt(o, w, h);
  };

  const size = () => {
    const r = +$('resolution').value;
    return [r, r];
  };

  // Renders at `scale` of the chosen resolution; a later call cancels this one.
  const draw = async (scale) => {
    if (!state.scene) return;
    const [W, H] = size();
    const w = Math.max(8, Math.round(W * scale)), h = Math.max(8, Math.round(H * scale));
    const off = new OffscreenCanvas(w, h), octx = off.getContext('2d');
    const t0 = performance.now();
    const frame = ++state.frames;
    try {
      const image = await state.scene.render(camera(w, h), {
        onTile: (t) => {
          const rgba = new Uint8ClampedArray(t.width * t.height * 4);
          for (let i = 0; i < t.width * t.height; i++) {
            rgba.set(t.rgb.subarray(3 * i, 3 * i + 3), 4 * i);
            rgba[4 * i + 3] = 255;
          }
          octx.putImageData(new ImageData(rgba, t.width, t.height), t.x, t.y);
          if (scale === 1) {
            ctx.imageSmoothingEnabled = false;
            ctx.drawImage(off, 0, 0, canvas.width, canvas.height);
          }
        },
      });
      const ms = performance.now() - t0;
      ctx.imageSmoothingEnabled = scale !== 1;
      ctx.drawImage(off, 0, 0, canvas.width, canvas.height);
      state.last = { frame, width: w, height: h, ms, evalsPerRay: image.stats.evalsPerRay,
                     image };
      $('stats').textContent = `${w}×${h}: ${ms.toFixed(0)} ms, ` +
        `${image.stats.evalsPerRay.toFixed(1)} evaluations per ray, ${state.scene.workers.length} workers`;
    } catch (e) {
      if (!(e instanceof CnerfError && e.status === 'CNERF_E_ABORTED')) showError(e);
    }
  };

  let idle = null;
  const moved = () => {
    if (!state.scene) return;
    clearTimeout(idle);
    draw(0.25);
    idle = setTimeout(() => { state.busy = draw(1); }, IDLE_MS);
  };
  viewer.moved = moved;

  const showInfo = () => {
    const i = state.scene.info, kb = (n) => `${n.toLocaleString()} B`;
    const preset = /preset=([a-z]+)/.exec(i.meta);
    const rows = [
      ['file', `${state.name}, ${kb(i.fileBytes)}, format ${i.versionMajor}.${i.versionMinor}`],
      ['scene', `${i.kind}, ${i.scene + 1} of ${i.scenes}`],
      ['preset', preset ? preset[1] : '(not recorded)'],
      ['networks', i.depth.slice(0, i.nets).map((d, n) => `depth ${d} width ${i.width[n]}`).join('; ')],
      ['samples', `${i.nCoarse} coarse + ${i.nFine} fine`],
      ['latents', `${i.params.toLocaleString()} in ${i.layers} layers: ${kb(i.layerBytes)}`],
      ['grid', i.grid ? `${i.grid}³ cells: ${kb(i.gridBytes)}` : 'none'],
      ['header, meta', `${kb(i.headBytes)}, ${kb(i.ancillaryBytes)}`],
      ['memory', `${(state.scene.memoryPerWorker / 1048576).toFixed(1)} MiB per worker`],
    ];
    $('info').replaceChildren(...rows.map(([k, v]) => {
      const tr = document.createElement('tr');
      for (const t of [k, v]) {
        const td = document.createElement('td');
        td.textContent = t;
        tr.append(td);
      }
      return tr;
    }));
    const pick = $('scene');
    pick.replaceChildren(...Array.from({ length: i.scenes }, (_, k) => new Option(`scene ${k + 1}`, k)));
    pick.value = String(i.scene);
    pick.hidden = i.scenes < 2;
  };

  // The views menu: eight around the scene (a 360-degree one) or five across the capture.
  const VIEWS = {
    '360': [0, 45, 90, 135, 180, 225, 270, 315].map((d) => [`${d}°`, (d * Math.PI) / 180, 0.35]),
    'forward-facing': [['centre', 0, 0], ['left', -0.4, 0], ['right', 0.4, 0], ['up', 0, 0.4],
                       ['down', 0, -0.4]],
  };
  const views = () => VIEWS[state.scene.info.kind === 'forward-facing' ? 'forward-facing' : '360'];

  const open = async (bytes, name, sceneIndex = 0) => {
    clearError();
    if (state.scene) state.scene.close();
    state.scene = null;
    try {
      state.scene = await openScene(bytes, { wasm: options.wasm, scene: sceneIndex,
                                             maxBytes: MAX_BYTES,
                                             memoryLimit: +params.get('memory') || 0 });
    } catch (e) {
      showError(e);
      return;
    }
    state.bytes = bytes;
    state.name = name;
    state.pan = [0, 0];
    state.distance = 1;
    [, state.azimuth, state.elevation] = views()[0];
    $('views').replaceChildren(...views().map(([label], k) => new Option(label, k)));
    showInfo();
    $('drop').hidden = true;
    await (state.busy = draw(1));
  };
  viewer.open = open;

  const download = async (url) => {
    clearError();
    let r;
    try {
      r = await fetch(url);
    } catch (e) {
      return showError(new CnerfError('CNERF_E_FETCH', `could not download ${url}: ${e.message}`));
    }
    if (!r.ok) return showError(new CnerfError('CNERF_E_FETCH', `could not download ${url}: HTTP ${r.status}`));
    const total = +r.headers.get('content-length') || 0;
    if (total > MAX_BYTES)
      return showError(new CnerfError('CNERF_E_TOO_LARGE', `${url}: ${total} bytes, over the ${MAX_BYTES} accepted`));
    const parts = [];
    let got = 0;
    try {
      const reader = r.body.getReader();
      for (;;) {
        const { done, value } = await reader.read();
        if (done) break;
        parts.push(value);
        got += value.length;
        progress(got, total || got + 1);
        if (got > MAX_BYTES)
          return showError(new CnerfError('CNERF_E_TOO_LARGE', `${url}: over the ${MAX_BYTES} bytes accepted`));
      }
    } catch (e) {
      progress(1, 1);
      return showError(new CnerfError('CNERF_E_FETCH', `the download of ${url} broke off after ${got} bytes: ${e.message}`));
    }
    progress(1, 1);
    if (total && got !== total)
      return showError(new CnerfError('CNERF_E_FETCH', `the download of ${url} ended after ${got} of ${total} bytes`));
    const bytes = new Uint8Array(got);
    let k = 0;
    for (const p of parts) {
      bytes.set(p, k);
      k += p.length;
    }
    await open(bytes, url.split('/').pop());
  };
  viewer.download = download;

  // Input: files, pointer, wheel, keys.
  const openFile = async (file) => {
    if (file.size > MAX_BYTES)
      return showError(new CnerfError('CNERF_E_TOO_LARGE', `${file.name}: ${file.size} bytes, over the ${MAX_BYTES} accepted`));
    await open(new Uint8Array(await file.arrayBuffer()), file.name);
  };
  $('file').addEventListener('change', (e) => e.target.files[0] && openFile(e.target.files[0]));
  document.addEventListener('dragover', (e) => e.preventDefault());
  document.addEventListener('drop', (e) => {
    e.preventDefault();
    if (e.dataTransfer.files[0]) openFile(e.dataTransfer.files[0]);
  });
  $('resolution').addEventListener('change', () => draw(1));
  $('scene').addEventListener('change', (e) => open(state.bytes, state.name, +e.target.value));
  $('views').addEventListener('change', (e) => {
    [, state.azimuth, state.elevation] = views()[+e.target.value];
    state.pan = [0, 0];
    state.distance = 1;
    draw(1);
  });

  const clampState = () => {
    const ff = state.scene && state.scene.info.kind === 'forward-facing';
    const lim = ff ? 0.6 : 1.45;
    state.elevation = Math.max(-lim, Math.min(lim, state.elevation));
    if (ff) state.azimuth = Math.max(-0.6, Math.min(0.6, state.azimuth));
    state.distance = Math.max(ff ? 0 : 0.3, Math.min(ff ? 1.5 : 3, state.distance));
    const p = ff ? 0.3 : 2;
    state.pan = state.pan.map((v) => Math.max(-p, Math.min(p, v)));
  };
  const pointers = new Map();
  let pinch = 0;
  canvas.addEventListener('pointerdown', (e) => {
    canvas.setPointerCapture(e.pointerId);
    pointers.set(e.pointerId, [e.clientX, e.clientY, e.button === 2 || e.shiftKey]);
  });
  canvas.addEventListener('pointerup', (e) => { pointers.delete(e.pointerId); pinch = 0; });
  canvas.addEventListener('pointercancel', (e) => { pointers.delete(e.pointerId); pinch = 0; });
  canvas.addEventListener('contextmenu', (e) => e.preventDefault());
  canvas.addEventListener('pointermove', (e) => {
    const p = pointers.get(e.pointerId);
    if (!p) return;
    const dx = (e.clientX - p[0]) / canvas.clientWidth, dy = (e.clientY - p[1]) / canvas.clientHeight;
    pointers.set(e.pointerId, [e.clientX, e.clientY, p[2]]);
    if (pointers.size === 2) { // two fingers: pinch to zoom
      const [a, b] = [...pointers.values()];
      const d = Math.hypot(a[0] - b[0], a[1] - b[1]);
      if (pinch) state.distance *= pinch / d;
      pinch = d;
    } else if (p[2]) {
      state.pan[0] -= dx * state.distance;
      state.pan[1] += dy * state.distance;
    } else {
      state.azimuth -= dx * Math.PI;
      state.elevation += dy * Math.PI / 2;
    }
    clampState();
    moved();
  });
  canvas.addEventListener('wheel', (e) => {
    e.preventDefault();
    state.distance *= Math.exp(e.deltaY * 0.001);
    clampState();
    moved();
  }, { passive: false });
  document.addEventListener('keydown', (e) => {
    const k = { ArrowLeft: [0.1, 0], ArrowRight: [-0.1, 0], ArrowUp: [0, 0.1], ArrowDown: [0, -0.1] }[e.key];
    if (k) {
      state.azimuth += k[0];
      state.elevation += k[1];
    } else if (e.key === '+' || e.key === '=') state.distance *= 0.9;
    else if (e.key === '-') state.distance /= 0.9;
    else if (e.key === 'a') state.pan[0] -= 0.05;
    else if (e.key === 'd') state.pan[0] += 0.05;
    else if (e.key === 'w') state.pan[1] += 0.05;
    else if (e.key === 's') state.pan[1] -= 0.05;
    else return;
    clampState();
    moved();
  });

  if (options.stream) open(options.stream, options.name || 'scene.cnrf');
  else if (params.get('src')) download(params.get('src'));
  return viewer;
}
