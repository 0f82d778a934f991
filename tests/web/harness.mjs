// What the browser tests share: numbered ok/FAIL checks, waiting with a deadline, the real
// featureline-server on a free 127.0.0.1 port (stopped by its own PID), the built page, and
// Debian's headless Chromium through playwright-core. Preconditions FAIL a test, never skip it.
import { spawn } from 'node:child_process';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

export const repo = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '..', '..');
export const fromRepo = (p) => (path.isAbsolute(p) ? p : path.join(repo, p));
export const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

// A problem that makes going on pointless: counted as a failure, then clean up and stop.
export class Fatal extends Error {}

export async function until(what, fn, timeoutMs = 15000, everyMs = 50) {
  const end = Date.now() + timeoutMs;
  let last;
  for (;;) {
    try {
      last = await fn();
      if (last) return last;
    } catch (e) {
      if (e instanceof Fatal) throw e;
      last = e;
    }
    if (Date.now() > end) throw new Fatal(`timed out after ${timeoutMs} ms waiting for ${what}${last instanceof Error ? ` (${last.message})` : ''}`);
    await sleep(everyMs);
  }
}

// A mesh of ../shared/data/meshes (relative to the repository), or a clear failure.
export function sharedMesh(name) {
  const p = path.join(repo, '..', 'shared', 'data', 'meshes', name);
  if (!fs.existsSync(p)) throw new Fatal(`test mesh missing: ${path.relative(repo, p)} (expected at ../shared/data/meshes/${name} beside the repository)`);
  return p;
}

