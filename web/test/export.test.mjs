// SPDX-License-Identifier: Apache-2.0
// `osteon export` as glTF consumers see it: the Khronos glTF-Validator finds no error in what it
// writes (the generated phantom always; BodyParts3D and MyoSim, with its mirrored instances, when
// ../shared/data is there); three.js's GLTFLoader (with its MeshoptDecoder) loads it in Debian's
// headless Chromium with the meshes and instances the file declares, every mirrored instance
// under a node that mirrors (three.js flips the winding per object, not per instance); and the
// glTF that web pipelines make of an exported file (gltfpack -cc, gltf-transform's Draco) is read
// back by `osteon info` with every triangle it holds.

import assert from 'node:assert/strict';
import { existsSync, mkdtempSync, readFileSync, rmSync, writeFileSync } from 'node:fs';
import { tmpdir } from 'node:os';
import path from 'node:path';
import { execFileSync } from 'node:child_process';
import { after, before, describe, test } from 'node:test';

import { NodeIO } from '@gltf-transform/core';
import { ALL_EXTENSIONS } from '@gltf-transform/extensions';
import { draco } from '@gltf-transform/functions';
import draco3d from 'draco3dgltf';
import validator from 'gltf-validator';

import { chromiumPath, cli, dataDir, launchBrowser, osteon, repo } from './browser_helpers.mjs';

const web = path.join(repo, 'web');
const modules = path.join(web, 'node_modules');
const bodyparts = path.join(dataDir, 'aHer-dev__3DAnatomy');
const myosim = path.join(dataDir, 'MyoHub__myo_sim', 'meshes');
const haveData = existsSync(path.join(bodyparts, 'models', 'bones')) && existsSync(myosim);
const noData = haveData ? false : `${dataDir} is absent: real-mesh exports skipped (the phantom still runs)`;
const noCli = cli && existsSync(cli) ? false : 'the osteon CLI is not built (set OSTEON_CLI or build build/release)';
const noBrowser = existsSync(chromiumPath) ? false : `no browser at ${chromiumPath}`;

let scratch;
const exported = {};  // name -> { path, summary }

/// `osteon export ... --json`, parsed.
function exportGlb(name, inputs, extra = []) {
  const out = path.join(scratch, `${name}.glb`);
  const summary = JSON.parse(osteon('export', ...inputs, '-o', out, '--threads', '2', '--json', ...extra));
  exported[name] = { path: out, summary };
  return exported[name];
}

/// The JSON chunk of a GLB.
function gltfJson(file) {
  const bytes = readFileSync(file);
  assert.equal(bytes.toString('latin1', 0, 4), 'glTF');
  const length = bytes.readUInt32LE(12);
  return JSON.parse(bytes.toString('utf8', 20, 20 + length));
}

/// What a file declares: mesh nodes, instanced meshes and their instances, triangles drawn.
function declared(doc) {
  let plain = 0, instancedPrimitives = 0, instances = 0, triangles = 0, mirroredNodes = 0;
  for (const node of doc.nodes ?? []) {
    if (node.mesh === undefined) continue;
    const primitives = doc.meshes[node.mesh].primitives;
    const tris = primitives.reduce((sum, p) => sum + doc.accessors[p.indices].count / 3, 0);
    const inst = node.extensions?.EXT_mesh_gpu_instancing;
    if (inst) {
      const count = doc.accessors[Object.values(inst.attributes)[0]].count;
      instancedPrimitives += primitives.length;
      instances += count * primitives.length;
      triangles += tris * count;
      if ((node.scale ?? [1, 1, 1])[0] < 0) mirroredNodes += 1;
    } else {
      plain += primitives.length;
      triangles += tris;
    }
  }
  return { plain, instancedPrimitives, instances, triangles, mirroredNodes };
}

