// SPDX-License-Identifier: Apache-2.0
// Shared helpers of the bench/paper scripts: where things are (repository, data, CLI, results),
// running a command and reading its JSON, and the number formats the page uses. Statistics,
// options and plots come from bench/lib/, which bench/web uses too.
//
// Every script of bench/paper imports this file; none of them needs an npm package except
// browser_decode.mjs (playwright-core, pinned in bench/package.json).

import { execFileSync } from 'node:child_process';
import { existsSync, mkdirSync, readFileSync, statSync, writeFileSync, renameSync } from 'node:fs';
import { cpus } from 'node:os';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

export const here = path.dirname(fileURLToPath(import.meta.url));
export const root = path.resolve(here, '..', '..');

/// The real meshes: $OSTEON_SHARED_DATA when set, else ../shared/data beside the checkout (the
/// layout every other bench assumes). Null when absent: the scripts then fall back to the phantom
/// and say so.
export function dataDir() {
  const dir = process.env.OSTEON_SHARED_DATA || path.resolve(root, '..', 'shared', 'data');
  return existsSync(dir) ? path.resolve(dir) : null;
}

/// The osteon CLI: $OSTEON_CLI, else the bench build (Release, what run.sh builds), else the
/// release build. Throws a clear error when none exists.
export function cliPath() {
  const candidates = [process.env.OSTEON_CLI, path.join(root, 'build-bench', 'osteon'),
    path.join(root, 'build', 'release', 'osteon')].filter(Boolean);
  const found = candidates.find((c) => existsSync(c));
  if (!found) {
    throw new Error(`no osteon CLI (looked for ${candidates.join(', ')}); run bash bench/paper/run.sh, ` +
      'which builds build-bench/osteon');
  }
  return found;
}

/// Where the measured results go (JSON, one file per item; the page is rendered from them).
export const resultsDir = path.join(root, 'docs', 'paper', 'results');

/// Runs a program, returns its stdout as text. On failure the error names the command and carries
/// the program's own stderr (osteon prints "osteon: error: FILE: what").
export function run(program, args, { cwd = root, timeoutMs = 15 * 60 * 1000 } = {}) {
  try {
    return execFileSync(program, args, {
      cwd, encoding: 'utf8', maxBuffer: 1 << 30, timeout: timeoutMs,
      stdio: ['ignore', 'pipe', 'pipe'],
    });
  } catch (e) {
    const stderr = String(e.stderr ?? '').trim().split('\n').slice(-5).join('\n');
    throw new Error(`${path.basename(program)} ${args.join(' ')} failed` +
      `${e.status != null ? ` (exit ${e.status})` : ''}: ${stderr || e.message}`);
  }
}

/// Runs a program that prints one JSON document and parses it.
export function runJson(program, args, options) {
  const text = run(program, args, options);
  try {
    return JSON.parse(text);
  } catch (e) {
    throw new Error(`${path.basename(program)} ${args.join(' ')}: output is not JSON (${e.message})`);
  }
}

export const fileSize = (file) => statSync(file).size;

export function writeJson(file, value) {
  mkdirSync(path.dirname(file), { recursive: true });
  const tmp = `${file}.tmp`;
  writeFileSync(tmp, `${JSON.stringify(value, null, 1)}\n`);
  renameSync(tmp, file);  // a reader never sees half a file
}

export const readJson = (file) => JSON.parse(readFileSync(file, 'utf8'));

/// Writes text through a temporary file and a rename.
export function writeText(file, text) {
  mkdirSync(path.dirname(file), { recursive: true });
  const tmp = `${file}.tmp`;
  writeFileSync(tmp, text);
  renameSync(tmp, file);
}

/// The machine, for the page's "measured on" lines.
export function machine() {
  const cpu = cpus();
  return {
    cpu: cpu[0]?.model?.trim() ?? 'unknown',
    cores: cpu.length,
    node: process.version,
    date: new Date().toISOString().slice(0, 10),
  };
}

// ---- number formats (the page's) ----

/// n significant digits, no exponent between 1e-3 and 1e6.
export function sig(x, n = 3) {
  if (x == null || Number.isNaN(x)) return 'n/a';
  if (x === 0) return '0';
  const a = Math.abs(x);
  if (a >= 1e-3 && a < 1e6) {
    const digits = Math.max(0, n - 1 - Math.floor(Math.log10(a)));
    return x.toFixed(Math.min(digits, 6));
  }
  return x.toExponential(n - 1);
}

export const fixed = (x, d = 2) => (x == null || Number.isNaN(x) ? 'n/a' : x.toFixed(d));

/// Thousands grouped with commas (the convention of docs/BENCHMARKS.md).
export const grouped = (x) => (x == null ? 'n/a' : Math.round(x).toLocaleString('en-US'));

export const kb = (bytes) => (bytes / 1024 >= 100 ? grouped(bytes / 1024) : sig(bytes / 1024, 3));
export const mb = (bytes) => fixed(bytes / (1024 * 1024), 2);
export const percent = (x, d = 1) => (x == null ? 'n/a' : `${(100 * x).toFixed(d)}%`);

/// A Markdown table from a header row and rows of cells; `align` is one 'l' or 'r' per column.
export function table(header, rows, align) {
  const a = align ?? header.map(() => 'l');
  const line = (cells) => `| ${cells.join(' | ')} |`;
  return [line(header), line(a.map((x) => (x === 'r' ? '---:' : '---'))), ...rows.map(line)]
    .join('\n');
}

/// Logs progress to stderr (stdout stays clean for JSON where a script prints it).
export const log = (...args) => process.stderr.write(`paper: ${args.join(' ')}\n`);

/// A positions-only binary PLY of `input` that Draco's command-line encoder can read (it reads
/// PLY and OBJ, not GLB or VTK, and takes an STL's facet normals as an attribute): the mesh
/// encoded by osteon at 24 bits and decoded. 24 bits moves no vertex by more than sqrt(3)/2 of
/// (largest side / 16,777,215), 5.2e-8 of the diagonal at most: over two orders of magnitude
/// below the 16-bit error, the finest this page measures. The decoded PLY carries smooth normals, which
/// the Draco runs skip (--skip NORMAL). Returns the path.
export function referencePly(cli, input, workDir, stem) {
  const stream = path.join(workDir, `${stem}.ref24.ostm`);
  const ply = path.join(workDir, `${stem}.ref24.ply`);
  if (!existsSync(ply)) {
    run(cli, ['encode', input, '-o', stream, '--bits', '24']);
    run(cli, ['decode', stream, '-o', ply]);
  }
  return ply;
}

/// The phantom skeleton (osteon phantom), written once into workDir: what the scripts use when
/// ../shared/data is absent.
export function phantomDir(cli, workDir) {
  const dir = path.join(workDir, 'phantom');
  if (!existsSync(path.join(dir, 'truth.json'))) run(cli, ['phantom', '-o', dir]);
  return dir;
}

/// A relative change with its sign: "+2.8%", "-38.0%", "0.0%".
export function change(x, d = 1) {
  if (x == null || Number.isNaN(x)) return 'n/a';
  const s = (100 * x).toFixed(d);
  return Number(s) > 0 ? `+${s}%` : Number(s) === 0 ? `${(0).toFixed(d)}%` : `${s}%`;
}
