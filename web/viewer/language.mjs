// SPDX-License-Identifier: Apache-2.0
// The names the panel shows, in the language the person picked (the panel's language menu):
// a part's or a group's name in that language where the manifest gives one (docs/FORMAT.md,
// "Groups and languages"), else its display name, which is in the manifest's first language.
// No DOM here but Intl, so Node tests run it as is.

/// The language the display names are in: the manifest's first, 'und' when it lists none.
export function baseLanguage(manifest) {
  return manifest.languages[0] ?? 'und';
}

/// `names[language]` ({tag: name}), or `fallback` (the name in the manifest's first language).
function nameIn(names, fallback, language, manifest) {
  if (language === baseLanguage(manifest)) return fallback;
  return names[language] ?? fallback;
}

/// Part `part`'s name in `language`.
export function partName(manifest, part, language) {
  return nameIn(part.names, part.displayName, language, manifest);
}

/// Group `index`'s name in `language`.
export function groupName(manifest, index, language) {
  const group = manifest.groups[index];
  return nameIn(group.names, group.name, language, manifest);
}

/// The groups of group `index` and its ancestors, outermost first (indices).
export function groupPath(manifest, index) {
  const path = [];
  for (let g = index; g >= 0; g = manifest.groups[g].parent) path.push(g);
  return path.reverse();
}

/// Part `part`'s groups in `language`, joined by ' / ' (its group string when it has no path).
export function partGroupText(manifest, part, language) {
  if (part.path < 0) return part.group;
  return groupPath(manifest, part.path).map((g) => groupName(manifest, g, language)).join(' / ');
}

/// A language menu's label for `tag`: the language's own name for itself where the browser
/// knows it ("日本語", "English"), with the English name after it when that differs; the tag
/// itself where the browser knows neither; 'Default' for 'und'.
export function languageLabel(tag) {
  if (tag === 'und') return 'Default';
  const of = (locale) => {
    try {
      const name = new Intl.DisplayNames([locale], { type: 'language', fallback: 'none' }).of(tag);
      return name && name !== tag ? name : null;
    } catch {
      return null;
    }
  };
  const own = of(tag);
  const english = of('en');
  if (own && english && own !== english) return `${own} (${english})`;
  return own ?? english ?? tag;
}

/// The tag as an HTML lang attribute ('' for 'und': the language is not known).
export function langAttribute(tag) {
  return tag === 'und' ? '' : tag;
}
