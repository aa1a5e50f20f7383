// frame_spec.ts -- the stream frame's constants, GENERATED from protocol/stream/frame.json by
// protocol/stream/generate.py: do not edit; change the spec and run `python3 protocol/stream/generate.py`.
// The decoder that uses them: frame.ts.
export const FRAME_MAGIC_TEXT = "IRPS";
export const FRAME_MAGIC = 0x53505249; // those bytes as a little-endian u32
export const FRAME_VERSION = 1;
export const FRAME_KIND_SAMPLES = 1;
export const HEADER_BYTES = 32;
/** offset and type of each header field (little-endian) */
export const FIELDS = {
  magic: { offset: 0, type: "bytes" },
  version: { offset: 4, type: "u16" },
  kind: { offset: 6, type: "u16" },
  first_seq: { offset: 8, type: "u64" },
  count: { offset: 16, type: "u32" },
  channels: { offset: 20, type: "u32" },
  dropped: { offset: 24, type: "u64" },
} as const;
/** the body, in frame order: `count` values of `type`, `repeat` times (1 when null) */
export const BODY = [
  { name: "t_ns", type: "i64", count: "count", repeat: null },
  { name: "columns", type: "f64", count: "count", repeat: "channels" },
] as const;
