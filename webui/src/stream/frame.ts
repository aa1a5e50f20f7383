// frame.ts -- decodes the agent's binary sample frames (protocol/stream/frame.json, described in
// docs/trace-and-stream.md §4): columns of due times and one column of doubles per subscribed
// channel.  The header's offsets and constants come from frame_spec.ts, generated from the spec;
// tests/unit/frame.test.ts decodes the spec's vectors (protocol/stream/vectors.json).
import {
  BODY,
  FIELDS,
  FRAME_KIND_SAMPLES,
  FRAME_MAGIC,
  FRAME_MAGIC_TEXT,
  FRAME_VERSION,
  HEADER_BYTES,
} from "./frame_spec";

// The body this decoder reads: a spec that lays it out otherwise stops the build or the import.
if (BODY.length !== 2 || BODY[0].type !== "i64" || BODY[1].type !== "f64" || BODY[1].repeat !== "channels")
  throw new Error("protocol/stream/frame.json lays the frame's body out otherwise than frame.ts decodes it");

export { FRAME_MAGIC, HEADER_BYTES };

export interface Frame {
  firstSeq: number;
  count: number;
  channels: number;
  dropped: number;
  /** due times, ns since an arbitrary origin (CLOCK_MONOTONIC), as float64 */
  t: Float64Array;
  /** one column per channel, in the order of the last `channels` message */
  columns: Float64Array[];
}

export class FrameError extends Error {}

type Field = (typeof FIELDS)[keyof typeof FIELDS];

/** A numeric header field, little-endian (u64 as a number: exact up to 2^53). */
function read(v: DataView, f: Field): number {
  switch (f.type) {
    case "u16":
      return v.getUint16(f.offset, true);
    case "u32":
      return v.getUint32(f.offset, true);
    case "u64":
      return Number(v.getBigUint64(f.offset, true));
    case "bytes":
      return v.getUint32(f.offset, true); // the magic's four bytes, as FRAME_MAGIC spells them
  }
}

export function decodeFrame(buf: ArrayBuffer): Frame {
  if (buf.byteLength < HEADER_BYTES)
    throw new FrameError(`frame of ${buf.byteLength} bytes is shorter than its header`);
  const v = new DataView(buf);
  if (read(v, FIELDS.magic) !== FRAME_MAGIC) throw new FrameError(`frame does not start with ${FRAME_MAGIC_TEXT}`);
  const version = read(v, FIELDS.version);
  const kind = read(v, FIELDS.kind);
  if (version !== FRAME_VERSION || kind !== FRAME_KIND_SAMPLES)
    throw new FrameError(`frame version ${version} kind ${kind} is not ${FRAME_VERSION}/${FRAME_KIND_SAMPLES}`);
  const firstSeq = read(v, FIELDS.first_seq);
  const count = read(v, FIELDS.count);
  const channels = read(v, FIELDS.channels);
  const dropped = read(v, FIELDS.dropped);
  // The body (BODY in frame_spec.ts): count i64 due times, then count f64 per channel.
  const need = HEADER_BYTES + 8 * count * (1 + channels);
  if (buf.byteLength !== need) throw new FrameError(`frame of ${buf.byteLength} bytes, ${need} expected`);
  const t = new Float64Array(count);
  const ts = new BigInt64Array(buf, HEADER_BYTES, count);
  for (let i = 0; i < count; i++) t[i] = Number(ts[i]);
  const columns: Float64Array[] = [];
  for (let c = 0; c < channels; c++) columns.push(new Float64Array(buf, HEADER_BYTES + 8 * count * (1 + c), count));
  return { firstSeq, count, channels, dropped, t, columns };
}