export function createHarness({ totalTimeoutMs = 180_000, artifactName = 'web.png' } = {}) {
  const SERVER = fromRepo(process.env.SERVER || 'build/server/featureline-server');
  const ARTIFACT = fromRepo(process.env.ARTIFACTS || `build/test-artifacts/${artifactName}`);
  const CHROMIUM = process.env.CHROMIUM || '/usr/bin/chromium';
  const h = {
    SERVER,
    ARTIFACT,
    artifactDir: path.dirname(ARTIFACT),
    CHROMIUM,
    passed: 0,
    failed: 0,
    tmp: fs.mkdtempSync(path.join(os.tmpdir(), 'featureline-web-')),
    server: null,
    serverLog: '',
    context: null,
    page: null,
    pageErrors: [],
    consoleErrors: [],
    webRoot: '',
  };
  h.ok = (name) => {
    h.passed++;
    console.log(`ok ${h.passed + h.failed} - ${name}`);
  };
  h.fail = (name, detail) => {
    h.failed++;
    console.log(`FAIL ${h.passed + h.failed} - ${name}${detail ? `: ${detail}` : ''}`);
  };
  h.check = (cond, name, detail) => {
    if (cond) h.ok(name);
    else h.fail(name, typeof detail === 'function' ? detail() : detail);
    return !!cond;
  };
  h.finish = (code) => {
    console.log(`${h.passed} passed, ${h.failed} failed`);
    process.exit(code ?? (h.failed ? 1 : 0));
  };
  h.artifact = (name) => {
    fs.mkdirSync(h.artifactDir, { recursive: true });
    return path.join(h.artifactDir, name);
  };
  const timer = setTimeout(() => {
    h.fail('the test finishes in time', `still running after ${totalTimeoutMs / 1000} s`);
    h.cleanup().finally(() => h.finish(1));
  }, totalTimeoutMs);

  h.cleanup = async () => {
    clearTimeout(timer);
    try {
      if (h.context) await h.context.close();
    } catch {
      // already gone
    }
    const server = h.server;
    if (server && server.exitCode === null) {
      process.kill(server.pid, 'SIGTERM'); // this server's own PID
      await Promise.race([new Promise((r) => server.once('exit', r)), sleep(3000)]);
      if (server.exitCode === null) process.kill(server.pid, 'SIGKILL');
    }
    fs.rmSync(h.tmp, { recursive: true, force: true });
  };

  // Preconditions and the built page; exits with a failure when something is missing.
  h.prepare = async () => {
    if (!fs.existsSync(CHROMIUM)) {
      h.fail('chromium is installed', `${CHROMIUM} not found (install it: apt-get install -y chromium; or set CHROMIUM)`);
      h.finish(1);
    }
    try {
      ({ chromium: h.chromium } = await import('playwright-core'));
    } catch (e) {
      h.fail('playwright-core is installed', `cannot import playwright-core (run npm ci at the repository root): ${e.message}`);
      h.finish(1);
    }
    if (!fs.existsSync(SERVER)) {
      h.fail('the server binary exists', `${SERVER} not found (build featureline-server, or set SERVER)`);
      h.finish(1);
    }
    // WEB_ROOT=embedded: the page compiled into the server binary, as a user runs it.
    h.embeddedPage = process.env.WEB_ROOT === 'embedded';
    if (h.embeddedPage) return;
    h.webRoot = process.env.WEB_ROOT ? fromRepo(process.env.WEB_ROOT) : '';
    if (!h.webRoot) {
      try {
        const { build } = await import(path.join(repo, 'web', 'build.mjs'));
        h.webRoot = build(path.join(h.tmp, 'web')).outDir;
      } catch (e) {
        h.fail('the page builds', e.message);
        h.finish(1);
      }
    }
    h.check(fs.existsSync(path.join(h.webRoot, 'index.html')), 'the page is built', `${h.webRoot}/index.html missing`);
  };

  h.startServer = async (extraArgs = []) => {
    const portFile = path.join(h.tmp, 'port');
    h.server = spawn(SERVER, ['--host', '127.0.0.1', '--port', '0', '--port-file', portFile, ...(h.embeddedPage ? [] : ['--web-root', h.webRoot]), '--threads', '2', ...extraArgs], {
      stdio: ['ignore', 'pipe', 'pipe'],
    });
    h.server.stdout.on('data', (d) => (h.serverLog += d));
    h.server.stderr.on('data', (d) => (h.serverLog += d));
    const port = await until('the server to write its port', () => {
      if (h.server.exitCode !== null) throw new Fatal(`the server exited with ${h.server.exitCode}:\n${h.serverLog}`);
      const text = fs.existsSync(portFile) ? fs.readFileSync(portFile, 'utf8').trim() : '';
      return /^\d+$/.test(text) ? Number(text) : 0;
    });
    h.base = `http://127.0.0.1:${port}`;
    return h.base;
  };

  // contextOptions: more playwright context options (e.g. {hasTouch: true}).
  h.launch = async (viewport = { width: 1280, height: 800 }, contextOptions = {}) => {
    const profile = path.join(h.tmp, 'profile');
    fs.mkdirSync(profile, { recursive: true });
    h.context = await h.chromium.launchPersistentContext(profile, {
      executablePath: CHROMIUM,
      headless: true,
      viewport,
      acceptDownloads: true,
      ...contextOptions,
      args: [
        '--no-sandbox',
        '--disable-gpu',
        '--disable-quic',
        '--no-first-run',
        '--disable-background-networking',
        '--disable-component-update',
        '--disable-sync',
        // WebGL without a GPU: ANGLE on SwiftShader (software).
        '--use-angle=swiftshader',
        '--enable-unsafe-swiftshader',
      ],
    });
    // The page loads three.js's modules (about 0.5 MB) from the server under test; with every
    // core busy (ctest -j beside other builds) that took up to 22 s, over playwright's default
    // 30 s navigation limit once the page's own requests were added. A slow machine is not a
    // failure of the page: navigations get 120 s (each test's total limit still holds).
    h.context.setDefaultNavigationTimeout(120_000);
    h.page = h.context.pages()[0] || (await h.context.newPage());
    h.watch(h.page);
    return h.page;
  };

  // Uncaught errors and console errors of a page are collected (and must stay empty).
  h.watch = (page) => {
    page.on('pageerror', (e) => h.pageErrors.push(e.message));
    page.on('console', (m) => {
      if (m.type() === 'error') h.consoleErrors.push(m.text());
      if (process.env.E2E_VERBOSE) console.log(`  [page ${m.type()}] ${m.text()}`);
    });
  };

  // Runs the test body; on an exception: a failure, a screenshot, the server's last lines.
  h.run = async (body) => {
    try {
      await body();
    } catch (e) {
      h.fail('the browser test runs to the end', e instanceof Fatal ? e.message : e.stack || String(e));
      try {
        if (h.page) {
          const shot = h.artifact(path.basename(ARTIFACT).replace(/\.png$/, '-failure.png'));
          await h.page.screenshot({ path: shot });
          console.log(`failure screenshot: ${shot}`);
        }
      } catch {
        // no screenshot then
      }
      if (h.pageErrors.length) console.log(`page errors:\n${h.pageErrors.join('\n')}`);
      if (h.serverLog) console.log(`server output (last lines):\n${h.serverLog.split('\n').slice(-15).join('\n')}`);
    }
    await h.cleanup();
    h.finish();
  };
  return h;
}
