// SPDX-License-Identifier: Apache-2.0
// The viewer's manifest reader (viewer/manifest.mjs) against the golden manifests the C++ parser
// is tested on too (tests/data/manifests/, README.md there): each valid_*.json gives the table
// sizes expected.json lists; each bad_*.json is refused with a message that names the field
// expected.json lists, as 'osteon: manifest.json: <path>: <what>'.

import assert from 'node:assert/strict';
import { readdirSync, readFileSync } from 'node:fs';
import path from 'node:path';
import { describe, test } from 'node:test';
import { fileURLToPath } from 'node:url';

import { parseManifest } from '../viewer/manifest.mjs';

const dir = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '..', '..', 'tests', 'data', 'manifests');
const expected = JSON.parse(readFileSync(path.join(dir, 'expected.json'), 'utf8'));
const files = readdirSync(dir).filter((f) => /^(valid|bad)_.*\.json$/.test(f)).sort();

describe('golden manifests (tests/data/manifests)', () => {
  test('expected.json lists every golden file, and only those', () => {
    assert.deepEqual(Object.keys(expected).sort(), files);
    assert.ok(files.some((f) => f.startsWith('valid_')) && files.some((f) => f.startsWith('bad_')));
  });

  test('valid_regions.json: languages, the region tree, part paths, names and systems', () => {
    const m = parseManifest(JSON.parse(readFileSync(path.join(dir, 'valid_regions.json'), 'utf8')));
    assert.deepEqual(m.languages, ['en', 'la', 'ja']);
    assert.deepEqual(m.groups.map((g) => [g.name, g.parent, g.depth]), [
      ['Skeleton', -1, 1], ['Lower limb', 0, 2], ['Left', 1, 3], ['Right', 1, 3], ['Vertebral column', 0, 2],
    ]);
    assert.deepEqual(m.groups[1].names, { la: 'Membrum inferius' });
    assert.deepEqual(m.groups[2].names, {});
    const femur = m.parts.find((p) => p.name === 'femur_l');
    assert.equal(femur.path, 2);
    assert.equal(femur.group, 'Skeleton / Lower limb / Left');
    assert.deepEqual(femur.names, { ja: '左大腿骨', la: 'Femur sinistrum' });
    assert.equal(femur.system, 'Skeletal system');
    const skull = m.parts.find((p) => p.name === 'skull');
    assert.deepEqual([skull.path, skull.names, skull.system, skull.group], [-1, {}, '', 'head']);
    assert.deepEqual(m.groupLabels.sort(), ['Skeleton / Lower limb / Left', 'Skeleton / Lower limb / Right', 'Skeleton / Vertebral column', 'head']);
    // A package without them: empty, not missing.
    const plain = parseManifest(JSON.parse(readFileSync(path.join(dir, 'valid_single_part.json'), 'utf8')));
    assert.deepEqual([plain.languages, plain.groups, plain.parts[0].path, plain.parts[0].names, plain.parts[0].system], [[], [], -1, {}, '']);
  });

  for (const file of files) {
    const want = expected[file];
    test(file, { skip: want ? false : 'not in expected.json' }, () => {
      const json = JSON.parse(readFileSync(path.join(dir, file), 'utf8'));
      if (file.startsWith('valid_')) {
        const m = parseManifest(json);
        assert.deepEqual(
          { parts: m.parts.length, components: m.components.length, instances: m.instances.length, chunks: m.chunks.length },
          want);
        return;
      }
      let message = null;
      try {
        parseManifest(json);
      } catch (e) {
        message = String(e?.message ?? e);
      }
      assert.notEqual(message, null, `${file} was accepted; expected an error at ${want.error}`);
      assert.ok(message.startsWith('osteon: manifest.json: '), message);
      assert.ok(message.includes(`: ${want.error}: `), `expected the error to name ${want.error}, got: ${message}`);
      // Where expected.json gives the words too, they are the C++ parser's.
      if (want.message) assert.ok(message.includes(`: ${want.error}: ${want.message}`), `expected '${want.error}: ${want.message}', got: ${message}`);
    });
  }
});
