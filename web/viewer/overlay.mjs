// SPDX-License-Identifier: Apache-2.0
// What is pinned to the surface, drawn over the 3D view: the measurements (measure.mjs) and the
// notes (notes.mjs), in one SVG layer laid over the canvas, in its CSS pixels. Each point is kept
// in the package's coordinates and projected again with the page's camera (state.camera, the one
// the renderer draws with a copy of) whenever the camera moves or the view is resized, so the
// lines stay on the bone; a line or label whose point is behind the camera is left out. Labels
// are drawn at a fixed size in pixels, so they read the same at every zoom. Lines are not
// hidden behind bones: the overlay has no depth, it shows where the points are.
//
// The tools bar (index.html's #tools) switches the tools: Measure and Note are toggles (one on at
// a time, aria-pressed follows); while one is on, a tap on the canvas places a point instead of
// selecting a bone (picking.mjs). Everything lives in state.annotations (annotations()).

import { Vector3 } from 'three';

const kSvg = 'http://www.w3.org/2000/svg';
const kLineChars = 32;                 // a note's label wraps at this many characters a line,
const kLines = 4;                      // and shows this many lines (the whole text is its tooltip)
const kLineHeight = 16;                // in CSS pixels
const kNoteOffset = { x: 22, y: -30 };  // the label's corner from the pinned point, in CSS pixels
const kCharPixels = 7.8;               // about the width of a character of the labels' 13 px font

/// This viewer's measurements, notes and tool state (made on first use):
///   tool: null | 'measure' | 'note', measurements: [{ points: [[x, y, z]], parts: [part id or
///   -1] }] (2 points: a distance, 3: also the angle at the middle one), current: the measurement
///   taking points (or null), notes: [{ p: [x, y, z], part: part id or -1, text, behind (a surface hides it) }], pendingNote:
///   { point, part } while the note's text is asked for, pickWaiters: pick id -> resolve
///   (picking.mjs pickAt), svg: the overlay, hint: a line for the tools bar.
export function annotations(state) {
  state.annotations ??= {
    tool: null, measurements: [], current: null, notes: [], pendingNote: null, pickWaiters: new Map(), svg: null, hint: '',
  };
  return state.annotations;
}

const $ = (state, id) => state.root.getElementById(id);

function svgElement(name, attributes = {}) {
  const element = document.createElementNS(kSvg, name);
  for (const [key, value] of Object.entries(attributes)) element.setAttribute(key, String(value));
  return element;
}

/// A label: text (never markup) with a dark halo, so it reads on bone and on background alike.
function label(x, y, text, className) {
  const element = svgElement('text', { x, y, class: className });
  element.textContent = text;
  return element;
}

/// A function from a point in package coordinates to { x, y } in the canvas's CSS pixels, or
/// null when it is behind the camera (or nearer than its near plane).
function projector(state) {
  const { camera, canvas } = state;
  camera.updateMatrixWorld();
  const width = canvas.clientWidth;
  const height = canvas.clientHeight;
  const v = new Vector3();
  return (p) => {
    v.fromArray(p).applyMatrix4(camera.matrixWorldInverse);
    if (!(v.z < -camera.near)) return null;
    v.applyMatrix4(camera.projectionMatrix);
    return { x: ((v.x + 1) / 2) * width, y: ((1 - v.y) / 2) * height };
  };
}

/// Draws measurement `m` (its labels from `describe(m)`: { segments: [text per segment], angle:
/// text or null }).
function drawMeasurement(group, m, project, describe) {
  const screen = m.points.map(project);
  const text = describe(m);
  for (let i = 0; i + 1 < screen.length; ++i) {
    const [s, t] = [screen[i], screen[i + 1]];
    if (!s || !t) continue;
    group.append(svgElement('line', { x1: s.x, y1: s.y, x2: t.x, y2: t.y, class: 'measure-line' }));
    if (!text.segments[i]) continue;
    // Beside the segment's middle; for an angle, on the side away from its other segment, so
    // the two lengths do not cover each other.
    const length = Math.hypot(t.x - s.x, t.y - s.y) || 1;
    const mid = { x: (s.x + t.x) / 2, y: (s.y + t.y) / 2 };
    const other = screen.length === 3 ? screen[i === 0 ? 2 : 0] : null;
    let nx = -(t.y - s.y) / length;
    let ny = (t.x - s.x) / length;
    if (other && nx * (other.x - mid.x) + ny * (other.y - mid.y) > 0) [nx, ny] = [-nx, -ny];
    const at = label(mid.x + nx * 12, mid.y + ny * 12 + 4, text.segments[i], 'measure-label');
    at.setAttribute('text-anchor', nx < 0 ? 'end' : 'start');
    group.append(at);
  }
  for (const s of screen) if (s) group.append(svgElement('circle', { cx: s.x, cy: s.y, r: 4, class: 'measure-point' }));
  if (text.angle && screen[1]) group.append(label(screen[1].x + 10, screen[1].y + 20, text.angle, 'measure-label angle'));
}

