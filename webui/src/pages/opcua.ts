// opcua.ts -- the OPC UA page (docs/opcua.md): the OPC UA server's endpoint, security and sessions,
// a red warning while security None or anonymous sessions are on, and the client applications'
// certificates, trusted and rejected; an admin trusts, rejects or removes one, each confirmed first.
// Polled every 2 s (the server writes its status every few seconds; the lists are read from disk).
import "../ops/ops.css";
import { unwrap } from "../api/client";
import type { Page } from "../app/context";
import { errorText, h, poll, setClass, setText } from "../ops/dom";
import {
  certRow,
  confirmText,
  type OpcuaCertificate,
  type OpcuaState,
  opcuaNotice,
  opcuaRows,
  type TrustAction,
} from "../ops/opcua";

const REFRESH_MS = 2000;
const LABEL: Record<TrustAction, string> = { trust: "Trust", reject: "Reject", remove: "Remove" };

export const opcuaPage: Page = (root, ctx) => {
  const admin = ctx.can("admin");
  const notice = h("div", { class: "ops-banner", "data-testid": "opcua-notice", role: "alert", hidden: true });
  const error = h("div", { class: "ops-error", "data-testid": "opcua-error", hidden: true });
  const figures = h("table", { class: "ops-kv", "data-testid": "opcua-figures" });
  const confirm = h("div", { class: "ops-confirm", "data-testid": "opcua-confirm", hidden: true });
  const result = h("div", { class: "ops-sub", "data-testid": "opcua-result" });
  const lists = { trusted: h("tbody"), rejected: h("tbody") };
  const unreadable = h("div", { class: "ops-sub", "data-testid": "opcua-unreadable" });

  const table = (folder: "trusted" | "rejected", title: string) =>
    h(
      "section",
      { class: "panel ops-panel" },
      h("h3", {}, title),
      h(
        "div",
        { class: "ops-scroll wide" },
        h(
          "table",
          { class: "ops-grid ops-dense", "data-testid": `opcua-${folder}` },
          h(
            "thead",
            {},
            h(
              "tr",
              {},
              ...["application", "subject", "SHA-1 thumbprint", "valid", admin ? "" : null]
                .filter((t) => t !== null)
                .map((t) => h("th", {}, t as string)),
            ),
          ),
          lists[folder],
        ),
      ),
    );

  let busy = false;
  const act = (action: TrustAction, c: OpcuaCertificate) => {
    const yes = h("button", { class: "primary danger", "data-testid": "opcua-confirm-yes" }, LABEL[action]);
    const no = h("button", { "data-testid": "opcua-confirm-no" }, "Cancel");
    confirm.replaceChildren(h("span", {}, confirmText(action, c), " "), yes, " ", no);
    confirm.hidden = false;
    no.addEventListener("click", () => {
      confirm.hidden = true;
    });
    yes.addEventListener("click", async () => {
      yes.disabled = no.disabled = true;
      busy = true;
      try {
        const path = { params: { path: { thumbprint: c.sha256 } } };
        const done = unwrap(
          action === "remove"
            ? await ctx.api.DELETE("/api/v1/opcua/certificates/{thumbprint}", path)
            : await ctx.api.POST(`/api/v1/opcua/certificates/{thumbprint}/${action}`, path),
        );
        setText(result, `${c.subject}: ${done.detail}`);
        ctx.notify(`${c.application_uri ?? c.subject}: ${done.detail}`);
      } catch (e) {
        setText(result, `${LABEL[action]} ${c.subject}: ${errorText(e)}`);
        ctx.notify(errorText(e), "error");
      } finally {
        busy = false;
        confirm.hidden = true;
        p.now();
      }
    });
  };

  const rowOf = (c: OpcuaCertificate) => {
    const r = certRow(c);
    const cells = [
      h("td", { class: "mono" }, r.uri),
      h("td", {}, r.subject),
      h("td", { class: "mono" }, r.thumbprint),
      h("td", { class: r.valid ? "" : "bad" }, r.validity),
    ];
    if (admin)
      cells.push(
        h(
          "td",
          {},
          ...r.actions.map((a) => {
            const b = h("button", { "data-testid": `opcua-${a}-${r.thumbprint}` }, LABEL[a]);
            b.addEventListener("click", () => act(a, c));
            return b;
          }),
        ),
      );
    return h("tr", { "data-testid": `opcua-cert-${r.thumbprint}`, "data-folder": r.folder }, ...cells);
  };

  const show = (s: OpcuaState) => {
    const n = opcuaNotice(s);
    notice.hidden = !n.text;
    setClass(notice, `ops-banner ${n.level}`);
    setText(notice, n.text);
    figures.replaceChildren(...opcuaRows(s).map(([k, v]) => h("tr", {}, h("th", {}, k), h("td", {}, v))));
    if (busy) return; // the lists change under the confirmation only after it
    const none = (text: string) => h("tr", {}, h("td", { colspan: admin ? 5 : 4, class: "muted" }, text));
    lists.trusted.replaceChildren(...(s.trusted.length ? s.trusted.map(rowOf) : [none("none")]));
    lists.rejected.replaceChildren(
      ...(s.rejected.length ? s.rejected.map(rowOf) : [none("none: a client refused as untrusted shows here")]),
    );
    setText(unreadable, s.unreadable.length ? `not certificates, ignored: ${s.unreadable.join(", ")}` : "");
  };

  const p = poll(
    async () => {
      show(unwrap(await ctx.api.GET("/api/v1/opcua")) as OpcuaState);
      error.hidden = true;
    },
    REFRESH_MS,
    (e) => {
      error.hidden = false;
      setText(error, `${errorText(e)} — retrying; what is shown is stale`);
    },
  );
  root.append(
    h(
      "div",
      { class: "ops-page", "data-testid": "opcua-page" },
      h("section", { class: "panel ops-panel" }, h("h3", {}, "OPC UA server"), notice, error, figures),
      confirm,
      result,
      table("rejected", "Rejected client applications"),
      table("trusted", "Trusted client applications"),
      unreadable,
      admin
        ? ""
        : h("p", { class: "ops-sub" }, "An admin trusts, rejects or removes a client application's certificate."),
    ),
  );
  return () => p.stop();
};
