// Types of the cnerf package (index.js).

/** The decoder's status names (include/cnerf/cnerf.h), with their values and messages. */
export const STATUS: Record<string, [number, string]>;

/**
 * An error of the decoder or of the package. `status` is the decoder's status name
 * ("CNERF_E_CRC", ...) or one of the package's: "CNERF_E_MEMORY" (the workspace cannot be
 * allocated), "CNERF_E_TOO_LARGE" (a stream over maxBytes), "CNERF_E_ABORTED" (a render
 * cancelled), "CNERF_E_FETCH" (a download failed).
 */
export class CnerfError extends Error {
  readonly status: string;
}

/** A camera in the decoder's fixed point: 21 int32 words (its own width and height). */
export interface Camera {
  words: number[];
}

export interface LookAt {
  eye: [number, number, number];
  target: [number, number, number];
  /** default [0, 0, 1] */
  up?: [number, number, number];
  /** horizontal field of view in degrees, default 50 */
  fovX?: number;
}

/** What a stream holds (cnerf info's essentials). */
export interface SceneInfo {
  versionMajor: number;
  versionMinor: number;
  /** scenes in the stream, and the one open (from 0) */
  scenes: number;
  scene: number;
  kind: '360' | 'forward-facing' | '360 with background' | 'unknown';
  coord: number;
  bounds: number[];
  near: number;
  far: number;
  background: number[];
  nets: number;
  nCoarse: number;
  nFine: number;
  depth: number[];
  width: number[];
  viewWidth: number[];
  color: number[];
  layers: number;
  params: number;
  biases: number;
  fileBytes: number;
  headBytes: number;
  layerBytes: number;
  ancillaryBytes: number;
  grid: number;
  gridBytes: number;
  unitBytes: number;
  sceneBytes: number;
  sharedBytes: number;
  /** the stream's meta text (the encoder's command, preset, ...) */
  meta: string;
  workspaceBytes: number;
  scratchBytes: number;
  [field: string]: unknown;
}

export interface Tile {
  x: number;
  y: number;
  width: number;
  height: number;
  /** the tile's RGB888 rows (RGB565 with those flags in knobs) */
  rgb: Uint8Array;
  done: number;
  total: number;
}

export interface RenderOptions {
  signal?: AbortSignal;
  onTile?: (tile: Tile) => void;
  /** [nCoarse, nFine, tStop, flags]; the stream's defaults when absent */
  knobs?: [number, number, number, number];
  /** only these tiles [x, y, w, h] (each side at most 64), instead of the whole image */
  tiles?: [number, number, number, number][];
}

export interface RenderedImage {
  width: number;
  height: number;
  data: Uint8ClampedArray;
  stats: { rays: number; evals: number; evalsPerRay: number };
}

export class Scene {
  readonly info: SceneInfo;
  /** bytes of WebAssembly memory each worker holds (its own copy of the decoded model) */
  readonly memoryPerWorker: number;
  readonly workers: unknown[];
  /** A camera at eye looking at target, made in integers (the same on any device). */
  lookAt(at: LookAt, width: number, height: number): Camera;
  /** A camera that looks at the scene. */
  startCamera(width?: number, height?: number): Camera;
  /** The look-at parameters of an orbit (radians; distance 1 is the default). */
  orbit(azimuth: number, elevation: number, distance: number): Required<LookAt>;
  /** Renders in the workers; a later render cancels this one (CNERF_E_ABORTED). */
  render(camera: Camera, options?: RenderOptions): Promise<ImageData & RenderedImage>;
  close(): void;
}

export interface OpenOptions {
  /** the module: compiled, its bytes or a URL; default cnerf.wasm beside index.js */
  wasm?: WebAssembly.Module | BufferSource | URL | string;
  /** default navigator.hardwareConcurrency (Node: os.availableParallelism()) */
  workers?: number;
  /** of a stream of several scenes, default 0 */
  scene?: number;
  /** the largest stream accepted, default 64 MiB */
  maxBytes?: number;
  /** bytes one instance may lay out (stream, workspace, scratch); default no limit */
  memoryLimit?: number;
}

export function openScene(bytes: Uint8Array | ArrayBuffer, options?: OpenOptions): Promise<Scene>;

/** A camera from a vector's .cam line: 18 integers (rot Q30, pos Q32, fx fy cx cy Q16, w, h). */
export function cameraFromIntegers(values: (number | string | bigint)[]): Camera;
