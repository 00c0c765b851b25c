// SPDX-License-Identifier: Apache-2.0
// Types of OsteonLoader (viewer/loader.mjs; the npm package's main module, dist/loader.js).

import { Group, InstancedMesh, Intersection, Loader, LoadingManager, Mesh, Object3DEventMap } from 'three';

/** A part of the package, as manifest.json lists it (docs/FORMAT.md, "manifest.json"). */
export interface OsteonPart {
  /** Index in manifest.json's `parts` (and in OsteonGroup.parts). */
  id: number;
  /** read_path's part name: the folder-relative path without extension ("bones/femur_l"). */
  name: string;
  /** From the names file (`osteon pack --names`), else the name. */
  displayName: string;
  /** From the names file, else ""; with a path, the path's group names joined by " / ". */
  group: string;
  /** Index in manifest.groups of the part's deepest group; -1 when it has no path. */
  path: number;
  /** The part's name in other languages: tag -> name, each tag in manifest.languages. */
  names: Record<string, string>;
  /** "Skeletal system", "Cartilage", ...; "" when absent. */
  system: string;
  /** The file it was read from. */
  source: string;
  /** Triangles at full resolution. */
  triangles: number;
  /** The part whose components draw it (itself, or the part it repeats). */
  prototype: number;
  /** sRGB 0..1, or null (the bone colour). */
  color: [number, number, number] | null;
}

/** One stream of a component: its coarsest level first, the full level last. */
export interface OsteonLevel {
  level: number;
  chunk: number;
  offset: number;
  bytes: number;
  file: string;
  triangles: number;
  vertices: number;
  /** Measured distance from the input, in the manifest's unit. */
  error: number;
}

export interface OsteonComponent {
  id: string;
  index: number;
  triangles: number;
  vertices: number;
  bounds: { min: [number, number, number]; max: [number, number, number] };
  errorBound: number;
  levels: OsteonLevel[];
  first: OsteonLevel;
}

export interface OsteonInstance {
  index: number;
  part: number;
  component: string;
  /** Column-major 4x4, component frame to the group's frame. */
  matrix: number[];
  /** Determinant < 0: drawn from the winding-flipped index copy. */
  mirror: boolean;
  errorBound: number;
}

/** The parsed, checked manifest (viewer/manifest.mjs parseManifest). */
export interface OsteonManifest {
  unit: 'mm' | 'cm' | 'm' | 'in' | 'unknown';
  bounds: { min: [number, number, number]; max: [number, number, number] };
  view: { up: [number, number, number]; eye: [number, number, number] } | null;
  parts: OsteonPart[];
  chunks: { index: number; file: string; bytes: number }[];
  components: OsteonComponent[];
  componentById: Map<string, OsteonComponent>;
  instances: OsteonInstance[];
  streamOrder: OsteonComponent[];
  instancesOf: Map<string, number[]>;
  instancesOfPart: number[][];
  /** World box per part, known before any mesh arrives. */
  partBounds: { min: [number, number, number]; max: [number, number, number] }[];
  /** Language tags ("en", "la"); the first is the display names' language; [] when absent. */
  languages: string[];
  /** The region tree, each group after its parent; [] when absent. */
  groups: { name: string; parent: number; names: Record<string, string>; depth: number }[];
  /** The parts' distinct group strings. */
  groupLabels: string[];
  bytesTotal: number;
}

/** userData of every Mesh and InstancedMesh the loader makes. */
export interface OsteonObjectData {
  /** The component it draws (manifest.json `components[].id`). */
  component: string;
  /** An InstancedMesh of mirrored instances (drawn from the winding-flipped index copy). */
  mirror: boolean;
  /** The level drawn (0: the coarsest) and how many the component has. */
  level: number;
  levels: number;
  /** Part names per instanceId (a Mesh has one). */
  parts: string[];
  /** Part ids (OsteonGroup.parts) per instanceId. */
  partIds: number[];
  /** Indices in manifest.instances per instanceId. */
  instances: number[];
  /** A Mesh's part, with its manifest fields. */
  part?: OsteonPart;
  /** A Mesh's instance index. */
  instance?: number;
}

export interface OsteonComponentEvent {
  type: 'component';
  /** The component's id. */
  component: string;
  /** The level just drawn (0: coarsest) of `levels`. */
  level: number;
  levels: number;
  /** No finer level of this component comes in this load. */
  final: boolean;
  /** Its draw objects (the same objects at every level: their geometry is swapped). */
  objects: (Mesh | InstancedMesh)[];
  /** The names of the parts it draws. */
  parts: string[];
  /** Components at their final level so far, of `total`. */
  loaded: number;
  total: number;
}

export interface OsteonGroupEventMap extends Object3DEventMap {
  manifest: { manifest: OsteonManifest };
  component: Omit<OsteonComponentEvent, 'type'>;
  load: {};
  error: { error: Error };
}

/** What OsteonLoader.load gives: the package's draw objects and tables. */
export class OsteonGroup extends Group<OsteonGroupEventMap> {
  readonly isOsteonGroup: true;
  /** null until the manifest has arrived (the 'manifest' event). */
  manifest: OsteonManifest | null;
  parts: OsteonPart[];
  /** The manifest's URL. */
  url: string;
  /** The part under a Raycaster intersection with one of this group's objects, or null. */
  partAt(intersection: Intersection): OsteonPart | null;
  /** A part by display name, name or source file (any case), or null. */
  findPart(query: string): OsteonPart | null;
  /** Shows the parts for which `visible(part)` holds (instanceIds then count visible instances). */
  setPartVisibility(visible: (part: OsteonPart) => boolean): void;
  /** Stops its load, frees its geometries and materials. */
  dispose(): void;
}

export type OsteonLevels = 'progressive' | 'coarsest' | 'finest';

export class OsteonLoader extends Loader<OsteonGroup> {
  constructor(manager?: LoadingManager);
  decoderPath: string;
  workerLimit: number | undefined;
  levels: OsteonLevels;
  timeout: number;
  /** The folder of osteon_decoder.wasm and decoder-worker.js (default: beside the module). */
  setDecoderPath(path: string): this;
  /** At most n decoder workers (default: hardware threads - 1, 1 to 4). */
  setWorkerLimit(n: number): this;
  /** 'progressive' (default: coarsest, then the full level), 'coarsest' or 'finest'. */
  setLevels(levels: OsteonLevels): this;
  /** A load without a byte or a decode for `ms` milliseconds fails (default 30000). */
  setTimeout(ms: number): this;
  /** Loads and compiles the decoder and starts its workers now. */
  preload(): this;
  /** Returns the group at once; its objects are added as they are decoded. */
  load(
    url: string,
    onLoad?: (group: OsteonGroup) => void,
    onProgress?: (event: ProgressEvent) => void,
    onError?: (error: Error) => void,
  ): OsteonGroup;
  loadAsync(url: string, onProgress?: (event: ProgressEvent) => void): Promise<OsteonGroup>;
  /** Ends every load in flight with an Error ('osteon: <url>: aborted'). */
  abort(): this;
  /** Aborts the loads in flight and terminates the decoder workers. */
  dispose(): this;
}
