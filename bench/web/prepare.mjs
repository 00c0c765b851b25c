// SPDX-License-Identifier: Apache-2.0
// Builds what bench/web serves, once per dataset, into build/bench-web/ (ignored by git):
//
//   site/<dataset>/direct/     the original part files (copied: osteon serve refuses symlinks that
//                              leave its root), parts.json, the page (GLTFLoader or STLLoader)
//   site/<dataset>/draco/      scene.glb: the parts merged by `gltf-transform merge` (GLB input) or
//                              written by glTF Transform from the STL files (welded, smooth
//                              normals), then `gltf-transform draco --quantize-position 14
//                              --quantization-volume scene`; DRACOLoader's decoder files; the page
//   site/<dataset>/gltfpack/   scene.glb: `gltfpack -i merged.glb -o scene.glb -cc -mi`; the page
//   site/<dataset>/gltfpack-cz/  the same with -cz (KHR_meshopt_compression, meshoptimizer 1.x's
//                              newer codec, which npm three's MeshoptDecoder, built from
//                              meshoptimizer 1.1, decodes); the same page
//   site/<dataset>/osteon/     `osteon pack FOLDER --precision E --viewer build/viewer [--names F]`
//                              (the dense skeleton: its label volume, with --surface-voxels 0)
//
// E, osteon's largest coordinate error, is half of Draco's 14-bit grid step over the merged scene
// (--quantization-volume scene: one grid of (2^14 - 1) steps over the scene box's largest side;
// gltfpack's default 14-bit grid is the same), so all three compressed ways round every coordinate
// to the same bound; when osteon's repeats would add to that bound, the budget is split (see the
// osteon step). Every served file gets a
// gzip -9 sibling (X.gz, which osteon serve sends to browsers that accept gzip, as nginx's
// gzip_static does) when that saves at least 5%: the same transport compression for every way.
//
// Each step is redone only when its inputs (file names, sizes, times; tool versions; options)
// changed since the stamp it left; --fresh redoes all.

import { spawnSync } from 'node:child_process';
import crypto from 'node:crypto';
import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import zlib from 'node:zlib';

const here = path.dirname(fileURLToPath(import.meta.url));
const modules = path.join(here, 'node_modules');
export const kPositionBits = 14;
const kGzipMinSaving = 0.05;

/// Runs a program; throws with its stderr's tail when it fails. Returns stdout.
function run(program, args, options = {}) {
  const result = spawnSync(program, args, { encoding: 'utf8', maxBuffer: 256 << 20, ...options });
  if (result.error) throw new Error(`${path.basename(program)}: ${result.error.message}`);
  if (result.status !== 0) {
    const tail = `${result.stderr || ''}${result.stdout || ''}`.trim().split('\n').slice(-12).join('\n');
    throw new Error(`${path.basename(program)} ${args.slice(0, 3).join(' ')} ... failed (exit ${result.status}):\n${tail}`);
  }
  return result.stdout;
}

function packageVersion(name) {
  return JSON.parse(fs.readFileSync(path.join(modules, name, 'package.json'), 'utf8')).version;
}

/// The versions of the npm tools a run used (printed with the results).
export function toolVersions() {
  return {
    three: packageVersion('three'),
    '@gltf-transform/cli': packageVersion('@gltf-transform/cli'),
    gltfpack: packageVersion('gltfpack'),
    'playwright-core': packageVersion('playwright-core'),
    esbuild: packageVersion('esbuild'),
  };
}

/// A short hash of files' names, sizes and modification times (or of a folder's files, recursively).
function signature(paths) {
  const hash = crypto.createHash('sha256');
  const visit = (p) => {
    const st = fs.statSync(p);
    if (st.isDirectory()) {
      for (const name of fs.readdirSync(p).sort()) visit(path.join(p, name));
    } else {
      hash.update(`${p}\0${st.size}\0${st.mtimeMs}\n`);
    }
  };
  for (const p of paths) {
    if (fs.existsSync(p)) visit(p);
    else hash.update(`${p}\0absent\n`);
  }
  return hash.digest('hex').slice(0, 24);
}

