// SPDX-License-Identifier: Apache-2.0
// Writes a benchmark's own section of a Markdown file (docs/BENCHMARKS.md): the text between its
// begin and end markers is replaced, or, the first time, the heading and the marked section are
// appended. Written to a temporary file, then renamed: no half-written file.

import { readFileSync, renameSync, writeFileSync } from 'node:fs';

export function writeSection(file, { heading, begin, end, body, tag }) {
  const text = readFileSync(file, 'utf8');
  const from = text.indexOf(begin);
  const to = text.indexOf(end);
  const next = from >= 0 && to > from
    ? `${text.slice(0, from + begin.length)}\n${body}\n${text.slice(to)}`
    : `${text.replace(/\n*$/, '\n')}\n${heading}\n\n${begin}\n${body}\n${end}\n`;
  const temporary = `${file}.${tag}.tmp`;
  writeFileSync(temporary, next);
  renameSync(temporary, file);
  console.log(`osteon: wrote the section between its markers in ${file}`);
}
