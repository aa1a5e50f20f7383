// build-frame.ts -- sample frames built for the tests from the spec's field table (frame_spec.ts,
// generated from protocol/stream/frame.json), independently of the decoder.
import { FIELDS, FRAME_KIND_SAMPLES, FRAME_MAGIC, FRAME_VERSION, HEADER_BYTES } from "../../src/stream/frame_spec";

/** A frame built field by field: the header, then the due times, then the columns. */
export function buildFrame(firstSeq: number, t: number[], columns: number[][], dropped = 0): ArrayBuffer {
  const count = t.length;
  const buf = new ArrayBuffer(HEADER_BYTES + 8 * count * (1 + columns.length));
  const v = new DataView(buf);
  v.setUint32(FIELDS.magic.offset, FRAME_MAGIC, true);
  v.setUint16(FIELDS.version.offset, FRAME_VERSION, true);
  v.setUint16(FIELDS.kind.offset, FRAME_KIND_SAMPLES, true);
  v.setBigUint64(FIELDS.first_seq.offset, BigInt(firstSeq), true);
  v.setUint32(FIELDS.count.offset, count, true);
  v.setUint32(FIELDS.channels.offset, columns.length, true);
  v.setBigUint64(FIELDS.dropped.offset, BigInt(dropped), true);
  t.forEach((x, k) => {
    v.setBigInt64(HEADER_BYTES + 8 * k, BigInt(x), true);
  });
  columns.forEach((col, c) => {
    col.forEach((x, k) => {
      v.setFloat64(HEADER_BYTES + 8 * count * (1 + c) + 8 * k, x, true);
    });
  });
  return buf;
}
