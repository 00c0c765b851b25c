// SPDX-License-Identifier: Apache-2.0
// A view shared by URL: the camera (position, target, up, field of view), the selected part, the
// hidden or isolated parts, the groups switched off, the clipping plane and the notes pinned to
// the surface (notes.mjs), written compactly into a URL's hash (docs/FORMAT.md, "Share URL"):
//
//   #v=1&cam=px,py,pz,tx,ty,tz,ux,uy,uz,fov&sel=skull&hide=femur_l,femur_r&clip=2,500,0
//     &notes=x,y,z,skull,Foramen%20magnum;x,y,z,,Another%20note
//
// The same text is the <osteon-viewer> element's `view` attribute and its `viewState` property.
// encodeViewState and parseViewState are pure (the unit tests run them under Node);
// captureView and applyView read and set one viewer's state (state.mjs). A value that cannot be
// read (not a number, an unknown part, a plane out of range, another version) is left out with a
// message naming it, and the rest of the view still applies: a link never breaks the viewer.

import { findPart } from './manifest.mjs';
import { kMaxNoteText, kMaxNotes, notesView, setNotes } from './notes.mjs';
import { applyVisibility, clipControls, select, setClipControls } from './panel.mjs';
import { setCameraView } from './view.mjs';

export const kShareVersion = 1;
const kFields = new Set(['v', 'cam', 'sel', 'hide', 'only', 'off', 'clip', 'clip2', 'cap', 'notes']);

// Numbers are written as JavaScript's shortest round-trip decimal (String(x)): reading the link
// back gives the same doubles, so a view restores exactly.
const number = (x) => String(Object.is(x, -0) ? 0 : x);
const names = (list) => list.map((n) => encodeURIComponent(n)).join(',');

/// The share text of `view` (no leading '#'): { camera: { position, target, up, fov } | null,
/// selected: part name | null, hidden: [part names] | null, only: [part names] | null (the parts
/// shown, all others hidden: the compact form of an isolation), groupsOff: [group names],
/// clip: { axis (0..2), position (0..1000 along the package's box), flip, second (the second
/// plane, the same fields, or null), cap (false: the sections left open) } | null (off), notes
/// (optional): [{ p: [x, y, z], part: part name | null, text }] }. A note is "x,y,z,part,text"
/// (part and text URL-encoded, so ',' and ';' only separate), the notes joined by ';'.
export function encodeViewState(view) {
  const fields = [`v=${kShareVersion}`];
  const { camera } = view;
  if (camera) fields.push(`cam=${[...camera.position, ...camera.target, ...camera.up, camera.fov].map(number).join(',')}`);
  if (view.selected) fields.push(`sel=${encodeURIComponent(view.selected)}`);
  if (view.only) fields.push(`only=${names(view.only)}`);
  else if (view.hidden?.length) fields.push(`hide=${names(view.hidden)}`);
  if (view.groupsOff?.length) fields.push(`off=${names(view.groupsOff)}`);
  const plane = (c) => `${c.axis},${c.position},${c.flip ? 1 : 0}`;
  if (view.clip) fields.push(`clip=${plane(view.clip)}`);
  if (view.clip?.second) fields.push(`clip2=${plane(view.clip.second)}`);
  if (view.clip && view.clip.cap === false) fields.push('cap=0');
  if (view.notes?.length) {
    fields.push(`notes=${view.notes.map((n) => [...n.p.map(number), encodeURIComponent(n.part ?? ''), encodeURIComponent(n.text)].join(',')).join(';')}`);
  }
  return fields.join('&');
}

function parseNumbers(text) {
  const parts = text.split(',');
  const values = parts.map((p) => (p.trim() === '' ? Number.NaN : Number(p)));
  return values.every(Number.isFinite) ? values : null;
}

/// The camera of `text`: "px,py,pz,tx,ty,tz" with optionally ",ux,uy,uz" and then ",fov" (the
/// `camera` attribute's form, and the share text's `cam`). Returns { camera, error }: camera
/// { position, target, up (null: keep the viewer's), fov (null: keep) } or null, error a message
/// or null.
export function parseCamera(text) {
  const v = parseNumbers(text);
  if (!v || ![6, 9, 10].includes(v.length)) {
    return { camera: null, error: `camera "${text}": expected 6, 9 or 10 comma-separated numbers (position, target, up, field of view)` };
  }
  const position = v.slice(0, 3);
  const target = v.slice(3, 6);
  if (position.every((x, i) => x === target[i])) return { camera: null, error: `camera "${text}": the position is the target` };
  const up = v.length >= 9 ? v.slice(6, 9) : null;
  if (up && Math.hypot(...up) === 0) return { camera: null, error: `camera "${text}": up is zero` };
  const fov = v.length === 10 ? v[9] : null;
  if (fov !== null && !(fov > 0 && fov < 180)) return { camera: null, error: `camera "${text}": field of view ${fov} is not in (0, 180) degrees` };
  return { camera: { position, target, up, fov }, error: null };
}

