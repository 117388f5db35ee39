// The WebAssembly decoder, wrapped: one module instance holds one stream. The same code runs
// on the page and in every worker (workers get it as source text, defineEngine's own, so that a
// page opened from file:// can start them from a blob URL).

// The decoder's statuses (include/cnerf/cnerf.h; tests/web/conformance.mjs checks this table
// against the header).
export const STATUS = {
  CNERF_E_NULL: [-1, 'a required pointer is NULL'],
  CNERF_E_ARG: [-2, 'an argument is out of range'],
  CNERF_E_WS_ALIGN: [-3, 'the workspace is not aligned'],
  CNERF_E_WS_SMALL: [-4, 'the workspace is too small'],
  CNERF_E_TRUNCATED: [-5, 'the stream ends before its DONE chunk (a truncated file?)'],
  CNERF_E_MAGIC: [-6, 'not a cnerf stream'],
  CNERF_E_VERSION: [-7, 'a format version this decoder does not support'],
  CNERF_E_CRC: [-8, "a chunk's CRC-32 does not match (a damaged file)"],
  CNERF_E_CHUNK_ORDER: [-9, 'chunks out of order, missing or repeated'],
  CNERF_E_UNKNOWN_CHUNK: [-10, 'a critical chunk this decoder does not know'],
  CNERF_E_LIMIT: [-11, "a dimension exceeds the format's limits"],
  CNERF_E_HEADER: [-12, 'inconsistent header fields'],
  CNERF_E_LAYER: [-13, 'a layer disagrees with the topology'],
  CNERF_E_RANGE: [-14, 'an invalid latent range'],
  CNERF_E_TABLE: [-15, 'an invalid frequency table'],
  CNERF_E_PAYLOAD: [-16, 'an entropy-coded payload inconsistent with its table'],
  CNERF_E_TRAILING: [-17, 'bytes after the DONE chunk'],
  CNERF_E_FORMAT: [-18, 'a number-format field out of range'],
  CNERF_E_CHUNK: [-19, "a chunk's length disagrees with its content"],
  CNERF_E_OVERFLOW: [-20, "a value could overflow the renderer's accumulators"],
  CNERF_E_BUF_SMALL: [-21, 'an output buffer is too small'],
  CNERF_E_IMAGE_ALIGN: [-22, 'a packed image not aligned to 8 bytes'],
  CNERF_E_IMAGE_VERSION: [-23, 'a packed image of another decoder version'],
  CNERF_E_IMAGE_TARGET: [-24, 'a packed image for other kernels or byte order'],
  CNERF_E_IMAGE_CRC: [-25, "a packed image whose CRC-32 does not match"],
  CNERF_E_IMAGE: [-26, "a packed image whose contents disagree with its stream"],
  CNERF_E_LEVEL: [-27, "a stream above the decoder's level, or of no level"],
  CNERF_E_LEVEL_EXCEEDED: [-28, 'a stream that needs more than the level it declares'],
};

// cw_summary's fields, in platform/web/cnerf_web.c's order ([name, count]).
export const FIELDS = [
  ['versionMajor', 1], ['versionMinor', 1], ['scenes', 1], ['scene', 1], ['coord', 1],
  ['lPos', 1], ['lDir', 1], ['nearQ16', 1], ['farQ16', 1], ['aabbQ16', 6], ['background', 3],
  ['nets', 1], ['nCoarse', 1], ['nFine', 1], ['layers', 1], ['params', 1], ['biases', 1],
  ['fileBytes', 1], ['signatureBytes', 1], ['headBytes', 1], ['ancillaryBytes', 1],
  ['doneBytes', 1], ['layerBytes', 1], ['grid', 1], ['gridBytes', 1], ['unitBytes', 1],
  ['sceneBytes', 1], ['sharedBytes', 1], ['metaOffset', 1], ['metaLength', 1], ['depth', 2],
  ['width', 2], ['viewWidth', 2], ['color', 2], ['workspaceBytes', 1], ['scratchBytes', 1],
];

