// SPDX-License-Identifier: Apache-2.0
// The few statistics the benchmark scripts report. Every function leaves out the values that are
// not finite numbers (a run that failed, a metric that was not measured) and returns NaN when
// none is left.

const finite = (values) => values.filter((x) => Number.isFinite(x));

export const sum = (values) => finite(values).reduce((a, b) => a + b, 0);

export function mean(values) {
  const v = finite(values);
  return v.length ? sum(v) / v.length : NaN;
}

/// The middle value; the mean of the two middle ones for an even count.
export function median(values) {
  const v = finite(values).sort((a, b) => a - b);
  if (v.length === 0) return NaN;
  const m = v.length >> 1;
  return v.length % 2 ? v[m] : (v[m - 1] + v[m]) / 2;
}

/// Median, smallest and largest value and how many there are: what a benchmark reports of its runs.
export function spread(values) {
  const v = finite(values);
  return { median: median(v), min: Math.min(...v), max: Math.max(...v), n: v.length };
}
