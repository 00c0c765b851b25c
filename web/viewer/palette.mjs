// SPDX-License-Identifier: Apache-2.0
// Colour by region or by body system (the panel's "Colour by" menu): each part gets the colour of
// its class, from a fixed qualitative palette that people with the common colour-vision
// deficiencies still tell apart, and the legend lists the classes. No DOM here, so Node tests run
// it as is.
//
// Based on: Okabe & Ito 2008, "Color Universal Design" (the first seven colours, without black,
// which vanishes on the view's dark background); Tableau 10 (the next five).

import { baseLanguage, groupName, groupPath } from './language.mjs';

/// sRGB colours, 0..255.
export const kPalette = [
  [230, 159, 0],    // orange
  [86, 180, 233],   // sky blue
  [0, 158, 115],    // bluish green
  [240, 228, 66],   // yellow
  [0, 114, 178],    // blue
  [213, 94, 0],     // vermillion
  [204, 121, 167],  // reddish purple
  [255, 157, 167],  // pink
  [156, 117, 95],   // brown
  [186, 176, 172],  // grey
  [118, 183, 178],  // teal
  [89, 161, 79],    // green
];

/// The colour parts of no class (no region, no system) get: a neutral bone.
export const kNoClassColor = [200, 196, 186];

/// The depth (1 the roots) at which the parts' region paths first differ: the depth whose groups
/// tell the regions apart (BodyParts3D: every path starts at Skeleton, so 2: Skull, Vertebral
/// column, Thorax, ...). With one path only, that path's deepest group's depth.
function regionDepth(manifest) {
  const paths = [];
  const seen = new Set();
  for (const part of manifest.parts) {
    if (part.path >= 0 && !seen.has(part.path)) {
      seen.add(part.path);
      paths.push(groupPath(manifest, part.path));
    }
  }
  if (!paths.length) return 0;
  const longest = Math.max(...paths.map((p) => p.length));
  for (let d = 0; d < longest; ++d) {
    const at = paths[0][d] ?? -1;
    if (paths.some((p) => (p[d] ?? -1) !== at)) return d + 1;
  }
  return longest;
}

/// The classes for colouring by `mode` ('region' or 'system'): { classOf (an Int32Array, a class
/// index per part, -1 for none), classes ([{ key, label(language) }], by their names in the
/// manifest's first language, as the region tree lists them) }.
export function classify(manifest, mode) {
  const classOf = new Int32Array(manifest.parts.length).fill(-1);
  let classes = [];
  const index = new Map();
  const add = (key, label) => {
    if (!index.has(key)) {
      index.set(key, classes.length);
      classes.push({ key, label, sortName: label(baseLanguage(manifest)) });
    }
    return index.get(key);
  };
  if (mode === 'region') {
    const depth = regionDepth(manifest);
    for (const part of manifest.parts) {
      if (part.path < 0) continue;
      const path = groupPath(manifest, part.path);
      const g = path[Math.min(depth, path.length) - 1];
      classOf[part.id] = add(`g${g}`, (language) => groupName(manifest, g, language));
    }
  } else if (mode === 'system') {
    for (const part of manifest.parts) {
      if (part.system) classOf[part.id] = add(part.system, () => part.system);
    }
  }
  const collator = new Intl.Collator('en', { numeric: true });
  const order = classes.map((_, k) => k).sort((a, b) => collator.compare(classes[a].sortName, classes[b].sortName));
  const rank = new Int32Array(classes.length);
  order.forEach((k, r) => { rank[k] = r; });
  for (let i = 0; i < classOf.length; ++i) if (classOf[i] >= 0) classOf[i] = rank[classOf[i]];
  classes = order.map((k) => ({ key: classes[k].key, label: classes[k].label }));
  return { classOf, classes };
}

/// The parts' colours and the legend for colouring by `mode`: { colors (Float32Array, 3 per part,
/// sRGB 0..1, as the manifest's colours), legend ([{ color (0..255), label(language) }]) }, or
/// null for 'part' (each part its own colour).
export function colorBy(manifest, mode) {
  if (mode !== 'region' && mode !== 'system') return null;
  const { classOf, classes } = classify(manifest, mode);
  const colors = new Float32Array(3 * manifest.parts.length);
  const colorOf = (k) => (k < 0 ? kNoClassColor : kPalette[k % kPalette.length]);
  for (let i = 0; i < manifest.parts.length; ++i) {
    const c = colorOf(classOf[i]);
    for (let j = 0; j < 3; ++j) colors[3 * i + j] = c[j] / 255;
  }
  const legend = classes.map((c, k) => ({ color: colorOf(k), label: c.label }));
  if (classOf.includes(-1)) {
    legend.push({ color: kNoClassColor, label: () => (mode === 'region' ? '(no region)' : '(no system)') });
  }
  return { colors, legend };
}
