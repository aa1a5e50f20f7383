// opcua.test.ts -- the OPC UA page: the warning while None or anonymous sessions are on, what it says
// when the server is off or stale, the certificates' rows and the actions each offers, and in a DOM the
// lists with Trust / Reject / Remove for an admin (confirmed before anything is sent), none for a viewer.
import { describe, expect, it } from "vitest";
import type { AppContext } from "../../src/app/context";
import { certRow, type OpcuaCertificate, type OpcuaState, opcuaNotice, opcuaRows } from "../../src/ops/opcua";
import { opcuaPage } from "../../src/pages/opcua";

function cert(over: Partial<OpcuaCertificate> = {}): OpcuaCertificate {
  return {
    folder: "rejected",
    file: "uaexpert.der",
    subject: "CN=UaExpert@ws1",
    issuer: "CN=UaExpert@ws1",
    sha1: "a".repeat(40),
    sha256: "b".repeat(64),
    not_before: "2026-01-01T00:00:00+00:00",
    not_after: "2031-01-01T00:00:00+00:00",
    valid_now: true,
    application_uri: "urn:ws1:UnifiedAutomation:UaExpert",
    ca: false,
    ...over,
  };
}

function state(over: Partial<OpcuaState> = {}): OpcuaState {
  return {
    server: "ok",
    message: "",
    endpoint: "opc.tcp://0.0.0.0:4840/",
    application_uri: "urn:cell:indurop:opcua",
    pid: 4242,
    started: "2026-11-26T20:00:00Z",
    updated: "2026-11-26T20:10:00Z",
    age_s: 1.2,
    security: {
      policies: ["Basic256Sha256", "Aes128_Sha256_RsaOaep"],
      security_none: false,
      anonymous: false,
      warnings: [],
    },
    certificate: { sha1: "c".repeat(40), not_after: "2031-11-26T00:00:00+00:00" },
    irpd: true,
    layout_hash: "d".repeat(64),
    sessions: 2,
    subscriptions: 1,
    monitored_items: 16,
    refused: 1,
    trusted: [cert({ folder: "trusted", sha1: "1".repeat(40), sha256: "2".repeat(64), subject: "CN=mes" })],
    rejected: [cert()],
    unreadable: [],
    ...over,
  };
}

describe("opcuaNotice", () => {
  it("says nothing while the server runs securely", () => {
    expect(opcuaNotice(state())).toEqual({ level: "", text: "" });
  });
  it("warns in red while None or anonymous sessions are on", () => {
    const n = opcuaNotice(
      state({
        security: {
          policies: ["None"],
          security_none: true,
          anonymous: true,
          warnings: ["security policy None is offered", "anonymous sessions are allowed (role viewer)"],
        },
      }),
    );
    expect(n.level).toBe("bad");
    expect(n.text).toContain("Insecure: security policy None is offered; anonymous sessions are allowed (role viewer)");
    expect(n.text).toContain("opc.tcp://0.0.0.0:4840/");
  });
  it("says why when the server is off or stale", () => {
    expect(opcuaNotice(state({ server: "off", message: "the OPC UA server has not run" }))).toEqual({
      level: "warn",
      text: "The OPC UA server has not run",
    });
    expect(opcuaNotice(state({ server: "stale", message: "it stopped" })).level).toBe("bad");
  });
});

describe("opcuaRows and certRow", () => {
  it("the figures in words", () => {
    const rows = Object.fromEntries(opcuaRows(state()));
    expect(rows.endpoint).toBe("opc.tcp://0.0.0.0:4840/");
    expect(rows.security).toBe("Basic256Sha256, Aes128_Sha256_RsaOaep (Sign, SignAndEncrypt) · anonymous refused");
    expect(rows.sessions).toBe("2 · 1 subscriptions · 16 monitored items");
    expect(opcuaRows(state({ server: "off" }))).toEqual([["server", "off"]]);
  });
  it("a rejected certificate may be trusted or removed, a trusted one rejected or removed", () => {
    expect(certRow(cert()).actions).toEqual(["trust", "remove"]);
    expect(certRow(cert({ folder: "trusted" })).actions).toEqual(["reject", "remove"]);
    const expired = certRow(cert({ valid_now: false, ca: true }));
    expect(expired.validity).toBe("2026-01-01 – 2031-01-01 (not valid now) · CA");
    expect(expired.valid).toBe(false);
  });
});

const flush = async () => {
  for (let i = 0; i < 10; i++) await Promise.resolve();
};

function mount(admin: boolean, s: OpcuaState = state()) {
  const calls: { method: string; path: string; opts: Record<string, unknown> }[] = [];
  const answer =
    (method: string) =>
    async (path: string, opts: Record<string, unknown> = {}) => {
      calls.push({ method, path, opts });
      const data = method === "GET" ? s : { action: "trust", changed: true, detail: "moved to trusted/uaexpert.der" };
      return { data, response: new Response(null, { status: 200 }) };
    };
  const ctx = {
    api: { GET: answer("GET"), POST: answer("POST"), DELETE: answer("DELETE") },
    can: (role: string) => admin || role === "viewer",
    notify: () => {},
  } as unknown as AppContext;
  const root = document.createElement("div");
  const stop = opcuaPage(root, ctx);
  return { root, calls, stop };
}
const q = (root: HTMLElement, testid: string) => root.querySelector<HTMLElement>(`[data-testid="${testid}"]`);

describe("the OPC UA page", () => {
  it("lists both folders; an admin's Trust is confirmed, then sent by SHA-256", async () => {
    const { root, calls, stop } = mount(true);
    await flush();
    expect(q(root, `opcua-cert-${"a".repeat(40)}`)?.dataset.folder).toBe("rejected");
    expect(q(root, `opcua-cert-${"1".repeat(40)}`)?.dataset.folder).toBe("trusted");
    expect(q(root, "opcua-notice")?.hidden).toBe(true);
    q(root, `opcua-trust-${"a".repeat(40)}`)?.click();
    expect(calls.filter((c) => c.method === "POST")).toEqual([]); // asked first
    expect(q(root, "opcua-confirm")?.textContent).toContain("Trust urn:ws1:UnifiedAutomation:UaExpert?");
    q(root, "opcua-confirm-yes")?.click();
    await flush();
    const post = calls.find((c) => c.method === "POST");
    expect(post?.path).toBe("/api/v1/opcua/certificates/{thumbprint}/trust");
    expect(post?.opts).toEqual({ params: { path: { thumbprint: "b".repeat(64) } } });
    expect(q(root, "opcua-result")?.textContent).toBe("CN=UaExpert@ws1: moved to trusted/uaexpert.der");
    q(root, `opcua-remove-${"1".repeat(40)}`)?.click();
    q(root, "opcua-confirm-yes")?.click();
    await flush();
    expect(calls.find((c) => c.method === "DELETE")?.path).toBe("/api/v1/opcua/certificates/{thumbprint}");
    stop();
  });

  it("shows a viewer the lists without buttons, and the insecure warning prominently", async () => {
    const insecure = state({
      security: {
        policies: ["None"],
        security_none: true,
        anonymous: true,
        warnings: ["anonymous sessions are allowed"],
      },
    });
    const { root, stop } = mount(false, insecure);
    await flush();
    expect(q(root, `opcua-cert-${"a".repeat(40)}`)).not.toBeNull();
    expect(root.querySelector("button")).toBeNull();
    const notice = q(root, "opcua-notice")!;
    expect(notice.hidden).toBe(false);
    expect(notice.className).toBe("ops-banner bad");
    expect(notice.textContent).toContain("Insecure: anonymous sessions are allowed");
    stop();
  });
});
