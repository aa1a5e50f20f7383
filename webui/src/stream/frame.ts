// frame.ts -- decodes the agent's binary sample frames (docs/trace-and-stream.md §4): columns of
// due times and one column of doubles per subscribed channel.
export const FRAME_MAGIC = 0x53505249; // the bytes "IRPS", little-endian
export const HEADER_BYTES = 32;

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

export function decodeFrame(buf: ArrayBuffer): Frame {
  if (buf.byteLength < HEADER_BYTES) throw new FrameError(`frame of ${buf.byteLength} bytes is shorter than its header`);
  const v = new DataView(buf);
  if (v.getUint32(0, true) !== FRAME_MAGIC) throw new FrameError("frame does not start with IRPS");
  const version = v.getUint16(4, true);
  const kind = v.getUint16(6, true);
  if (version !== 1 || kind !== 1) throw new FrameError(`frame version ${version} kind ${kind} is not 1/1`);
  const firstSeq = Number(v.getBigUint64(8, true));
  const count = v.getUint32(16, true);
  const channels = v.getUint32(20, true);
  const dropped = Number(v.getBigUint64(24, true));
  const need = HEADER_BYTES + 8 * count * (1 + channels);
  if (buf.byteLength !== need) throw new FrameError(`frame of ${buf.byteLength} bytes, ${need} expected`);
  const t = new Float64Array(count);
  const ts = new BigInt64Array(buf, HEADER_BYTES, count);
  for (let i = 0; i < count; i++) t[i] = Number(ts[i]);
  const columns: Float64Array[] = [];
  for (let c = 0; c < channels; c++) columns.push(new Float64Array(buf, HEADER_BYTES + 8 * count * (1 + c), count));
  return { firstSeq, count, channels, dropped, t, columns };
}
