// SPDX-License-Identifier: Apache-2.0
// The direct way for glTF / GLB parts: three.js's GLTFLoader, one load per file.

import { GLTFLoader } from 'three/examples/jsm/loaders/GLTFLoader.js';
import { loadDirect } from './direct.js';

const loader = new GLTFLoader();
loadDirect(async (url) => (await loader.loadAsync(url)).scene);
