// SPDX-License-Identifier: Apache-2.0
// The Draco glTF way: one .glb (the parts merged by gltf-transform, then Draco-compressed) loaded
// by GLTFLoader with DRACOLoader. The decoder files (npm three's examples/jsm/libs/draco/gltf/)
// are served from this page's folder, and preload() starts fetching them while the .glb
// downloads, as three.js's documentation recommends. DRACOLoader decodes in its own workers
// (four by default).

import { DRACOLoader } from 'three/examples/jsm/loaders/DRACOLoader.js';
import { GLTFLoader } from 'three/examples/jsm/loaders/GLTFLoader.js';
import { loadOneGlb } from './common.js';

const draco = new DRACOLoader().setDecoderPath('./draco/');
draco.preload();
loadOneGlb(new GLTFLoader().setDRACOLoader(draco));