/// Runs `build` unless the stamp file says it ran with this `key` and its outputs still exist.
async function step(stampDir, name, key, outputs, build, log) {
  const stamp = path.join(stampDir, `${name}.json`);
  const keyText = JSON.stringify(key);
  if (fs.existsSync(stamp) && fs.readFileSync(stamp, 'utf8') === keyText && outputs.every((o) => fs.existsSync(o))) {
    return false;
  }
  const start = performance.now();
  await build();
  fs.mkdirSync(stampDir, { recursive: true });
  fs.writeFileSync(stamp, keyText);
  log(`  ${name}: built in ${((performance.now() - start) / 1000).toFixed(1)} s`);
  return true;
}

function emptyDir(dir) {
  fs.rmSync(dir, { recursive: true, force: true });
  fs.mkdirSync(dir, { recursive: true });
}

/// Writes the page of a way: its title, its bundle and <link rel=preload> for the files its script
/// will fetch (as="fetch" with crossorigin="anonymous" matches three.js's FileLoader requests, so
/// the preloaded response is the one used, not a second download).
function writePage(dir, title, script, preloads = []) {
  const template = fs.readFileSync(path.join(here, 'pages', 'page.html'), 'utf8');
  const links = preloads.map((href) => `<link rel="preload" href="${href}" as="fetch" crossorigin="anonymous">`).join('\n');
  fs.writeFileSync(path.join(dir, 'index.html'), template.replace('%TITLE%', title).replace('%PRELOAD%', links).replace('%SCRIPT%', script));
}

/// Bundles the peer pages (pages/*.js, three.js included) with esbuild into `outDir`.
async function bundlePages(outDir) {
  const esbuild = await import('esbuild');
  emptyDir(outDir);
  await esbuild.build({
    entryPoints: ['direct_gltf', 'direct_stl', 'draco', 'gltfpack'].map((n) => path.join(here, 'pages', `${n}.js`)),
    outdir: outDir,
    bundle: true,
    format: 'esm',
    minify: true,
    target: 'es2022',
    logLevel: 'error',
    legalComments: 'none',
  });
}

/// Writes the STL parts as one GLB (a node and mesh per part, named by file stem), welded
/// (bit-identical positions merged: STL stores every corner) with smooth vertex normals, which is
/// what a converter from STL to glTF gives and what the compressors then work on.
async function stlToGlb(files, output) {
  const { Document, NodeIO } = await import('@gltf-transform/core');
  const { weld, normals } = await import('@gltf-transform/functions');
  const { STLLoader } = await import('three/examples/jsm/loaders/STLLoader.js');
  const loader = new STLLoader();
  const doc = new Document();
  const buffer = doc.createBuffer();
  const scene = doc.createScene('skeleton');
  for (const file of files) {
    const bytes = fs.readFileSync(file);
    const geometry = loader.parse(bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.byteLength));
    const positions = geometry.getAttribute('position').array;
    const name = path.basename(file, path.extname(file));
    const accessor = doc.createAccessor().setType('VEC3').setArray(new Float32Array(positions)).setBuffer(buffer);
    const primitive = doc.createPrimitive().setAttribute('POSITION', accessor);
    const mesh = doc.createMesh(name).addPrimitive(primitive);
    scene.addChild(doc.createNode(name).setMesh(mesh));
  }
  await doc.transform(weld(), normals({ overwrite: true }));
  await new NodeIO().write(output, doc);
}

/// Writes X.gz beside every file X under `dir` that gzip -9 shrinks by at least 5%, and removes
/// .gz siblings that no longer apply. Returns nothing.
function precompress(dir) {
  const visit = (d) => {
    for (const entry of fs.readdirSync(d, { withFileTypes: true })) {
      const p = path.join(d, entry.name);
      if (entry.isDirectory()) {
        visit(p);
        continue;
      }
      if (entry.name.endsWith('.gz')) {
        if (!fs.existsSync(p.slice(0, -3))) fs.rmSync(p);
        continue;
      }
      const raw = fs.readFileSync(p);
      const gz = zlib.gzipSync(raw, { level: 9 });
      if (gz.length <= raw.length * (1 - kGzipMinSaving)) fs.writeFileSync(`${p}.gz`, gz);
      else fs.rmSync(`${p}.gz`, { force: true });
    }
  };
  visit(dir);
}

