// SPDX-License-Identifier: Apache-2.0
// Command-line options of the benchmark scripts: node:util's parseArgs (strict), and a --help text
// made from the same table.

import { parseArgs } from 'node:util';

/// Parses `argv` (default: this process's arguments) against `options`, node:util parseArgs's
/// option table with two more fields per option for the help text: `arg`, the value's name (a
/// string option's), and `help`, its description ('\n' continues it on another line). `usage`
/// is the help text's first line after "Usage: ", `about` an optional paragraph below it. Adds
/// -h / --help, which prints the help text and exits. Returns { values, positionals }; throws on
/// an unknown option, a missing value or, unless `positionals` is true, any positional argument.
export function parseCommandLine({ usage, about, options, positionals = false,
  argv = process.argv.slice(2) }) {
  const all = { ...options, help: { type: 'boolean', short: 'h', help: 'this text' } };
  let parsed;
  try {
    parsed = parseArgs({
      args: argv,
      options: Object.fromEntries(Object.entries(all).map(([name, { arg, help, ...o }]) => [name, o])),
      allowPositionals: positionals,
      strict: true,
    });
  } catch (e) {
    throw new Error(`${e.message.split('. ')[0]} (--help lists the options)`);
  }
  if (parsed.values.help) {
    process.stdout.write(helpText(usage, about, all));
    process.exit(0);
  }
  return { values: parsed.values, positionals: parsed.positionals };
}

function helpText(usage, about, options) {
  const lines = [`Usage: ${usage}`, ''];
  if (about) lines.push(about, '');
  for (const [name, o] of Object.entries(options)) {
    const flag = `${o.short ? `-${o.short}, ` : ''}--${name}${o.arg ? ` ${o.arg}` : ''}`;
    const [first, ...rest] = (o.help ?? '').split('\n');
    lines.push(`  ${flag.padEnd(19)} ${first}`, ...rest.map((l) => `${' '.repeat(22)}${l}`));
  }
  return `${lines.join('\n')}\n`;
}
