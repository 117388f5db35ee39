// Headless Chromium driven over the DevTools protocol on a pipe (--remote-debugging-pipe:
// commands in on fd 3, replies and events out on fd 4, each JSON message ended by a NUL).
// No npm package and no download: Debian's chromium.
//   const b = await launch('/usr/bin/chromium');
//   const page = await b.newPage(); await page.open(url); await page.evaluate('1 + 1');
//   await b.close();
import { spawn } from 'node:child_process';
import { existsSync, mkdtempSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';

export async function launch(chromium) {
  if (!existsSync(chromium)) throw new Error(`${chromium} is missing (apt-get install chromium)`);
  const profile = mkdtempSync(join(tmpdir(), 'cnerf-chromium-'));
  const browser = spawn(chromium, ['--headless=new', '--remote-debugging-pipe', '--no-sandbox',
    '--disable-gpu', '--no-first-run', '--no-default-browser-check', '--disable-extensions',
    `--user-data-dir=${profile}`, '--allow-file-access-from-files', 'about:blank'],
  // Its own process group, so that close() can end the renderers and helpers with it.
  { stdio: ['ignore', 'ignore', 'pipe', 'pipe', 'pipe'], detached: true });
  let chromeLog = '';
  browser.stdio[2].on('data', (d) => { chromeLog = (chromeLog + d).slice(-4000); });
  const pending = new Map(), listeners = [];
  let nextId = 1, inbox = '';
  browser.stdio[4].on('data', (d) => {
    inbox += d.toString('utf8');
    let z;
    while ((z = inbox.indexOf('\0')) >= 0) {
      const msg = JSON.parse(inbox.slice(0, z));
      inbox = inbox.slice(z + 1);
      if (msg.id && pending.has(msg.id)) {
        const { resolve: ok, reject: no } = pending.get(msg.id);
        pending.delete(msg.id);
        if (msg.error) no(new Error(`${msg.error.message} ${msg.error.data || ''}`));
        else ok(msg.result);
      } else {
        for (const l of listeners) l(msg);
      }
    }
  });
  const send = (method, params = {}, sessionId) => new Promise((ok, no) => {
    const id = nextId++;
    pending.set(id, { resolve: ok, reject: no });
    browser.stdio[3].write(JSON.stringify({ id, method, params, sessionId }) + '\0');
  });
  const waitEvent = (method, sessionId, ms = 60000) => new Promise((ok, no) => {
    const t = setTimeout(() => no(new Error(`no ${method} in ${ms} ms`)), ms);
    const l = (m) => {
      if (m.method === method && m.sessionId === sessionId) {
        clearTimeout(t);
        listeners.splice(listeners.indexOf(l), 1);
        ok(m.params);
      }
    };
    listeners.push(l);
  });

  // A page: open(url), evaluate(expression) (awaited, by value), its console errors.
  async function newPage() {
    const { targetId } = await send('Target.createTarget', { url: 'about:blank' });
    const { sessionId } = await send('Target.attachToTarget', { targetId, flatten: true });
    const page = { sessionId, logs: [] };
    listeners.push((m) => {
      if (m.sessionId !== sessionId) return;
      if (m.method === 'Runtime.exceptionThrown') page.logs.push(`exception: ${JSON.stringify(m.params.exceptionDetails.exception?.description || m.params.exceptionDetails.text)}`);
      if (m.method === 'Runtime.consoleAPICalled' && m.params.type === 'error') page.logs.push(`console.error: ${m.params.args.map((a) => a.value ?? a.description).join(' ')}`);
    });
    await send('Page.enable', {}, sessionId);
    await send('Runtime.enable', {}, sessionId);
    page.open = async (url) => {
      const loaded = waitEvent('Page.loadEventFired', sessionId);
      await send('Page.navigate', { url }, sessionId);
      await loaded;
    };
    page.evaluate = async (expression) => {
      const r = await send('Runtime.evaluate', { expression, awaitPromise: true, returnByValue: true }, sessionId);
      if (r.exceptionDetails) throw new Error(`in the page: ${r.exceptionDetails.exception?.description || r.exceptionDetails.text}`);
      return r.result.value;
    };
    // Waits until `expression` is truthy in the page; returns its value.
    page.until = async (expression, ms = 60000) => {
      const end = Date.now() + ms;
      for (;;) {
        const v = await page.evaluate(expression).catch(() => null);
        if (v) return v;
        if (Date.now() > end) throw new Error(`timed out waiting for ${expression}`);
        await new Promise((r) => setTimeout(r, 50));
      }
    };
    page.close = () => send('Target.closeTarget', { targetId });
    return page;
  }

  // Asks the browser to shut down (it flushes its profile and ends its helpers), waits for
  // it, then ends whatever of its process group is left before removing the profile: a
  // helper still writing there made the removal fail with ENOTEMPTY under load.
  const close = async () => {
    const exited = browser.exitCode !== null || browser.signalCode !== null ? Promise.resolve()
      : new Promise((ok) => browser.once('exit', ok));
    const wait = (ms) => new Promise((ok) => setTimeout(ok, ms));
    send('Browser.close').catch(() => {});
    await Promise.race([exited, wait(30000)]);
    try { process.kill(-browser.pid, 'SIGKILL'); } catch { /* the group has ended */ }
    await Promise.race([exited, wait(5000)]);
    for (let attempt = 0; ; attempt++) {
      try {
        rmSync(profile, { recursive: true, force: true });
        return;
      } catch (e) {
        if (attempt >= 20) {
          process.stderr.write(`cdp: ${profile} left behind: ${e.message}\n`);
          return;
        }
        await wait(250);
      }
    }
  };
  return { send, newPage, close, log: () => chromeLog };
}
