// SPDX-License-Identifier: Apache-2.0
// The gltfpack way: one .glb from `gltfpack -cc -mi` (meshopt compression, quantized attributes,
// EXT_mesh_gpu_instancing) loaded by GLTFLoader with npm three's MeshoptDecoder (its WebAssembly
// is inside the module), set up the way three.js's documentation shows: decoding on the main
// thread.

import { GLTFLoader } from 'three/examples/jsm/loaders/GLTFLoader.js';
import { MeshoptDecoder } from 'three/examples/jsm/libs/meshopt_decoder.module.js';
import { loadOneGlb } from './common.js';

loadOneGlb(new GLTFLoader().setMeshoptDecoder(MeshoptDecoder));
