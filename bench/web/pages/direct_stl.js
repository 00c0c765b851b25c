// SPDX-License-Identifier: Apache-2.0
// The direct way for STL parts: three.js's STLLoader, one load per file (a triangle soup with the
// file's facet normals, as STLLoader gives it).

import { Mesh } from 'three';
import { STLLoader } from 'three/examples/jsm/loaders/STLLoader.js';
import { loadDirect } from './direct.js';

const loader = new STLLoader();
loadDirect(async (url) => new Mesh(await loader.loadAsync(url)));
