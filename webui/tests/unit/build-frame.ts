// build-frame.ts -- sample frames built by hand for the tests, as the agent packs them.
import { HEADER_BYTES } from "../../src/stream/frame";

/** A frame built field by field, as the agent packs it ("<4sHHQIIQ", then t, then the columns). */
export function buildFrame(firstSeq: number, t: number[], columns: number[][], dropped = 0): ArrayBuffer {
  const count = t.length;
  const buf = new ArrayBuffer(HEADER_BYTES + 8 * count * (1 + columns.length));
  const v = new DataView(buf);
  new Uint8Array(buf, 0, 4).set([0x49, 0x52, 0x50, 0x53]); // "IRPS"
  v.setUint16(4, 1, true);
  v.setUint16(6, 1, true);
  v.setBigUint64(8, BigInt(firstSeq), true);
  v.setUint32(16, count, true);
  v.setUint32(20, columns.length, true);
  v.setBigUint64(24, BigInt(dropped), true);
  t.forEach((x, k) => v.setBigInt64(HEADER_BYTES + 8 * k, BigInt(x), true));
  columns.forEach((col, c) => col.forEach((x, k) => v.setFloat64(HEADER_BYTES + 8 * count * (1 + c) + 8 * k, x, true)));
  return buf;
}