/// Bytes of the files under `dir` as a browser accepting gzip gets them (X.gz where present).
function servedBytes(dir) {
  let total = 0;
  const visit = (d) => {
    for (const entry of fs.readdirSync(d, { withFileTypes: true })) {
      const p = path.join(d, entry.name);
      if (entry.isDirectory()) visit(p);
      else if (!entry.name.endsWith('.gz')) total += fs.statSync(fs.existsSync(`${p}.gz`) ? `${p}.gz` : p).size;
    }
  };
  visit(dir);
  return total;
}

/// gltfpack's position grid step: integer positions are dequantized by the scale of the node that
/// draws them (one uniform scale for the whole scene). NaN when the file has no scaled node.
function gltfpackStep(glb) {
  const bytes = fs.readFileSync(glb);
  const json = JSON.parse(bytes.subarray(20, 20 + bytes.readUInt32LE(12)).toString('utf8'));
  const scales = (json.nodes || []).filter((n) => n.mesh !== undefined && n.scale).map((n) => Math.max(...n.scale));
  return scales.length ? Math.max(...scales) : NaN;
}

/// Whether `osteon pack` can write the viewer: the CLI knows --viewer and build/viewer has an
/// index.html. Returns null when it can, else the reason it cannot.
function osteonViewerMissing(osteon, viewer) {
  const help = run(osteon, ['pack', '--help']);
  if (!help.includes('--viewer')) return `${osteon} pack has no --viewer option (rebuild the CLI)`;
  if (!fs.existsSync(path.join(viewer, 'index.html'))) {
    return `${viewer}/index.html is missing (build the viewer: cd web && npm ci && npm run build:viewer)`;
  }
  return null;
}