function decodeNames(key, text, errors) {
  const out = [];
  for (const item of text.split(',')) {
    try {
      out.push(decodeURIComponent(item));
    } catch (e) {
      errors.push(`${key}: "${item}" is not URL-encoded`);
    }
  }
  return out;
}

/// The notes of a `notes` field: at most kMaxNotes (the rest are cut, with a message), each text
/// at most kMaxNoteText characters; a note that cannot be read is left out, with a message. A
/// link is anyone's text: nothing here is ever shown as markup.
function parseNotes(text, errors) {
  const items = text.split(';');
  if (items.length > kMaxNotes) errors.push(`notes: ${items.length} notes, only the first ${kMaxNotes} are read`);
  const notes = [];
  items.slice(0, kMaxNotes).forEach((item, i) => {
    const fields = item.split(',');
    const p = fields.length === 5 ? parseNumbers(fields.slice(0, 3).join(',')) : null;
    let part;
    let body;
    try {
      part = decodeURIComponent(fields[3] ?? '');
      body = decodeURIComponent(fields[4] ?? '');
    } catch (e) {
      part = null;
    }
    if (!p || part === null) {
      errors.push(`notes[${i}]: expected x,y,z,part,text (numbers, then URL-encoded names): left out`);
      return;
    }
    if (body.length > kMaxNoteText) {
      errors.push(`notes[${i}]: a text of ${body.length} characters, cut to ${kMaxNoteText}`);
      body = body.slice(0, kMaxNoteText);
    }
    notes.push({ p, part: part || null, text: body });
  });
  return notes;
}

