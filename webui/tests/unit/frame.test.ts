// frame.test.ts -- decoding the agent's binary sample frames (docs/trace-and-stream.md §4): the
// spec's vectors (protocol/stream/vectors.json, which the Python tests decode too), then frames
// built here.
import { describe, expect, it } from "vitest";
import vectors from "../../../protocol/stream/vectors.json";
import { decodeFrame, FRAME_MAGIC, FrameError } from "../../src/stream/frame";
import { FIELDS } from "../../src/stream/frame_spec";
import { buildFrame } from "./build-frame";

function bytes(hex: string): ArrayBuffer {
  const out = new Uint8Array(hex.length / 2);
  for (let i = 0; i < out.length; i++) out[i] = parseInt(hex.slice(2 * i, 2 * i + 2), 16);
  return out.buffer;
}

describe("the spec's vectors", () => {
  it.each(vectors.decode.map((v) => [v.name, v] as const))("decodes %s", (_name, v) => {
    const f = decodeFrame(bytes(v.hex));
    expect(f.firstSeq).toBe(v.frame.first_seq);
    expect(f.count).toBe(v.frame.count);
    expect(f.channels).toBe(v.frame.channels);
    expect(f.dropped).toBe(v.frame.dropped);
    expect([...f.t]).toEqual(v.frame.t_ns);
    expect(f.columns.map((c) => [...c])).toEqual(v.frame.columns);
  });

  it.each(vectors.refuse.map((v) => [v.name, v] as const))("refuses %s", (_name, v) => {
    expect(() => decodeFrame(bytes(v.hex))).toThrow(FrameError);
  });

  it("keeps the sign of a negative zero", () => {
    const v = vectors.decode.find((x) => x.frame.columns.some((c) => c.some((y) => Object.is(y, -0))));
    expect(v).toBeDefined();
    const f = decodeFrame(bytes(v!.hex));
    expect(f.columns.some((c) => [...c].some((y) => Object.is(y, -0)))).toBe(true);
  });
});

describe("decodeFrame", () => {
  it("reads the header, the due times and the columns", () => {
    const t = [123456789012345, 123456790012345, 123456791012345];
    const f = decodeFrame(
      buildFrame(
        4242,
        t,
        [
          [1.5, -2, 3],
          [0, 1e300, -0],
        ],
        17,
      ),
    );
    expect(new DataView(buildFrame(1, [], [])).getUint32(0, true)).toBe(FRAME_MAGIC);
    expect(f.firstSeq).toBe(4242);
    expect(f.count).toBe(3);
    expect(f.channels).toBe(2);
    expect(f.dropped).toBe(17);
    expect([...f.t]).toEqual(t);
    expect([...f.columns[0]]).toEqual([1.5, -2, 3]);
    expect([...f.columns[1]]).toEqual([0, 1e300, -0]);
  });

  it("takes an empty frame and a frame without channels", () => {
    expect(decodeFrame(buildFrame(1, [], [])).count).toBe(0);
    const f = decodeFrame(buildFrame(9, [1, 2], []));
    expect(f.columns).toEqual([]);
    expect([...f.t]).toEqual([1, 2]);
  });

  it("refuses a bad magic, a wrong version, a short buffer and a wrong length", () => {
    const bad = buildFrame(1, [1], [[1]]);
    new DataView(bad).setUint8(0, 0x58);
    expect(() => decodeFrame(bad)).toThrow(/IRPS/);
    const v2 = buildFrame(1, [1], [[1]]);
    new DataView(v2).setUint16(FIELDS.version.offset, 2, true);
    expect(() => decodeFrame(v2)).toThrow(FrameError);
    expect(() => decodeFrame(new ArrayBuffer(20))).toThrow(/shorter than its header/);
    const good = buildFrame(1, [1, 2], [[1, 2]]);
    expect(() => decodeFrame(good.slice(0, good.byteLength - 8))).toThrow(/expected/);
    const longer = new ArrayBuffer(good.byteLength + 8);
    new Uint8Array(longer).set(new Uint8Array(good));
    expect(() => decodeFrame(longer)).toThrow(FrameError);
  });
});
