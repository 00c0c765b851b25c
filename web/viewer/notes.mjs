// SPDX-License-Identifier: Apache-2.0
// Notes pinned to the surface: with the Note tool on (overlay.mjs), a tap on a bone opens a small
// field in the view, at the point, for the note's text; Enter pins it there (Esc drops it). A note
// is drawn as a leader line from its point to its label (overlay.mjs), and travels in the share
// link (share.mjs, the `notes` field). Export downloads the notes and the measurements as JSON.
//
// A note's text is shown as text only (textContent), never as markup: it comes from links anyone
// can write. Its point is rounded when pinned (roundPoint), so the note a link brings back is the
// note that was made, to the digit.

import { Vector3 } from 'three';

import { findPart } from './manifest.mjs';
import { clearMeasurements, measurementsView, partErrorBound } from './measure.mjs';
import { pickAt } from './picking.mjs';
import { annotations, drawOverlay, setHint } from './overlay.mjs';
import { viewChanged } from './state.mjs';

/// A share link carries at most this many notes, each at most this long; a longer list or text
/// is cut (share.mjs parseViewState), and the tool adds no more.
export const kMaxNotes = 64;
export const kMaxNoteText = 500;

const $ = (state, id) => state.root.getElementById(id);

/// `point` rounded to a step of about a millionth of the package's diagonal (a power of ten in
/// its unit: 0.01 mm for a skeleton of 2 m), far below any error bound or tap.
export function roundPoint(manifest, point) {
  const { min, max } = manifest.bounds;
  const diagonal = Math.hypot(...max.map((v, i) => v - min[i])) || 1;
  const decimals = Math.min(12, Math.max(0, 6 - Math.ceil(Math.log10(diagonal))));
  const scale = 10 ** decimals;
  return point.map((v) => {
    const r = Math.round(v * scale) / scale;
    return Object.is(r, -0) ? 0 : r;
  });
}

/// A part by id, name (what a link writes) or what findPart reads; -1 for none or unknown.
function partIdOf(manifest, part) {
  if (part === undefined || part === null || part === -1) return -1;
  if (Number.isInteger(part)) return manifest.parts[part] ? part : -1;
  return (manifest.parts.find((p) => p.name === part) ?? findPart(manifest, part))?.id ?? -1;
}

/// Pins a note: { point: [x, y, z], part (id or name; optional), text }. Returns the note as
/// notesView lists it, or null (no manifest yet, a bad point, no text, or kMaxNotes already).
export function addNote(state, { point, part, text } = {}) {
  const { manifest } = state;
  if (!manifest || !Array.isArray(point) || point.length !== 3 || !point.every(Number.isFinite)) return null;
  const body = String(text ?? '').slice(0, kMaxNoteText);
  if (!body.trim()) return null;
  const a = annotations(state);
  if (a.notes.length >= kMaxNotes) {
    setHint(state, `At most ${kMaxNotes} notes.`);
    return null;
  }
  const note = { p: roundPoint(manifest, point), part: partIdOf(manifest, part), text: body };
  a.notes.push(note);
  viewChanged(state);  // redraws the overlay, checks the notes' depth; the share link carries them
  return noteView(manifest, note);
}

const noteView = (manifest, note) => ({ p: note.p, part: note.part >= 0 ? manifest.parts[note.part].name : null, text: note.text });

/// The notes: [{ p: [x, y, z], part: name or null, text }] (share.mjs captureView writes them).
export function notesView(state) {
  const { manifest } = state;
  return manifest && state.annotations ? state.annotations.notes.map((n) => noteView(manifest, n)) : [];
}

/// Replaces the notes with `list` (parseViewState's: [{ p, part: name or null, text }], already
/// bounded). An unknown part is named in `errors`; its note stays, pinned to no part.
export function setNotes(state, list, errors = []) {
  const { manifest } = state;
  const a = annotations(state);
  a.notes = list.slice(0, kMaxNotes).map((n) => {
    const part = partIdOf(manifest, n.part);
    if (n.part !== null && part < 0) errors.push(`notes: no part "${n.part}"`);
    return { p: roundPoint(manifest, n.p), part, text: String(n.text).slice(0, kMaxNoteText) };
  });
  drawOverlay(state);
  checkNotesDepth(state);
  return errors;
}

/// Removes every note; false when there was none.
export function clearNotes(state) {
  const a = annotations(state);
  if (!a.notes.length) return false;
  a.notes = [];
  viewChanged(state);  // redraws the overlay
  return true;
}

/// What Export downloads, and window.osteon.notes(): { unit, notes: notesView, measurements:
/// measure.mjs measurementsView }.
export function annotationsExport(state) {
  return { unit: state.manifest?.unit ?? null, notes: notesView(state), measurements: measurementsView(state) };
}

/// Downloads annotationsExport as osteon-notes.json.
function download(state) {
  const blob = new Blob([`${JSON.stringify(annotationsExport(state), null, 2)}\n`], { type: 'application/json' });
  const url = URL.createObjectURL(blob);
  const link = document.createElement('a');
  link.href = url;
  link.download = 'osteon-notes.json';
  link.click();
  setTimeout(() => URL.revokeObjectURL(url), 10000);
}

