// SPDX-License-Identifier: Apache-2.0
// The "direct" way (the paper's "directly loading mesh"): the original files, one three.js loader
// request per file, each part added to the scene the moment it has loaded. Every request is
// issued at once, as a page that loops over its file list would; Chromium itself keeps at most six
// connections per host on HTTP/1.1 and queues the rest. The list of files is parts.json beside the
// page, fetched first (a site has to learn its file names somehow; the osteon viewer fetches
// manifest.json the same way).

import { createView, fail } from './common.js';

/// Loads every file of parts.json with `load(url) -> Promise<Object3D>`.
export async function loadDirect(load) {
  const view = createView();
  try {
    const response = await fetch('parts.json');
    if (!response.ok) throw new Error(`parts.json: HTTP ${response.status}`);
    const files = await response.json();
    if (!Array.isArray(files) || !files.length) throw new Error('parts.json: expected a non-empty array of file names');
    await Promise.all(files.map(async (file) => view.add(await load(file))));
    view.setComplete();
  } catch (e) {
    fail(e);
  }
}
