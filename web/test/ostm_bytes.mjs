// SPDX-License-Identifier: Apache-2.0
// The bytes of .ostm streams (docs/FORMAT.md, "Mesh stream"), for tests that corrupt them: the
// checksum, and the header counts of versions 7 and 8 (two varints after the flags byte).

/// CRC-32 (IEEE, reflected), the stream's trailer.
export function crc32(bytes) {
  let crc = ~0;
  for (const byte of bytes) {
    crc ^= byte;
    for (let k = 0; k < 8; ++k) crc = crc & 1 ? (crc >>> 1) ^ 0xedb88320 : crc >>> 1;
  }
  return ~crc >>> 0;
}

/// Sets the stream's trailing checksum over the bytes before it, in place; returns `bytes`.
export function withChecksum(bytes) {
  new DataView(bytes.buffer, bytes.byteOffset).setUint32(bytes.length - 4,
    crc32(bytes.subarray(0, bytes.length - 4)), true);
  return bytes;
}

/// Unsigned LEB128 bytes of `value` (a safe integer).
function varint(value) {
  const out = [];
  for (; value >= 0x80; value = Math.floor(value / 0x80)) out.push((value % 0x80) | 0x80);
  return [...out, value];
}

/// A version-7 or -8 stream's counts: { vertices, triangles, end } (end: the byte after them).
export function headerCounts(stream) {
  const counts = [];
  let at = 6;
  for (let k = 0; k < 2; ++k) {
    let value = 0;
    for (let shift = 1; ; shift *= 0x80) {
      const byte = stream[at++];
      value += (byte & 0x7f) * shift;
      if (!(byte & 0x80)) break;
    }
    counts.push(value);
  }
  return { vertices: counts[0], triangles: counts[1], end: at };
}

/// A copy of version-7 or -8 `stream` declaring `vertices` and `triangles`, its checksum set. With
/// `keepLength` it keeps the stream's length: what the longer varints add comes off the end of
/// the geometry section, which a decoder refusing the counts never reaches.
export function withCounts(stream, vertices, triangles, { keepLength = false } = {}) {
  const counts = [...varint(vertices), ...varint(triangles)];
  const { end } = headerCounts(stream);
  const grown = counts.length - (end - 6);
  const rest = stream.subarray(end, stream.length - (keepLength ? Math.max(0, grown) : 0));
  return withChecksum(Uint8Array.from([...stream.subarray(0, 6), ...counts, ...rest]));
}