async function validate(file) {
  const report = await validator.validateBytes(new Uint8Array(readFileSync(file)), {
    uri: path.basename(file),
    maxIssues: 100,
  });
  const errors = report.issues.messages.filter((m) => m.severity === 0);
  return { errors, report };
}

function infoTriangles(file) {
  return JSON.parse(osteon('info', '--json', file)).triangles;
}

before(() => {
  scratch = mkdtempSync(path.join(tmpdir(), 'osteon-export-'));
  if (noCli) return;
  const phantom = path.join(scratch, 'phantom');
  osteon('phantom', '-o', phantom);
  exportGlb('phantom', [phantom]);
  exportGlb('phantom_plain', [phantom], ['--no-compress']);
  if (haveData) {
    exportGlb('bodyparts3d', [path.join(bodyparts, 'models', 'bones')],
      ['--names', path.join(bodyparts, 'meta.json')]);
    exportGlb('myosim', [myosim]);
  }
});

after(() => {
  if (scratch) rmSync(scratch, { recursive: true, force: true });
});

describe('glTF-Validator', { skip: noCli }, () => {
  test('the phantom, compressed and plain, has no error', async () => {
    for (const name of ['phantom', 'phantom_plain']) {
      const { errors } = await validate(exported[name].path);
      assert.deepEqual(errors, [], `${name}: ${JSON.stringify(errors.slice(0, 5))}`);
      assert.ok(exported[name].summary.mirrored_instances > 0, 'the phantom has mirrored instances');
    }
  });
  test('BodyParts3D and MyoSim have no error', { skip: noData }, async () => {
    for (const name of ['bodyparts3d', 'myosim']) {
      const { errors, report } = await validate(exported[name].path);
      assert.deepEqual(errors, [], `${name}: ${JSON.stringify(errors.slice(0, 5))}`);
      assert.equal(report.issues.numErrors, 0);
    }
    assert.ok(exported.myosim.summary.mirrored_instances > 0, 'MyoSim has mirrored instances');
    assert.equal(exported.bodyparts3d.summary.parts, 235);
  });
});