/// Prepares one dataset. Returns { id, siteDir, ways: { <way>: { path, servedBytes, errorBound }
/// | { skipped } }, bounds, largestSide, precision, gridStep, triangles, merged }. A way's
/// `errorBound` is how far its quantization may move a vertex (the peers' grids: sqrt(3)/2 steps;
/// direct: 0; osteon: the manifest's largest at full resolution), in the dataset's unit; the
/// osteon way also gives `manifest`, the package's manifest.json.
export async function prepareDataset(dataset, options) {
  const { outDir, osteon, viewer, fresh, log } = options;
  // Only the ways asked for are built (all when options.ways is absent).
  const want = (way) => !options.ways || options.ways.includes(way);
  const work = path.join(outDir, 'work', dataset.id);
  const site = path.join(outDir, 'site', dataset.id);
  const stamps = path.join(work, 'stamps');
  if (fresh) fs.rmSync(stamps, { recursive: true, force: true });
  fs.mkdirSync(work, { recursive: true });
  log(`prepare ${dataset.id}: ${dataset.files.length} files from ${dataset.folder}`);

  const inputs = signature(dataset.files);
  const tools = toolVersions();
  const osteonSig = signature([osteon]);

  // The skeleton as osteon reads it (node transforms applied): its box sets the grid.
  const info = JSON.parse(run(osteon, ['info', '--json', dataset.folder]));
  const bounds = { min: info.bbox_min, max: info.bbox_max };
  const largestSide = Math.max(...[0, 1, 2].map((i) => bounds.max[i] - bounds.min[i]));
  const gridStep = largestSide / (2 ** kPositionBits - 1);
  const precision = gridStep / 2;

  const bundles = path.join(outDir, 'work', 'bundles');
  await step(path.join(outDir, 'work', 'stamps'), 'bundles', { pages: signature([path.join(here, 'pages')]), tools },
    ['direct_gltf.js', 'direct_stl.js', 'draco.js', 'gltfpack.js'].map((n) => path.join(bundles, n)),
    () => bundlePages(bundles), log);
  const pageKey = signature([bundles, path.join(here, 'pages', 'page.html'), fileURLToPath(import.meta.url)]);

  const ways = {};
  if (want('direct')) {
    // direct: the original files.
    const direct = path.join(site, 'direct');
    await step(stamps, 'direct', { inputs, pageKey }, [path.join(direct, 'index.html')], () => {
      emptyDir(direct);
      fs.mkdirSync(path.join(direct, 'files'));
      const urls = [];
      for (const file of dataset.files) {
        const name = path.basename(file);
        fs.copyFileSync(file, path.join(direct, 'files', name));
        urls.push(`files/${encodeURIComponent(name)}`);
      }
      fs.writeFileSync(path.join(direct, 'parts.json'), JSON.stringify(urls));
      const script = dataset.format === 'glb' ? 'direct_gltf.js' : 'direct_stl.js';
      fs.copyFileSync(path.join(bundles, script), path.join(direct, script));
      writePage(direct, `direct (${dataset.format === 'glb' ? 'GLTFLoader' : 'STLLoader'}) - bench/web`, script, ['parts.json']);
      precompress(direct);
    }, log);
    ways.direct = { path: 'direct/', servedBytes: servedBytes(direct), errorBound: 0 };
  }

  // The parts as one GLB: the input of both glTF compressors.
  const merged = path.join(work, 'merged.glb');
  const gltfTransform = path.join(modules, '.bin', 'gltf-transform');
  if (want('draco') || want('gltfpack') || want('gltfpack-cz')) {
    await step(stamps, 'merged', { inputs, tools }, [merged], async () => {
      if (dataset.format === 'glb') {
        run(gltfTransform, ['merge', ...dataset.files, merged, '--merge-scenes']);
      } else {
        await stlToGlb(dataset.files, merged);
      }
    }, log);
  }

  if (want('draco')) {
    const draco = path.join(site, 'draco');
    await step(stamps, 'draco', { inputs, tools, pageKey, bits: kPositionBits }, [path.join(draco, 'scene.glb')], () => {
      emptyDir(draco);
      run(gltfTransform, ['draco', merged, path.join(draco, 'scene.glb'), '--quantize-position', String(kPositionBits),
        '--quantization-volume', 'scene']);
      const decoder = path.join(modules, 'three', 'examples', 'jsm', 'libs', 'draco', 'gltf');
      fs.mkdirSync(path.join(draco, 'draco'));
      for (const name of ['draco_wasm_wrapper.js', 'draco_decoder.wasm']) {
        fs.copyFileSync(path.join(decoder, name), path.join(draco, 'draco', name));
      }
      fs.copyFileSync(path.join(bundles, 'draco.js'), path.join(draco, 'draco.js'));
      writePage(draco, 'Draco glTF (GLTFLoader + DRACOLoader) - bench/web', 'draco.js',
        ['scene.glb', 'draco/draco_wasm_wrapper.js', 'draco/draco_decoder.wasm']);
      precompress(draco);
    }, log);
    ways.draco = { path: 'draco/', servedBytes: servedBytes(draco), errorBound: (Math.sqrt(3) / 2) * gridStep };
  }

  // gltfpack, twice: -cc (EXT_meshopt_compression) and -cz (KHR_meshopt_compression).
  for (const [way, flag] of [['gltfpack', '-cc'], ['gltfpack-cz', '-cz']]) {
    if (!want(way)) continue;
    const dir = path.join(site, way);
    await step(stamps, way, { inputs, tools, pageKey, flag }, [path.join(dir, 'scene.glb')], () => {
      emptyDir(dir);
      run(process.execPath, [path.join(modules, 'gltfpack', 'cli.js'), '-i', merged, '-o', path.join(dir, 'scene.glb'), flag, '-mi']);
      fs.copyFileSync(path.join(bundles, 'gltfpack.js'), path.join(dir, 'gltfpack.js'));
      writePage(dir, `gltfpack ${flag} (GLTFLoader + MeshoptDecoder) - bench/web`, 'gltfpack.js', ['scene.glb']);
      precompress(dir);
    }, log);
    const step_ = gltfpackStep(path.join(dir, 'scene.glb'));
    ways[way] = { path: `${way}/`, servedBytes: servedBytes(dir), gridStep: step_, errorBound: (Math.sqrt(3) / 2) * step_ };
  }

  if (want('osteon')) {
    const packDir = path.join(site, 'osteon');
    const missing = osteonViewerMissing(osteon, viewer);
    if (missing) {
      ways.osteon = { skipped: missing };
      log(`  osteon: skipped: ${missing}`);
    } else {
      // A repeated bone is drawn from its prototype within the repeat tolerance, on top of the
      // codec's bound (docs/FORMAT.md: an instance's error_bound). When the default tolerance (the
      // codec's bound) takes osteon past Draco's bound, sqrt(3)/2 grid steps, the budget is split:
      // 80% to the codec, the rest to the repeats, so no drawn vertex can be further off than
      // Draco's.
      const dracoBound = (Math.sqrt(3) / 2) * gridStep;
      const argsFile = path.join(work, 'osteon_args.json');
      const inputsPacked = dataset.pack?.inputs ?? [dataset.folder];
      // The data are packed with --no-viewer and the viewer's files copied in by a step of their
      // own (what --viewer does: every file of the folder, relative paths kept), so a rebuilt
      // viewer does not repack the data (the dense skeleton's pack takes minutes).
      const base = ['pack', ...inputsPacked, '-o', packDir, '--no-viewer', ...(dataset.pack?.extra ?? []),
        ...(dataset.names ? ['--names', dataset.names] : [])];
      await step(stamps, 'osteon', { inputs: dataset.pack ? signature(inputsPacked) : inputs, osteonSig, base, precision }, [path.join(packDir, 'manifest.json'), argsFile], () => {
        const pack = (extra) => {
          emptyDir(packDir);
          run(osteon, [...base, ...extra]);
          const manifest = JSON.parse(fs.readFileSync(path.join(packDir, 'manifest.json'), 'utf8'));
          return Math.max(...manifest.instances.map((i) => i.error_bound), ...manifest.components.map((c) => c.error_bound));
        };
        let extra = ['--precision', String(precision)];
        let bound = pack(extra);
        if (bound > dracoBound * (1 + 1e-6)) {
          log(`  osteon: error bound ${bound.toPrecision(4)} with repeats > Draco's ${dracoBound.toPrecision(4)}: repacking with 80% to the codec`);
          extra = ['--precision', String(precision * 0.8), '--repeat-tolerance', String(dracoBound * 0.2 * 0.999)];
          bound = pack(extra);
        }
        fs.writeFileSync(argsFile, JSON.stringify({ args: [...base, ...extra], bound, dracoBound }));
      }, log);
      await step(stamps, 'osteon-viewer', { viewer: signature([viewer]), packed: signature([argsFile]) }, [path.join(packDir, 'index.html')], () => {
        for (const entry of fs.readdirSync(packDir)) {
          if (!['manifest.json', 'manifest.json.gz', 'c'].includes(entry)) fs.rmSync(path.join(packDir, entry), { recursive: true, force: true });
        }
        fs.cpSync(viewer, packDir, { recursive: true });
        precompress(packDir);
      }, log);
      const packed = JSON.parse(fs.readFileSync(argsFile, 'utf8'));
      ways.osteon = { path: 'osteon/', servedBytes: servedBytes(packDir), packArgs: packed.args, errorBound: packed.bound,
        manifest: path.join(packDir, 'manifest.json'), viewer };
    }
  }

  return {
    id: dataset.id,
    siteDir: site,
    ways,
    bounds,
    largestSide,
    gridStep,
    precision,
    dracoBound: (Math.sqrt(3) / 2) * gridStep,
    triangles: info.triangles,
    merged,
  };
}
