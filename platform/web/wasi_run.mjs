// Runs a WASI command module (wasm32-wasi, preview 1) under Node's WASI with the host's file
// system at / (give it absolute paths) and the caller's environment; exits with the module's
// status. scripts/xarch.sh runs the decoder's test programs built for wasm32 so.
//   node wasi_run.mjs MODULE.wasm [ARGS...]
import { readFile } from 'node:fs/promises';
import { argv, env, exit } from 'node:process';
import { WASI } from 'node:wasi';

process.removeAllListeners('warning'); // node:wasi's "experimental" warning: not this run's
const [, , module, ...args] = argv;
if (!module) {
  console.error('usage: node wasi_run.mjs MODULE.wasm [ARGS...]');
  exit(2);
}
const wasi = new WASI({ version: 'preview1', args: [module, ...args], env, preopens: { '/': '/' },
                        returnOnExit: true });
const wasm = await WebAssembly.compile(await readFile(module));
const instance = await WebAssembly.instantiate(wasm, wasi.getImportObject());
exit(wasi.start(instance));