describe('three.js GLTFLoader in Chromium', { skip: noCli || noBrowser }, () => {
  let browser;
  before(async () => { browser = await launchBrowser(); });
  after(async () => { await browser?.close(); });

  // Serves the page, three.js and the file from memory (no server, nothing downloaded).
  async function load(file) {
    const page = await browser.newPage();
    const problems = [];
    page.on('pageerror', (e) => problems.push(`pageerror: ${e.message}`));
    await page.route('http://osteon.test/**', (route) => {
      const url = new URL(route.request().url());
      if (url.pathname === '/') {
        return route.fulfill({ contentType: 'text/html', body: `<!doctype html><script type="importmap">
          {"imports": {"three": "/three/build/three.module.js", "three/addons/": "/three/examples/jsm/"}}
          </script>` });
      }
      if (url.pathname === '/model.glb') return route.fulfill({ contentType: 'model/gltf-binary', body: readFileSync(file) });
      const local = path.join(modules, decodeURIComponent(url.pathname));
      if (!local.startsWith(modules) || !existsSync(local)) return route.fulfill({ status: 404, body: '' });
      return route.fulfill({ contentType: 'text/javascript', body: readFileSync(local) });
    });
    await page.goto('http://osteon.test/');
    const result = await page.evaluate(async () => {
      const THREE = await import('three');
      const { GLTFLoader } = await import('three/addons/loaders/GLTFLoader.js');
      const { MeshoptDecoder } = await import('three/addons/libs/meshopt_decoder.module.js');
      const loader = new GLTFLoader();
      loader.setMeshoptDecoder(MeshoptDecoder);
      const gltf = await loader.loadAsync('/model.glb');
      gltf.scene.updateMatrixWorld(true);
      let plain = 0, instancedPrimitives = 0, instances = 0, triangles = 0;
      let mirroredMeshes = 0, badInstances = 0;
      const m = new THREE.Matrix4();
      gltf.scene.traverse((o) => {
        if (!o.isMesh) return;
        const tris = o.geometry.index.count / 3;
        if (o.isInstancedMesh) {
          instancedPrimitives += 1;
          instances += o.count;
          triangles += tris * o.count;
          if (o.matrixWorld.determinant() < 0) mirroredMeshes += 1;
          // Every instance keeps a positive determinant: the winding is the object's.
          for (let i = 0; i < o.count; ++i) {
            o.getMatrixAt(i, m);
            if (m.determinant() <= 0) badInstances += 1;
          }
        } else {
          plain += 1;
          triangles += tris;
        }
      });
      // One frame, so that the buffers reach WebGL (SwiftShader) without an error.
      const renderer = new THREE.WebGLRenderer({ canvas: document.createElement('canvas') });
      renderer.setSize(64, 64);
      const camera = new THREE.PerspectiveCamera();
      const box = new THREE.Box3().setFromObject(gltf.scene);
      box.getCenter(camera.position);
      camera.position.z += box.getSize(new THREE.Vector3()).length();
      renderer.render(gltf.scene, camera);
      const glError = renderer.getContext().getError();
      return { plain, instancedPrimitives, instances, triangles, mirroredMeshes, badInstances, glError };
    });
    await page.close();
    assert.deepEqual(problems, []);
    return result;
  }

  async function expectLoads(name) {
    const { path: file, summary } = exported[name];
    const want = declared(gltfJson(file));
    const got = await load(file);
    assert.equal(got.plain, want.plain, 'meshes');
    assert.equal(got.instancedPrimitives, want.instancedPrimitives, 'instanced meshes');
    assert.equal(got.instances, want.instances, 'instances');
    assert.equal(got.triangles, summary.triangles, 'triangles');
    assert.equal(got.mirroredMeshes, want.mirroredNodes > 0 ? got.mirroredMeshes : 0);
    assert.ok(want.mirroredNodes === 0 || got.mirroredMeshes > 0, 'mirrored instances under a mirroring node');
    assert.equal(got.badInstances, 0, 'no instance matrix mirrors');
    assert.equal(got.glError, 0, 'WebGL error');
  }

  test('loads the phantom (compressed and plain)', async () => {
    await expectLoads('phantom');
    await expectLoads('phantom_plain');
  });
  test('loads BodyParts3D and MyoSim', { skip: noData }, async () => {
    await expectLoads('bodyparts3d');
    await expectLoads('myosim');
  });
});

describe('what web pipelines make of an export reads back', { skip: noCli }, () => {
  test('gltfpack -cc', () => {
    const out = path.join(scratch, 'gltfpack.glb');
    execFileSync(process.execPath, [path.join(modules, 'gltfpack', 'cli.js'), '-i', exported.phantom_plain.path,
      '-o', out, '-cc'], { stdio: ['ignore', 'pipe', 'pipe'] });
    const doc = gltfJson(out);
    assert.ok(doc.extensionsUsed.includes('EXT_meshopt_compression'));
    assert.equal(infoTriangles(out), declared(doc).triangles);
  });
  test("gltf-transform's Draco", async () => {
    const io = new NodeIO().registerExtensions(ALL_EXTENSIONS).registerDependencies({
      'draco3d.encoder': await draco3d.createEncoderModule(),
      'draco3d.decoder': await draco3d.createDecoderModule(),
    });
    const document = await io.read(exported.phantom_plain.path);
    await document.transform(draco());
    const out = path.join(scratch, 'draco.glb');
    writeFileSync(out, await io.writeBinary(document));
    const doc = gltfJson(out);
    assert.ok(doc.extensionsUsed.includes('KHR_draco_mesh_compression'));
    // Every triangle the file holds (Draco's encoder drops the degenerate ones it was given).
    assert.equal(infoTriangles(out), declared(doc).triangles);
  });
});
