// SPDX-License-Identifier: Apache-2.0
// Two or more builds of the osteon viewer on one package, side by side: what a change to the
// viewer does to a load, measured the way bench/web measures the osteon way (measure.mjs
// measureLoad, the same profiles and throttling), without the peers or their preparation.
//
//   node bench/web/compare_viewers.mjs --package DIR --viewer A --viewer B [--profile phone]
//        [--runs 5] [--timeout 120]
//
// DIR is a package (`osteon pack` output: manifest.json and c/); each --viewer is a built viewer
// folder (`OUT=folder node web/viewer/build.mjs`; build/viewer is the working tree's). Each viewer
// is served beside the package's files by its own `osteon serve`, and the viewers load in turn
// (run k of every viewer before run k + 1), so a slow spell of the shared machine hits each
// alike. Prints every load and, per viewer, the median and range of the longest main-thread task,
// total blocking time, first frame, skeleton complete and refined (ms from navigation start).

import { spawn } from 'node:child_process';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

import { parseCommandLine } from '../lib/args.mjs';
import { median } from '../lib/stats.mjs';
import { kProfiles, launchBrowser, measureLoad } from './measure.mjs';

const repo = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '../..');

const { values: opt } = parseCommandLine({
  usage: 'node bench/web/compare_viewers.mjs --package DIR --viewer A --viewer B [options]',
  options: {
    package: { type: 'string', arg: 'DIR', help: 'the package folder (manifest.json, c/)' },
    viewer: { type: 'string', multiple: true, arg: 'DIR', help: 'a built viewer folder; give two or more' },
    profile: { type: 'string', default: 'phone', arg: 'NAME', help: `${Object.keys(kProfiles).join(', ')} (default phone)` },
    runs: { type: 'string', default: '5', arg: 'N', help: 'loads per viewer (default 5)' },
    timeout: { type: 'string', default: '120', arg: 'S', help: 'seconds one load may take (default 120)' },
    osteon: { type: 'string', default: process.env.OSTEON_CLI ?? path.join(repo, 'build/release/osteon'), arg: 'PATH', help: 'the osteon CLI' },
    chromium: { type: 'string', default: '/usr/bin/chromium', arg: 'PATH', help: 'Chromium (never downloaded)' },
  },
});

function fail(message) {
  console.error(`compare_viewers: ${message}`);
  process.exit(1);
}

const profile = kProfiles[opt.profile] ?? fail(`--profile ${opt.profile}: expected one of ${Object.keys(kProfiles).join(', ')}`);
const runs = Number(opt.runs);
if (!Number.isInteger(runs) || runs < 1) fail(`--runs ${opt.runs}: expected a whole number of at least 1`);
if (!opt.package || !fs.existsSync(path.join(opt.package, 'manifest.json'))) fail(`--package ${opt.package}: no manifest.json there`);
const viewers = opt.viewer ?? [];
if (viewers.length < 2) fail('give two or more --viewer folders');
for (const v of viewers) if (!fs.existsSync(path.join(v, 'index.html'))) fail(`--viewer ${v}: no index.html there (a built viewer folder)`);

/// Hard-links `from` to `to` (no copy of a large package's chunks), or copies it where that fails
/// (another file system). Not a symbolic link: `osteon serve` refuses one that leaves its root.
function place(from, to) {
  if (fs.statSync(from).isDirectory()) {
    fs.mkdirSync(to);
    for (const name of fs.readdirSync(from)) place(path.join(from, name), path.join(to, name));
    return;
  }
  try {
    fs.linkSync(from, to);
  } catch {
    fs.copyFileSync(from, to);
  }
}

/// A site for `viewer`: the viewer's files beside the package's (the viewer's win where both
/// have one: a package carries the viewer it was packed with).
function makeSite(viewer, k) {
  const site = fs.mkdtempSync(path.join(os.tmpdir(), `osteon-viewers-${k}-`));
  for (const name of fs.readdirSync(viewer)) place(path.join(viewer, name), path.join(site, name));
  for (const name of fs.readdirSync(opt.package)) {
    if (!fs.existsSync(path.join(site, name))) place(path.join(opt.package, name), path.join(site, name));
  }
  return site;
}

/// `osteon serve site --port 0`; resolves with { url, stop }.
function serve(site) {
  return new Promise((resolve, reject) => {
    const child = spawn(opt.osteon, ['serve', site, '--port', '0', '--idle-timeout', String(Number(opt.timeout))], { stdio: ['ignore', 'pipe', 'ignore'] });
    let out = '';
    child.on('error', reject);
    child.on('exit', (code) => reject(new Error(`osteon serve exited (${code})`)));
    child.stdout.on('data', (chunk) => {
      out += chunk;
      const url = /https?:\/\/\S+/.exec(out);
      if (url) resolve({ url: url[0].replace(/\/?$/, '/'), stop: () => child.kill() });
    });
  });
}

const sites = viewers.map(makeSite);
const servers = [];
try {
  for (const site of sites) servers.push(await serve(site));
  const browser = await launchBrowser(opt.chromium);
  const results = viewers.map(() => []);
  for (let run = 0; run < runs; ++run) {
    for (const [k, server] of servers.entries()) {
      const r = await measureLoad(browser, server.url, { profile, viewport: profile.viewport ?? { width: 1280, height: 800 }, timeoutMs: Number(opt.timeout) * 1000 });
      results[k].push(r);
      console.log(`${viewers[k]} run ${run + 1}: longest task ${Math.round(r.longestTaskMs)} ms, TBT ${Math.round(r.tbtMs)} ms, first ${Math.round(r.firstMs)} ms, complete ${Math.round(r.completeMs)} ms, refined ${Math.round(r.refinedMs)} ms${r.timedOut ? ', did not finish' : ''}`);
    }
  }
  await browser.close();
  console.log(`\n${profile.label}, ${runs} load${runs > 1 ? 's' : ''} each; median [fastest, slowest] in ms:`);
  const row = (rs, key) => {
    const v = rs.map((r) => r[key]).filter(Number.isFinite);
    return v.length ? `${Math.round(median(v))} [${Math.round(Math.min(...v))}, ${Math.round(Math.max(...v))}]` : 'n/a';
  };
  for (const [k, rs] of results.entries()) {
    console.log(`${viewers[k]}: longest task ${row(rs, 'longestTaskMs')}, TBT ${row(rs, 'tbtMs')}, first frame ${row(rs, 'firstMs')}, ` +
      `skeleton complete ${row(rs, 'completeMs')}, refined ${row(rs, 'refinedMs')}`);
  }
} finally {
  for (const s of servers) s.stop();
  for (const site of sites) fs.rmSync(site, { recursive: true, force: true });
}