function closeForm(state) {
  const a = annotations(state);
  a.pendingNote = null;
  if (a.form) a.form.hidden = true;
}

/// The renderer's answer to a tap with the Note tool on: the field for the text opens at the point.
export function notePicked(state, message) {
  if (!message.point) {
    setHint(state, message.part >= 0 ? 'The renderer gave no surface point for this tap.' : 'No bone there: tap on a bone.');
    return;
  }
  const a = annotations(state);
  if (a.notes.length >= kMaxNotes) {
    setHint(state, `At most ${kMaxNotes} notes.`);
    return;
  }
  a.pendingNote = { point: message.point.slice(0, 3), part: message.part };
  const rect = state.canvas.getBoundingClientRect();
  const tap = a.lastTap ?? { x: rect.left + rect.width / 2, y: rect.top + rect.height / 2 };
  const { form } = a;
  form.hidden = false;
  // At the tap, kept inside the view.
  form.style.left = `${Math.max(4, Math.min(tap.x - rect.left + 12, rect.width - form.offsetWidth - 4))}px`;
  form.style.top = `${Math.max(4, Math.min(tap.y - rect.top + 12, rect.height - form.offsetHeight - 4))}px`;
  const input = form.querySelector('input');
  input.value = '';
  input.focus();
}

/// Makes the note's text field (hidden until a tap asks for it) and wires the tools bar's Export
/// and Clear (once): Clear removes the notes while the Note tool is on, else the measurements (as
/// Esc does in the bar).
export function wireNotes(state) {
  const a = annotations(state);
  const form = document.createElement('form');
  form.id = 'note-form';
  form.hidden = true;
  const input = document.createElement('input');
  Object.assign(input, { type: 'text', id: 'note-text', maxLength: kMaxNoteText, placeholder: 'Note', autocomplete: 'off' });
  input.setAttribute('aria-label', 'Note text');
  const add = document.createElement('button');
  add.type = 'submit';
  add.textContent = 'Pin';
  const cancel = document.createElement('button');
  cancel.type = 'button';
  cancel.textContent = 'Cancel';
  form.append(input, add, cancel);
  state.canvas.parentElement.append(form);
  a.form = form;
  form.addEventListener('submit', (e) => {
    e.preventDefault();
    const pending = a.pendingNote;
    closeForm(state);
    if (pending && addNote(state, { ...pending, text: input.value })) setHint(state, 'Note pinned.');
    state.canvas.focus();
  });
  cancel.addEventListener('click', () => {
    closeForm(state);
    state.canvas.focus();
  });
  input.addEventListener('keydown', (e) => {
    if (e.key !== 'Escape') return;
    e.stopPropagation();
    closeForm(state);
    state.canvas.focus();
  });
  a.onToolChanged = () => closeForm(state);
  $(state, 'notes-export')?.addEventListener('click', () => download(state));
  $(state, 'tools')?.addEventListener('keydown', (e) => {
    if (e.key === 'Escape') clearMeasurements(state);
  });
  $(state, 'measure-clear')?.addEventListener('click', () => {
    if (a.tool === 'note') clearNotes(state);
    else clearMeasurements(state);
  });
}

const kDepthCheckMs = 150;  // after the view's last change, the notes' depth is checked

/// Marks the notes that a surface hides from the camera as it is now (drawn faded, so a note on
/// the far side of a bone does not read as this side's): a quiet pick through each note's point
/// whose hit lies nearer the eye than the note, by more than the two parts' error bounds and a
/// thousandth of the package's size, puts the note behind. Debounced; the answers of a later
/// view replace an earlier one's. O(notes) picks, each O(log triangles) with the picking trees.
export function checkNotesDepth(state) {
  const a = annotations(state);
  clearTimeout(a.depthTimer);
  if (!a.notes.length || !state.manifest) return;
  a.depthTimer = setTimeout(() => markHiddenNotes(state), kDepthCheckMs);
}

async function markHiddenNotes(state) {
  const a = annotations(state);
  const seq = (a.depthSeq = (a.depthSeq ?? 0) + 1);
  const { camera, manifest } = state;
  camera.updateMatrixWorld();
  const eye = camera.position.toArray();
  const { min, max } = manifest.bounds;
  const size = Math.hypot(...max.map((v, i) => v - min[i]));
  const notes = a.notes.slice();
  const v = new Vector3();
  const answers = await Promise.all(notes.map((n) => {
    v.fromArray(n.p).project(camera);
    if (!(Math.abs(v.x) <= 1 && Math.abs(v.y) <= 1 && Math.abs(v.z) <= 1)) return null;  // not in view
    return pickAt(state, [v.x, v.y], { quiet: true });
  }));
  if (seq !== a.depthSeq) return;
  const from = (p) => Math.hypot(...p.map((x, i) => x - eye[i]));
  notes.forEach((n, k) => {
    const hit = answers[k];
    const slack = 1e-3 * size + partErrorBound(manifest, n.part) + (hit ? partErrorBound(manifest, hit.part) : 0);
    n.behind = !!hit?.point && from(hit.point) < from(n.p) - slack;
  });
  drawOverlay(state);
}