// A decoder error: `status` is the decoder's status name (CNERF_E_CRC...), or one of the
// package's own: CNERF_E_MEMORY (the page cannot allocate the workspace), CNERF_E_TOO_LARGE
// (a stream over the accepted size), CNERF_E_ABORTED (a render cancelled).
export class CnerfError extends Error {
  constructor(status, message) {
    super(`${status}: ${message}`);
    this.name = 'CnerfError';
    this.status = status;
  }
}

export function statusError(code, what) {
  for (const [name, [value, text]] of Object.entries(STATUS))
    if (value === code) return new CnerfError(name, what ? `${what}: ${text}` : text);
  return new CnerfError('CNERF_E_UNKNOWN_STATUS', `${what || 'the decoder'} returned ${code}`);
}

// Returns the Engine class. Self-contained on purpose: its source text is what workers run.
export function defineEngine() {
  const PAGE = 65536;
  const TILE_MAX = 64 * 64; // pixels of the largest tile render() is given
  const CAMERA_WORDS = 21;
  const align = (n, a) => Math.ceil(n / a) * a;

  class Engine {
    // module: a compiled WebAssembly.Module of platform/web/build.sh.
    // limit: the most bytes it may lay out above the module's own (0: as many as the
    // platform gives).
    static async create(module, limit) {
      const instance = await WebAssembly.instantiate(module, {});
      return new Engine(instance, limit);
    }

    constructor(instance, limit) {
      this.limit = limit || 0;
      this.x = instance.exports;
      this.memory = this.x.memory;
      this.base = align(this.x.__heap_base.value, 16);
      this.top = this.base;
      this.decoder = 0;
    }

    // Reserves n bytes at the top (8-aligned) and grows the memory to hold them.
    reserve(n) {
      const at = align(this.top, 16);
      this.top = at + align(n, 16);
      const need = Math.ceil(this.top / PAGE) - this.memory.buffer.byteLength / PAGE;
      if (need > 0) {
        let ok = !this.limit || this.top - this.base <= this.limit;
        try {
          if (ok) this.memory.grow(need);
        } catch (e) {
          ok = false;
        }
        if (!ok) {
          const err = new Error(`cannot allocate ${this.top - this.base} bytes of WebAssembly ` +
                                `memory${this.limit ? ` (the limit is ${this.limit})` : ''}`);
          err.status = 'CNERF_E_MEMORY';
          throw err;
        }
      }
      return at;
    }

    bytes(at, n) {
      return new Uint8Array(this.memory.buffer, at, n);
    }

    words(at, n) {
      return new Int32Array(this.memory.buffer, at, n);
    }

    // Copies the stream in and describes `scene`: [status, summary array].
    peek(stream, scene) {
      this.top = this.base;
      this.decoder = 0;
      this.stream = this.reserve(stream.length);
      this.streamLength = stream.length;
      this.bytes(this.stream, stream.length).set(stream);
      this.info = this.reserve(this.x.cw_info_bytes());
      this.summaryAt = this.reserve(4 * this.x.cw_fields());
      this.camera = this.reserve(4 * CAMERA_WORDS * 2);
      this.stats = this.reserve(16);
      const st = this.x.cw_peek(this.stream, stream.length, scene, this.info);
      if (st !== 0) return [st, null];
      this.x.cw_summary(this.info, this.summaryAt);
      return [0, Array.from(this.words(this.summaryAt, this.x.cw_fields()))];
    }

    // Decodes the peeked scene: the workspace, scratch and tile memory are taken once, here.
    open(scene) {
      const wsBytes = this.x.cw_workspace_size(this.info);
      const scBytes = this.x.cw_scratch_size(this.info);
      this.decoderAt = this.reserve(this.x.cw_decoder_bytes());
      this.ws = this.reserve(wsBytes);
      this.wsBytes = wsBytes;
      this.scratch = this.reserve(scBytes);
      this.scratchBytes = scBytes;
      this.tile = this.reserve(TILE_MAX * 3);
      const st = this.x.cw_open(this.decoderAt, this.stream, this.streamLength, scene, this.ws,
                                wsBytes);
      if (st === 0) this.decoder = this.decoderAt;
      return st;
    }

    // The look-at camera's 21 words, or a negative status.
    lookAt(eyeQ16, targetQ16, upQ16, fovQ16, width, height) {
      const v = this.words(this.camera + 4 * CAMERA_WORDS, 9);
      v.set([...eyeQ16, ...targetQ16, ...upQ16]);
      const at = this.camera + 4 * CAMERA_WORDS;
      const st = this.x.cw_look_at(this.camera, at, at + 12, at + 24, fovQ16, width, height);
      return st === 0 ? Array.from(this.words(this.camera, CAMERA_WORDS)) : st;
    }

    // Renders a tile: [status, its RGB888 (or RGB565) rows (a copy), rays, evaluations].
    render(camera, knobs, x0, y0, w, h) {
      if (w * h > TILE_MAX) return [-2, null, 0, 0];
      this.words(this.camera, CAMERA_WORDS).set(camera);
      const k = knobs || [0, 0, 0, 0];
      const bpp = k[3] & 12 ? 2 : 3; // RGB565 in either byte order, else RGB888
      const st = this.x.cw_render(this.decoder, this.camera, k[0], k[1], k[2], k[3], x0, y0, w,
                                  h, this.tile, w * bpp, this.scratch, this.scratchBytes,
                                  this.stats);
      if (st !== 0) return [st, null, 0, 0];
      const s = new Uint32Array(this.memory.buffer, this.stats, 4);
      return [0, this.bytes(this.tile, w * h * bpp).slice(), s[0], s[1]];
    }

    memoryBytes() {
      return this.memory.buffer.byteLength;
    }
  }
  Engine.TILE_MAX = TILE_MAX;
  Engine.CAMERA_WORDS = CAMERA_WORDS;
  return Engine;
}

