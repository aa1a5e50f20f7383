// stream.test.ts -- the stream client against a fake WebSocket: one socket, the union of the
// listeners' paths, each listener given its own columns, the drop counter, reconnection.
import { describe, expect, it, vi } from "vitest";
import { type Samples, StreamClient } from "../../src/stream/stream";
import { buildFrame } from "./build-frame";
import { FakeSocket, useFakeSocket } from "./fake-socket";

const channels = (paths: string[]) => ({
  channels: paths.map((path, index) => ({ index, path, type: "double" })),
  decimation: 1,
  basic_period_ns: 1000000,
});

useFakeSocket();

describe("StreamClient", () => {
  it("asks for the union of the listeners' paths on one socket, every sample", () => {
    const c = new StreamClient("ws://x/api/v1/stream");
    c.subscribe(["a", "b"], () => {});
    expect(FakeSocket.all.length).toBe(1);
    const ws = FakeSocket.all[0];
    expect(ws.url).toBe("ws://x/api/v1/stream"); // the session cookie signs it in, no token in the URL
    ws.open();
    expect(ws.last).toEqual({ subscribe: ["a", "b"], decimation: 1, stats: true });
    const off = c.subscribe(["b", "c"], () => {});
    expect(FakeSocket.all.length).toBe(1);
    expect(ws.last.subscribe).toEqual(["a", "b", "c"]);
    off();
    expect(ws.last.subscribe).toEqual(["a", "b"]);
  });

  it("hands each listener the columns of its own paths, and keeps the agent's drop counter", () => {
    const c = new StreamClient("ws://x");
    const got1: Samples[] = [];
    const got2: Samples[] = [];
    c.subscribe(["a", "b"], (s) => got1.push(s));
    c.subscribe(["c", "a"], (s) => got2.push(s));
    const ws = FakeSocket.all[0];
    ws.open();
    ws.text(channels(["a", "b", "c"]));
    expect(c.status.basicPeriodNs).toBe(1000000);
    ws.binary(
      buildFrame(
        100,
        [1e9, 2e9],
        [
          [1, 2],
          [3, 4],
          [5, 6],
        ],
        7,
      ),
    );
    expect(got1.length).toBe(1);
    expect(got1[0].firstSeq).toBe(100);
    expect([...got1[0].t]).toEqual([1, 2]);
    expect([...got1[0].values.get("a")!]).toEqual([1, 2]);
    expect([...got1[0].values.get("b")!]).toEqual([3, 4]);
    expect(got1[0].values.has("c")).toBe(false);
    expect([...got2[0].values.get("c")!]).toEqual([5, 6]);
    expect([...got2[0].values.get("a")!]).toEqual([1, 2]);
    expect(got2[0].dropped).toBe(7);
    expect(c.status.dropped).toBe(7);
    ws.text({ stats: { stream: { dropped: 9 } } });
    expect(c.status.dropped).toBe(9);
  });

  it("counts the samples of a frame it cannot hand on as discarded", () => {
    const c = new StreamClient("ws://x");
    const got: Samples[] = [];
    c.subscribe(["a"], (s) => got.push(s));
    const ws = FakeSocket.all[0];
    ws.open();
    ws.text(channels(["a"]));
    ws.binary(
      buildFrame(
        1,
        [1, 2, 3],
        [
          [1, 2, 3],
          [4, 5, 6],
        ],
      ),
    ); // two channels: not this subscription
    const bad = buildFrame(4, [1, 2], [[1, 2]]);
    new DataView(bad).setUint8(0, 0);
    ws.binary(bad);
    expect(got.length).toBe(0);
    expect(c.status.discarded).toBe(5);
    expect(c.status.error).toMatch(/IRPS/);
  });

  it("reports a refused subscription", () => {
    const c = new StreamClient("ws://x");
    c.subscribe(["nope"], () => {});
    const ws = FakeSocket.all[0];
    ws.open();
    ws.text({ error: { code: "refused", message: "no variable 'nope'" } });
    expect(c.status.error).toBe("no variable 'nope'");
  });

  it("reconnects once after a drop, even if a page subscribes while it waits", () => {
    const c = new StreamClient("ws://x");
    c.subscribe(["a"], () => {});
    FakeSocket.all[0].open();
    FakeSocket.all[0].drop();
    expect(c.status.connected).toBe(false);
    c.subscribe(["b"], () => {}); // during the retry delay
    expect(FakeSocket.all.length).toBe(1);
    vi.advanceTimersByTime(1000);
    expect(FakeSocket.all.length).toBe(2);
    const ws = FakeSocket.all[1];
    ws.open();
    expect(ws.last.subscribe).toEqual(["a", "b"]);
    vi.advanceTimersByTime(5000);
    expect(FakeSocket.all.length).toBe(2);
  });

  it("does not reconnect once the session has ended, and says so", () => {
    const c = new StreamClient("ws://x");
    let signedOut = 0;
    c.onSignedOut = () => signedOut++;
    c.subscribe(["a"], () => {});
    FakeSocket.all[0].drop(4401);
    vi.advanceTimersByTime(5000);
    expect(FakeSocket.all.length).toBe(1);
    expect(c.status.error).toMatch(/4401/);
    expect(signedOut).toBe(1);
  });
});