/// `text` in lines of at most `width` characters, broken at spaces where it can be; at most
/// `count` lines, the last ending in '…' where text is left out.
export function wrapText(text, width = kLineChars, count = kLines) {
  const lines = [];
  let rest = text.replace(/\s+/g, ' ').trim();
  while (rest && lines.length < count) {
    if (rest.length <= width) {
      lines.push(rest);
      rest = '';
      break;
    }
    const space = rest.lastIndexOf(' ', width);
    const cut = space > width / 3 ? space : width;
    lines.push(rest.slice(0, cut));
    rest = rest.slice(cut).trimStart();
  }
  if (rest) lines[lines.length - 1] = `${lines.at(-1).slice(0, width - 1)}…`;
  return lines;
}

/// Draws a note: its point, the leader and the label (wrapped, at most kLines lines), up and to
/// the right of the point, or to the left or below where the view's edge would cut it (its width
/// estimated from its length). The label's tooltip is the whole text.
function drawNote(group, note, project, size) {
  const s = project(note.p);
  if (!s) return;
  const lines = wrapText(note.text);
  const width = Math.max(...lines.map((l) => l.length)) * kCharPixels;
  const right = s.x + kNoteOffset.x + width <= size.width - 4;
  const left = !right && s.x - kNoteOffset.x - width >= 4;
  // Where it fits on neither side, it is moved in from the right edge.
  const x = left ? s.x - kNoteOffset.x : right ? s.x + kNoteOffset.x : Math.max(4, size.width - 7 - width);
  const above = s.y + kNoteOffset.y - (lines.length - 1) * kLineHeight >= 16;
  const y = above ? s.y + kNoteOffset.y - (lines.length - 1) * kLineHeight : s.y - kNoteOffset.y;
  // A note a surface hides from the camera (notes.mjs checkNotesDepth) is drawn faded.
  const behind = note.behind ? ' behind' : '';
  group.append(svgElement('line', { x1: s.x, y1: s.y, x2: x, y2: above ? y + 4 + (lines.length - 1) * kLineHeight : y - 12, class: `note-leader${behind}` }));
  group.append(svgElement('circle', { cx: s.x, cy: s.y, r: 4, class: `note-point${behind}` }));
  const text = svgElement('text', { x: left ? x - 3 : x + 3, y, class: `note-label${behind}` });
  if (left) text.setAttribute('text-anchor', 'end');
  const title = svgElement('title');
  title.textContent = note.text;  // text, never markup: notes come from links
  text.append(title);
  lines.forEach((line, i) => {
    const span = svgElement('tspan', { x: left ? x - 3 : x + 3, dy: i ? kLineHeight : 0 });
    span.textContent = line;
    text.append(span);
  });
  group.append(text);
}

/// Projects every measurement and note again with the camera as it is now. `describe`: the
/// measurement's labels (measure.mjs sets it, so this file needs no measuring of its own).
export function drawOverlay(state) {
  const a = state.annotations;
  if (!a?.svg) return;
  const project = projector(state);
  const measurements = svgElement('g', { class: 'measurements' });
  for (const m of a.measurements) drawMeasurement(measurements, m, project, a.describe);
  const notes = svgElement('g', { class: 'notes' });
  const size = { width: state.canvas.clientWidth, height: state.canvas.clientHeight };
  for (const note of a.notes) drawNote(notes, note, project, size);
  a.svg.replaceChildren(measurements, notes);
}

/// The tools bar's hint line (what a tap does now, or what just went wrong).
export function setHint(state, text) {
  annotations(state).hint = text;
  const hint = $(state, 'tool-hint');
  if (hint) hint.textContent = text;
}

const kToolHints = {
  measure: 'Tap two points for a distance, a third for the angle at the middle one. Enter: a new measurement; Esc: clear.',
  note: 'Tap the surface to pin a note.',
};

/// Switches tool `tool` ('measure', 'note' or null: none, taps select bones again) on.
export function setTool(state, tool) {
  const a = annotations(state);
  if (a.tool === tool) return;
  a.tool = tool;
  a.current = null;
  for (const [name, id] of [['measure', 'measure-tool'], ['note', 'note-tool']]) $(state, id)?.setAttribute('aria-pressed', String(tool === name));
  $(state, 'measure-clear')?.setAttribute('title', tool === 'note' ? 'Remove the notes' : 'Remove the measurements (Esc)');
  a.onToolChanged?.(tool);
  setHint(state, kToolHints[tool] ?? '');
}

/// Lays the SVG over the canvas and wires the tools bar's toggles (once).
export function wireOverlay(state) {
  const a = annotations(state);
  a.svg = svgElement('svg', { id: 'overlay', role: 'group', 'aria-label': 'Measurements and notes' });
  state.canvas.after(a.svg);
  for (const [tool, id] of [['measure', 'measure-tool'], ['note', 'note-tool']]) {
    $(state, id)?.addEventListener('click', () => setTool(state, a.tool === tool ? null : tool));
  }
}
