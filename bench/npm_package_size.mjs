// SPDX-License-Identifier: Apache-2.0
// What a page that uses the npm package downloads: web/ is packed with `npm pack` (which builds
// web/dist/), the tarball installed with three 0.187 into a page folder, and a minimal page that
// only loads a package with OsteonLoader into a scene is bundled by esbuild, minified, with three
// left external (the page has three anyway: its size is reported on its own). The download is
// the page's JavaScript (OsteonLoader and the modules it shares with the viewer), the decoder
// worker and the WebAssembly decoder, each under gzip -9 (the system gzip), and the tarball.
//
//   node bench/npm_package_size.mjs [--out build/npm-bench] [--write docs/BENCHMARKS.md]
//
// --write replaces only the text between this benchmark's markers in that file (appending the
// section the first time); the other sections are left as they are.

import { execFileSync } from 'node:child_process';
import { mkdirSync, readFileSync, readdirSync, rmSync, statSync, writeFileSync } from 'node:fs';
import { createRequire } from 'node:module';
import os from 'node:os';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

import { parseCommandLine } from './lib/args.mjs';
import { writeSection } from './lib/section.mjs';

const repo = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '..');
const web = path.join(repo, 'web');
const esbuild = createRequire(path.join(web, 'package.json'))('esbuild');

const { values } = parseCommandLine({
  usage: 'node bench/npm_package_size.mjs [--out DIR] [--write FILE]',
  about: 'The download of a page that uses OsteonLoader from the npm package (gzip -9), and the tarball.',
  options: {
    out: { type: 'string', arg: 'DIR', help: 'working folder (default build/npm-bench; emptied first)' },
    write: { type: 'string', arg: 'FILE', help: 'replace this benchmark\'s section of FILE (docs/BENCHMARKS.md)' },
  },
});
const out = path.resolve(repo, values.out ?? 'build/npm-bench');
const write = values.write ?? null;
const kBegin = '<!-- bench/npm_package_size.mjs: begin (written by the script; edits here are overwritten) -->';
const kEnd = '<!-- bench/npm_package_size.mjs: end -->';
const kHeading = '## npm package download (bench/npm_package_size.mjs)';

const gzipBytes = (file) => execFileSync('gzip', ['-9c', file], { maxBuffer: 64 << 20 }).length;
const size = (file) => statSync(file).size;

rmSync(out, { recursive: true, force: true });
const page = path.join(out, 'page');
mkdirSync(page, { recursive: true });
const tarballName = execFileSync('npm', ['pack', '--silent', '--pack-destination', out], { cwd: web, encoding: 'utf8', stdio: ['ignore', 'pipe', 'inherit'] })
  .trim().split('\n').pop();
const tarball = path.join(out, tarballName);
writeFileSync(path.join(page, 'package.json'), JSON.stringify({ name: 'osteon-size-page', private: true, type: 'module' }));
execFileSync('npm', ['install', '--prefer-offline', '--no-audit', '--no-fund', '--no-package-lock', tarball, 'three@0.187.0'],
  { cwd: page, stdio: ['ignore', 'ignore', 'inherit'] });
const installed = path.join(page, 'node_modules', 'osteon');
const unpacked = (function walk(dir) {
  return readdirSync(dir, { withFileTypes: true }).reduce((sum, e) => sum + (e.isDirectory() ? walk(path.join(dir, e.name)) : size(path.join(dir, e.name))), 0);
})(installed);

// The minimal page: a package loaded into a scene. The renderer is the page's own business.
writeFileSync(path.join(page, 'page.mjs'), [
  "import { Scene } from 'three';",
  "import { OsteonLoader } from 'osteon';",
  'const scene = new Scene();',
  "new OsteonLoader().load('skeleton/', (group) => scene.add(group));",
  '',
].join('\n'));
await esbuild.build({
  entryPoints: [path.join(page, 'page.mjs')], bundle: true, minify: true, format: 'esm', target: 'es2022',
  external: ['three'], outfile: path.join(page, 'dist', 'page.js'), absWorkingDir: page, logLevel: 'warning',
});
// three 0.187 on its own (0.187 ships no minified build): the whole module minified by esbuild,
// and the part of it the minimal page pulls in when three is bundled and tree-shaken too.
writeFileSync(path.join(page, 'three_all.mjs'), "export * from 'three';\n");
const bundle = (entry, outfile, external) => esbuild.build({
  entryPoints: [path.join(page, entry)], bundle: true, minify: true, format: 'esm', target: 'es2022',
  external, outfile: path.join(page, 'dist', outfile), absWorkingDir: page, logLevel: 'warning',
});
await bundle('three_all.mjs', 'three.js', []);
await bundle('page.mjs', 'page_with_three.js', []);

const rows = [
  ['page script (OsteonLoader, manifest, stream, scene, decoder pool and wrapper; three external)', path.join(page, 'dist', 'page.js')],
  ['decoder worker (`dist/decoder-worker.js`)', path.join(installed, 'dist', 'decoder-worker.js')],
  ['WebAssembly decoder (`dist/osteon_decoder.wasm`)', path.join(installed, 'dist', 'osteon_decoder.wasm')],
].map(([what, file]) => ({ what, bytes: size(file), gzip: gzipBytes(file) }));
const total = { what: '**osteon download**', bytes: rows.reduce((s, r) => s + r.bytes, 0), gzip: rows.reduce((s, r) => s + r.gzip, 0) };
const threeAll = path.join(page, 'dist', 'three.js');
const withThree = path.join(page, 'dist', 'page_with_three.js');
const three = [
  { what: 'three 0.187, the whole module minified (esbuild), for reference', bytes: size(threeAll), gzip: gzipBytes(threeAll) },
  { what: 'the same page with three bundled in and tree-shaken (the page and the parts of three it uses; no renderer)', bytes: size(withThree), gzip: gzipBytes(withThree) },
];
const fmt = (n) => n.toLocaleString('en-US');

const table = [
  '| file | bytes | gzip -9 |',
  '|---|---:|---:|',
  ...[...rows, total].map((r) => `| ${r.what} | ${fmt(r.bytes)} | ${fmt(r.gzip)} |`),
  ...three.map((r) => `| ${r.what} | ${fmt(r.bytes)} | ${fmt(r.gzip)} |`),
  `| npm tarball \`${tarballName}\` (as published; unpacked ${fmt(unpacked)} bytes) | ${fmt(size(tarball))} | |`,
].join('\n');
const pkg = JSON.parse(readFileSync(path.join(installed, 'package.json'), 'utf8'));
const body = [
  `The download of a page that shows an osteon package with \`OsteonLoader\` from the npm package \`${pkg.name}@${pkg.version}\`: ` +
  'the page\'s own script (a minimal page that loads a package into a `Scene`, bundled and minified by esbuild with three external), ' +
  'the decoder worker and the WebAssembly decoder, each under gzip -9. three.js is listed apart: a page that draws a scene has it already. ' +
  'The tarball is `npm pack` of web/ (its prepack step builds web/dist/).',
  '',
  `Machine: ${os.cpus()[0]?.model ?? 'unknown CPU'}, ${os.cpus().length} cores; Node ${process.version}. Date: ${new Date().toISOString().slice(0, 10)}. Command (from the repository root, after \`cd web && npm run build:decoder\`):`,
  '',
  '```',
  'node bench/npm_package_size.mjs --write docs/BENCHMARKS.md',
  '```',
  '',
  table,
].join('\n');
console.log(body);

if (write) {
  writeSection(path.resolve(repo, write), { heading: kHeading, begin: kBegin, end: kEnd, body, tag: 'npm_package_size' });
}