// The worker's loop over its messages, given the Engine class and its port (self in a
// browser, worker_threads' parentPort in Node). Messages in: {type: 'open', module, stream,
// scene} then {type: 'tile', job, camera, knobs, x, y, w, h}; out: {type: 'opened', status,
// memory} and {type: 'tile', job, status, x, y, w, h, rgb, rays, evals}.
export function workerLoop(Engine, port, listen) {
  let engine = null;
  listen(async (m) => {
    try {
      if (m.type === 'open') {
        engine = await Engine.create(m.module, m.limit);
        let [st] = engine.peek(new Uint8Array(m.stream), m.scene);
        if (st === 0) st = engine.open(m.scene);
        port.postMessage({ type: 'opened', status: st, memory: engine.memoryBytes() });
      } else if (m.type === 'tile') {
        const [st, rgb, rays, evals] = engine.render(m.camera, m.knobs, m.x, m.y, m.w, m.h);
        const msg = { type: 'tile', job: m.job, status: st, x: m.x, y: m.y, w: m.w, h: m.h,
                      rgb, rays, evals };
        port.postMessage(msg, rgb ? [rgb.buffer] : []);
      }
    } catch (e) {
      port.postMessage({ type: 'error', job: m.job, status: e.status || 'CNERF_E_MEMORY',
                         message: String(e.message || e) });
    }
  });
}

// The source a worker runs: the two functions above, started for the platform it is on.
export function workerSource() {
  return `const Engine = (${defineEngine.toString()})();
const workerLoop = ${workerLoop.toString()};
if (typeof self !== 'undefined' && typeof self.postMessage === 'function') {
  workerLoop(Engine, self, (f) => { self.onmessage = (e) => f(e.data); });
} else {
  const { parentPort } = require('node:worker_threads');
  workerLoop(Engine, parentPort, (f) => parentPort.on('message', f));
}
`;
}
