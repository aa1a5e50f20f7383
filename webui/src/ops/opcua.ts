// opcua.ts -- the OPC UA page's logic: GET /opcua as the server's state in words (endpoint, security,
// sessions), the warning when None or anonymous sessions are on, and the client certificates as
// rows with what an admin may do to each (trust a rejected one, reject a trusted one, remove either).
import type { components } from "../api/schema";

type S = components["schemas"];
export type OpcuaState = S["OpcuaState"];
export type OpcuaCertificate = S["OpcuaCertificate"];
export type TrustAction = "trust" | "reject" | "remove";

/** The banner above the page: the insecure warning first (red), else why the server is not ok. */
export function opcuaNotice(s: OpcuaState): { level: "" | "warn" | "bad"; text: string } {
  const warnings = s.security?.warnings ?? [];
  if (warnings.length && s.server !== "off")
    return {
      level: "bad",
      text: `Insecure: ${warnings.join("; ")}. Anyone who reaches ${s.endpoint ?? "the server"} gets in without a password or unencrypted; turn it off in the server's settings unless this network is closed.`,
    };
  if (s.server === "ok") return { level: "", text: "" };
  const text = s.message ? s.message[0].toUpperCase() + s.message.slice(1) : `The OPC UA server is ${s.server}.`;
  return { level: s.server === "off" ? "warn" : "bad", text };
}

/** The server's figures as label/value pairs for a key-value table. */
export function opcuaRows(s: OpcuaState): [string, string][] {
  if (s.server === "off" || s.server === "unreadable") return [["server", s.server]];
  const sec = s.security;
  const anonymous = sec?.anonymous ? "allowed" : "refused";
  return [
    [
      "server",
      s.server === "ok" ? `running · pid ${s.pid ?? "?"}` : `${s.server} (last status ${s.age_s ?? "?"} s ago)`,
    ],
    ["endpoint", s.endpoint ?? "–"],
    ["security", sec ? `${sec.policies.join(", ")} (Sign, SignAndEncrypt) · anonymous ${anonymous}` : "–"],
    ["irpd", s.irpd ? "reachable" : "unreachable"],
    [
      "sessions",
      `${s.sessions ?? 0} · ${s.subscriptions ?? 0} subscriptions · ${s.monitored_items ?? 0} monitored items`,
    ],
    ["refused", `${s.refused ?? 0} client certificate(s) since the server started`],
    [
      "certificate",
      s.certificate?.sha1 ? `SHA-1 ${s.certificate.sha1} · until ${(s.certificate.not_after ?? "").slice(0, 10)}` : "–",
    ],
  ];
}

export interface CertRow {
  key: string;
  folder: OpcuaCertificate["folder"];
  subject: string;
  uri: string;
  thumbprint: string;
  validity: string;
  valid: boolean;
  /** what an admin may do to it, in the order the buttons show */
  actions: TrustAction[];
}

export function certRow(c: OpcuaCertificate): CertRow {
  return {
    key: c.sha256,
    folder: c.folder,
    subject: c.subject,
    uri: c.application_uri ?? "–",
    thumbprint: c.sha1,
    validity: `${c.not_before.slice(0, 10)} – ${c.not_after.slice(0, 10)}${c.valid_now ? "" : " (not valid now)"}${c.ca ? " · CA" : ""}`,
    valid: c.valid_now,
    actions: c.folder === "trusted" ? ["reject", "remove"] : ["trust", "remove"],
  };
}

/** The question a button asks before it acts. */
export function confirmText(action: TrustAction, c: OpcuaCertificate): string {
  const who = c.application_uri ?? c.subject;
  if (action === "trust") return `Trust ${who}? Its next session is let in (with a user's name and password).`;
  if (action === "reject") return `Reject ${who}? Its new sessions are refused; open ones go on until they close.`;
  return `Remove ${who} from the trust list? It is refused, and comes back to Rejected at its next try.`;
}
