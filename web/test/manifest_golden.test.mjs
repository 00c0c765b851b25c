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
    });
  }
});
