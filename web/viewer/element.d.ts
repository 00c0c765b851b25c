// SPDX-License-Identifier: Apache-2.0
// Types of the <osteon-viewer> element (viewer/element.mjs; the npm package's "osteon/element",
// dist/osteon-viewer.mjs). Importing the module defines the element.

/** The counts every 'progress' and 'load' event carries (a subset of the report). */
export interface OsteonViewerCounts {
  componentsLoaded: number;
  componentsFailed: number;
  componentsTotal: number;
  bytesLoaded: number;
  bytesTotal: number;
  /** How many errors the viewer has listed. */
  errors: number;
  /** 'load' and 'error' only: the last error, or null. */
  message?: string | null;
}

/** 'select': the part picked by a click or by select(); name null when the selection is cleared. */
export interface OsteonViewerSelectDetail {
  /** The display name. */
  name: string | null;
  /** The part's name in the manifest. */
  partName: string | null;
  /** Its index in the manifest's parts, -1 when cleared. */
  part: number;
  group: string | null;
  source: string | null;
  triangles: number;
}

export interface OsteonViewerEventMap extends HTMLElementEventMap {
  progress: CustomEvent<OsteonViewerCounts>;
  load: CustomEvent<OsteonViewerCounts>;
  /** Nothing can be drawn (the manifest, WebGL or the decoder failed). */
  error: CustomEvent<{ message: string }>;
  select: CustomEvent<OsteonViewerSelectDetail>;
  /** The view changed; detail.view is its share text (docs/FORMAT.md, "Share URL"). */
  viewchange: CustomEvent<{ view: string }>;
}

/**
 * `<osteon-viewer src="package/">`. Attributes: src, camera ("px,py,pz,tx,ty,tz[,ux,uy,uz[,fov]]"
 * or share text), view (share text), background ("#rrggbb"), panel ("on" | "off"), budget-mb,
 * budget-triangles, render ("page"), sync-hash, offline (registers the service worker beside the
 * element's script once the skeleton has loaded, for use without a network).
 */
export class OsteonViewer extends HTMLElement {
  static observedAttributes: string[];
  /** The loading state (what the standalone page shows as window.osteon); null before the start. */
  readonly report: Record<string, unknown> | null;
  /** Settles with the report once the manifest is read. */
  readonly ready: Promise<Record<string, unknown>>;
  /** The view as share text; setting it restores that view. */
  viewState: string | null;
  /** Each returns false for an unknown name or before the manifest is read. */
  select(name: string | null): boolean;
  frame(name?: string): boolean;
  hide(name: string): boolean;
  show(name: string): boolean;
  isolate(name: string): boolean;
  showAll(): boolean;
  addEventListener<K extends keyof OsteonViewerEventMap>(type: K, listener: (this: OsteonViewer, ev: OsteonViewerEventMap[K]) => unknown, options?: boolean | AddEventListenerOptions): void;
  addEventListener(type: string, listener: EventListenerOrEventListenerObject, options?: boolean | AddEventListenerOptions): void;
}

declare global {
  interface HTMLElementTagNameMap {
    'osteon-viewer': OsteonViewer;
  }
}