/// Reads a share text (a URL's hash with or without its '#', or the `view` attribute). Returns
/// { view, errors }: `view` as encodeViewState takes it, with what could be read (null when the
/// text is empty or another version), `errors` a message per value left out.
export function parseViewState(text) {
  const errors = [];
  const body = String(text ?? '').replace(/^#/, '').trim();
  if (!body) return { view: null, errors };
  const fields = new Map();
  for (const item of body.split('&')) {
    if (!item) continue;
    const eq = item.indexOf('=');
    const key = eq < 0 ? item : item.slice(0, eq);
    if (fields.has(key)) errors.push(`"${key}" is given twice; the first is used`);
    else fields.set(key, eq < 0 ? '' : item.slice(eq + 1));
  }
  if (fields.get('v') !== String(kShareVersion)) {
    errors.push(fields.has('v') ? `version "${fields.get('v')}" is not ${kShareVersion}: the view is ignored` : 'no version ("v=1"): the view is ignored');
    return { view: null, errors };
  }
  for (const key of fields.keys()) if (!kFields.has(key)) errors.push(`"${key}" is not a field of version ${kShareVersion}: ignored`);
  const view = { camera: null, selected: null, hidden: null, only: null, groupsOff: [], clip: null };
  if (fields.has('cam')) {
    const { camera, error } = parseCamera(fields.get('cam'));
    if (error) errors.push(error);
    view.camera = camera;
  }
  if (fields.has('sel')) {
    const [name] = decodeNames('sel', fields.get('sel'), errors);
    if (name) view.selected = name;
  }
  if (fields.has('hide')) view.hidden = decodeNames('hide', fields.get('hide'), errors).filter(Boolean);
  if (fields.has('only')) {
    view.only = decodeNames('only', fields.get('only'), errors).filter(Boolean);
    if (!view.only.length) {
      errors.push('"only" names no part: ignored');
      view.only = null;
    }
  }
  if (view.hidden && view.only) {
    errors.push('both "hide" and "only": "hide" is ignored');
    view.hidden = null;
  }
  if (fields.has('off')) view.groupsOff = decodeNames('off', fields.get('off'), errors);
  const parsePlane = (key) => {
    const v = parseNumbers(fields.get(key));
    if (!v || v.length !== 3 || ![0, 1, 2].includes(v[0]) || !Number.isInteger(v[1]) || v[1] < 0 || v[1] > 1000 || ![0, 1].includes(v[2])) {
      errors.push(`${key} "${fields.get(key)}": expected axis (0, 1 or 2), position (0 to 1000) and flip (0 or 1)`);
      return null;
    }
    return { axis: v[0], position: v[1], flip: v[2] === 1 };
  };
  if (fields.has('clip')) {
    const plane = parsePlane('clip');
    if (plane) view.clip = { ...plane, second: null, cap: true };
  }
  if (fields.has('clip2')) {
    const second = parsePlane('clip2');
    if (second && !view.clip) errors.push('clip2: a second plane without "clip" is ignored');
    else if (second) view.clip.second = second;
  }
  if (fields.has('cap')) {
    const cap = fields.get('cap');
    if (cap !== '0' && cap !== '1') errors.push(`cap "${cap}": expected 0 (sections open) or 1 (filled)`);
    else if (view.clip) view.clip.cap = cap === '1';
  }
  if (fields.has('notes')) view.notes = parseNotes(fields.get('notes'), errors);
  return { view, errors };
}

/// The view one viewer shows now (encodeViewState's argument); null before its manifest is read.
export function captureView(state) {
  const { manifest, camera, controls } = state;
  if (!manifest || !controls) return null;
  const parts = manifest.parts;
  const hidden = parts.filter((p) => state.hiddenParts.has(p.id));
  const shown = parts.filter((p) => !state.hiddenParts.has(p.id));
  // Whichever list is shorter: an isolated bone of 235 is one name, not 234.
  const useOnly = hidden.length > 0 && shown.length < hidden.length;
  const clip = clipControls(state);
  const notes = notesView(state);
  return {
    camera: { position: camera.position.toArray(), target: controls.target.toArray(), up: camera.up.toArray(), fov: camera.fov },
    selected: state.selectedPart >= 0 ? parts[state.selectedPart].name : null,
    hidden: useOnly ? null : hidden.map((p) => p.name),
    only: useOnly ? shown.map((p) => p.name) : null,
    groupsOff: [...state.groupOn].filter(([, on]) => !on).map(([group]) => group).sort(),
    clip: clip.on ? { axis: clip.axis, position: clip.position, flip: clip.flip, second: clip.second.on ? { axis: clip.second.axis, position: clip.second.position, flip: clip.second.flip } : null, cap: clip.cap } : null,
    ...(notes.length ? { notes } : {}),
  };
}

/// A part by its name first (what captureView writes), else by display name or source file.
function partNamed(manifest, name) {
  return manifest.parts.find((p) => p.name === name) ?? findPart(manifest, name);
}

/// Sets one viewer to `view` (parseViewState's); returns messages for the values it could not
/// use (an unknown part or group). Needs the manifest read and the controls made.
export function applyView(state, view) {
  const { manifest } = state;
  const errors = [];
  if (!view) return errors;
  if (view.camera) setCameraView(state, view.camera);
  const lookUp = (key, list) => list.flatMap((name) => {
    const part = partNamed(manifest, name);
    if (!part) errors.push(`${key}: no part "${name}"`);
    return part ? [part.id] : [];
  });
  if (view.hidden || view.only || view.groupsOff) {
    state.hiddenParts.clear();
    if (view.only) {
      const shown = new Set(lookUp('only', view.only));
      for (const part of manifest.parts) if (!shown.has(part.id)) state.hiddenParts.add(part.id);
    } else if (view.hidden) {
      for (const id of lookUp('hide', view.hidden)) state.hiddenParts.add(id);
    }
    for (const group of state.groupOn.keys()) state.groupOn.set(group, true);
    for (const group of view.groupsOff ?? []) {
      if (state.groupOn.has(group)) state.groupOn.set(group, false);
      else errors.push(`off: no group "${group}"`);
    }
    applyVisibility(state);
  }
  if (view.selected) {
    const [id] = lookUp('sel', [view.selected]);
    select(state, id ?? -1, { frame: false, scroll: false });
  } else {
    select(state, -1);
  }
  const clip = clipControls(state);
  setClipControls(state, view.clip
    ? { on: true, ...view.clip, cap: view.clip.cap ?? true, second: view.clip.second ? { on: true, ...view.clip.second } : { ...clip.second, on: false } }
    : { ...clip, on: false });
  // A view is whole: one without notes has none.
  setNotes(state, view.notes ?? [], errors);
  return errors;
}
