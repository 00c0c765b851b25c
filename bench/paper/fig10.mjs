// SPDX-License-Identifier: Apache-2.0
// Fig. 10 of Zhou, Jia & Su 2018 (the five segmentation measures of the Princeton benchmark
// against published methods), redone with osteon's segmentation on the benchmark models in
// ../shared/data.
//
//   node bench/paper/fig10.mjs [--quick] [--bench PATH]
//
// Runs bench/segmentation_bench (build-bench/segmentation_bench; --no-speed, and --no-cgal with
// --quick) with --json, which segments every model to K segments (the most common human segment
// count of the model) with osteon's segment() and, when built with CGAL, CGAL's shape diameter
// function segmentation, and scores each against every human segmentation of the model with
// osteon's evaluator. This script averages its per-model scores over the models (Cut Discrepancy
// over the models where it is defined, as the bench does) and sets the published values of
// bench/paper/published_psb.json beside them. Writes docs/paper/results/fig10.json.

import { existsSync, mkdtempSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import path from 'node:path';
import { dataDir, here, log, machine, readJson, resultsDir, root, run, writeJson } from './lib.mjs';
import { parseCommandLine } from '../lib/args.mjs';
import { mean, sum } from '../lib/stats.mjs';

const kMeasures = ['cd', 'hd', 'one_minus_ri', 'gce', 'lce'];

function summarize(rows) {
  const ok = rows.filter((r) => r.scores);
  const out = { models: ok.length, failed: rows.length - ok.length };
  for (const m of kMeasures) {
    const values = ok.map((r) => r.scores[m]).filter((v) => v != null);
    out[m] = values.length ? mean(values) : null;
    if (m === 'cd') out.cd_models = values.length;
  }
  const segments = ok.map((r) => r.segments).filter((v) => v != null);
  if (segments.length) out.segments = mean(segments);
  const targets = ok.map((r) => r.target).filter((v) => v != null);
  if (targets.length) out.target = mean(targets);
  const seconds = ok.map((r) => r.seconds).filter((v) => v != null);
  if (seconds.length) out.seconds = sum(seconds);
  return out;
}

function main() {
  const { values: args } = parseCommandLine({
    usage: 'node bench/paper/fig10.mjs [--quick] [--bench PATH]',
    about: 'Fig. 10: the Princeton benchmark\'s five measures, osteon against published methods;\n' +
      'writes docs/paper/results/fig10.json.',
    options: {
      quick: { type: 'boolean', help: 'no CGAL peer (segmentation_bench --no-cgal)' },
      bench: { type: 'string', arg: 'PATH', help: 'segmentation_bench (default build-bench/segmentation_bench)' },
    },
  });
  const bench = args.bench ?? path.join(root, 'build-bench', 'segmentation_bench');
  if (!existsSync(bench)) {
    throw new Error(`${bench} not built (cmake --build build-bench --target segmentation_bench)`);
  }
  const data = dataDir();
  const published = readJson(path.join(here, 'published_psb.json'));
  if (!data || !existsSync(path.join(data, 'cearto__zen__MeshsegBenchmark'))) {
    // The phantom has no human segmentations: there is nothing to score against.
    log('../shared/data (the Princeton benchmark subset) is absent: Fig. 10 cannot be measured');
    writeJson(path.join(resultsDir, 'fig10.json'), {
      item: 'Fig. 10', data: 'absent', machine: machine(), published,
      note: 'the Princeton benchmark models and their human segmentations are not in ' +
        '../shared/data; the phantom has no human segmentations to score against',
      rows: {},
    });
    return;
  }
  const work = mkdtempSync(path.join(tmpdir(), 'osteon-fig10-'));
  try {
    const json = path.join(work, 'scores.json');
    const flags = ['--no-speed', '--json', json, '--data', data];
    if (args.quick) flags.push('--no-cgal');
    log(`fig10: ${path.relative(root, bench)} ${flags.join(' ')} (${args.quick ? 'seconds'
      : 'a few minutes: CGAL SDF is slow'}) ...`);
    run(bench, flags);
    const perModel = readJson(json);
    const rows = {};
    for (const [name, list] of Object.entries(perModel)) rows[name] = summarize(list);
    const k = perModel.osteon?.map((r) => r.target).filter((v) => v != null) ?? [];
    writeJson(path.join(resultsDir, 'fig10.json'), {
      item: 'Fig. 10', quick: Boolean(args.quick), data: 'shared', machine: machine(),
      command: `build-bench/segmentation_bench --no-speed${args.quick ? ' --no-cgal' : ''
      } --json FILE`,
      models: Math.max(...Object.values(rows).map((r) => r.models)),
      mean_target_segments: k.length ? mean(k) : null,
      rows,
      per_model: perModel,
      published,
    });
    log('fig10: wrote docs/paper/results/fig10.json');
  } finally {
    rmSync(work, { recursive: true, force: true });
  }
}

try {
  main();
} catch (e) {
  process.stderr.write(`fig10: ${e?.message ?? e}\n`);
  process.exit(1);
}
