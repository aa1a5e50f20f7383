// users.ts -- the Users page (admin): every user with role, state, last sign-in, password age,
// tokens and sessions; add a user, change a role, disable (their tokens are revoked, their sessions
// end) or enable one, reset a password, list and revoke a user's tokens.  The agent audits each
// change with who made it (docs/administration.md).
import "../ops/ops.css";
import { unwrap } from "../api/client";
import type { components } from "../api/schema";
import type { Page, Role } from "../app/context";
import { errorText, h, setText } from "../ops/dom";

type User = components["schemas"]["UserPublic"];
type Token = components["schemas"]["TokenInfo"];

const ROLES: Role[] = ["viewer", "operator", "admin"];

function when(iso: string | null | undefined): string {
  return iso ? iso.replace("T", " ").replace(/\.\d+Z$|Z$/, " UTC") : "never";
}

function roleSelect(value: Role, testid: string): HTMLSelectElement {
  const s = h("select", { "data-testid": testid }, ...ROLES.map((r) => h("option", { value: r }, r)));
  s.value = value;
  return s;
}

export const usersPage: Page = (root, ctx) => {
  const api = ctx.api;
  const error = h("div", { class: "ops-error", "data-testid": "users-error", hidden: true });
  const info = h("span", { class: "ops-sub", "data-testid": "users-info" });
  const body = h("tbody", {});
  const table = h(
    "table",
    { class: "ops-table", "data-testid": "users-table" },
    h(
      "thead",
      {},
      h(
        "tr",
        {},
        ...["Name", "Role", "State", "Last sign-in", "Password changed", "Tokens", "Sessions", ""].map((t) =>
          h("th", {}, t),
        ),
      ),
    ),
    body,
  );

  // ---- add a user ---------------------------------------------------------------------------------
  const addName = h("input", { autocomplete: "off", autocapitalize: "off", "data-testid": "add-name", required: true });
  const addRole = roleSelect("operator", "add-role");
  const addPassword = h("input", {
    type: "password",
    autocomplete: "new-password",
    "data-testid": "add-password",
    required: true,
  });
  const addAgain = h("input", {
    type: "password",
    autocomplete: "new-password",
    "data-testid": "add-again",
    required: true,
  });
  const addForm = h(
    "form",
    { class: "ops-actions" },
    h("label", {}, "name ", addName),
    h("label", {}, "role ", addRole),
    h("label", {}, "password ", addPassword),
    h("label", {}, "again ", addAgain),
    h("button", { type: "submit", "data-testid": "add-user" }, "Add"),
  );

  // ---- reset a password -----------------------------------------------------------------------------
  let resetting: string | null = null;
  const resetTitle = h("span", { "data-testid": "reset-title" });
  const resetPassword = h("input", {
    type: "password",
    autocomplete: "new-password",
    "data-testid": "reset-password",
    required: true,
  });
  const resetAgain = h("input", {
    type: "password",
    autocomplete: "new-password",
    "data-testid": "reset-again",
    required: true,
  });
  const resetCancel = h("button", { type: "button", "data-testid": "reset-cancel" }, "Cancel");
  const resetForm = h(
    "form",
    { class: "ops-actions" },
    resetTitle,
    h("label", {}, "new password ", resetPassword),
    h("label", {}, "again ", resetAgain),
    h("button", { type: "submit", "data-testid": "reset-save" }, "Set"),
    resetCancel,
  );
  const resetPanel = h(
    "section",
    { class: "panel ops-panel", hidden: true, "data-testid": "reset-panel" },
    h("h3", {}, "Reset a password", h("span", { class: "ops-sub" }, " — the user's sessions end")),
    resetForm,
  );

  // ---- a user's tokens --------------------------------------------------------------------------------
  const tokensTitle = h("h3", {}, "Tokens");
  const tokensList = h("div", { "data-testid": "tokens-list" });
  const tokensPanel = h(
    "section",
    { class: "panel ops-panel", hidden: true, "data-testid": "tokens-panel" },
    tokensTitle,
    tokensList,
  );

  root.append(
    h(
      "div",
      { class: "ops-page", "data-testid": "users-page" },
      error,
      h("section", { class: "panel ops-panel" }, h("h3", {}, "Users", info), table),
      resetPanel,
      tokensPanel,
      h("section", { class: "panel ops-panel" }, h("h3", {}, "Add a user"), addForm),
    ),
  );

  const fail = (e: unknown) => {
    error.hidden = false;
    setText(error, errorText(e));
  };
  const done = (message: string) => {
    error.hidden = true;
    ctx.notify(message);
  };

  async function change(name: string, body: { role?: Role; disabled?: boolean }, what: string): Promise<void> {
    try {
      unwrap(await api.PATCH("/api/v1/users/{name}", { params: { path: { name } }, body }));
      done(`${name}: ${what}`);
    } catch (e) {
      fail(e);
    }
    await load();
  }

  async function showTokens(name: string): Promise<void> {
    try {
      const tokens = unwrap(await api.GET("/api/v1/users/{name}/tokens", { params: { path: { name } } })) as Token[];
      tokensPanel.hidden = false;
      setText(tokensTitle, `Tokens of ${name}`);
      tokensList.replaceChildren(
        tokens.length
          ? h(
              "table",
              { class: "ops-table" },
              h("tr", {}, ...["Id", "Name", "Role", "Created", ""].map((t) => h("th", {}, t))),
              ...tokens.map((t) =>
                h(
                  "tr",
                  { "data-testid": `token-${t.id}` },
                  h("td", { class: "mono" }, t.id),
                  h("td", {}, t.name),
                  h("td", {}, t.role),
                  h("td", {}, when(t.created)),
                  h(
                    "td",
                    {},
                    h(
                      "button",
                      {
                        class: "small",
                        "data-testid": `revoke-${t.id}`,
                        onclick: async () => {
                          try {
                            unwrap(
                              await api.DELETE("/api/v1/tokens/{token_id}", { params: { path: { token_id: t.id } } }),
                            );
                            done(`token ${t.name} of ${name} revoked`);
                          } catch (e) {
                            fail(e);
                          }
                          await showTokens(name);
                          await load();
                        },
                      },
                      "Revoke",
                    ),
                  ),
                ),
              ),
            )
          : h("p", { class: "ops-sub" }, `${name} has no tokens (an admin makes one with POST /api/v1/tokens).`),
      );
    } catch (e) {
      fail(e);
    }
  }

  function row(u: User): HTMLTableRowElement {
    const role = roleSelect(u.role as Role, `role-${u.name}`);
    role.addEventListener("change", () => void change(u.name, { role: role.value as Role }, `role ${role.value}`));
    const toggle = h(
      "button",
      { class: "small", "data-testid": `toggle-${u.name}` },
      u.disabled ? "Enable" : "Disable",
    );
    toggle.addEventListener("click", () => {
      if (u.disabled) return void change(u.name, { disabled: false }, "enabled");
      if (confirm(`Disable ${u.name}? Their ${u.tokens} token(s) are revoked and their sessions end.`))
        void change(u.name, { disabled: true }, "disabled");
    });
    const reset = h("button", { class: "small", "data-testid": `reset-${u.name}` }, "Reset password");
    reset.addEventListener("click", () => {
      resetting = u.name;
      setText(resetTitle, `${u.name}: `);
      resetPanel.hidden = false;
      resetPassword.focus();
    });
    const tokens = h("button", { class: "link", "data-testid": `tokens-${u.name}` }, String(u.tokens));
    tokens.addEventListener("click", () => void showTokens(u.name));
    return h(
      "tr",
      { "data-testid": `user-row-${u.name}`, class: u.disabled ? "muted" : "" },
      h("td", {}, u.name, u.name === ctx.session.name ? h("span", { class: "ops-sub" }, " (you)") : null),
      h("td", {}, role),
      h(
        "td",
        { "data-testid": `state-${u.name}`, class: u.disabled ? "bad" : "good" },
        u.disabled ? "disabled" : "enabled",
      ),
      h("td", { "data-testid": `last-sign-in-${u.name}` }, when(u.last_sign_in)),
      h("td", {}, when(u.password_changed)),
      h("td", { class: "num" }, tokens),
      h("td", { class: "num" }, String(u.sessions)),
      h("td", { class: "nowrap" }, toggle, " ", u.name === ctx.session.name ? null : reset),
    );
  }

  async function load(): Promise<void> {
    try {
      const users = unwrap(await api.GET("/api/v1/users")) as User[];
      body.replaceChildren(...users.map(row));
      setText(
        info,
        ` — ${users.length} user${users.length === 1 ? "" : "s"}, ${users.filter((u) => u.disabled).length} disabled`,
      );
    } catch (e) {
      fail(e);
    }
  }

  addForm.addEventListener("submit", async (ev) => {
    ev.preventDefault();
    if (addPassword.value !== addAgain.value) return fail("the two passwords differ");
    try {
      const user = { name: addName.value.trim(), role: addRole.value as Role, password: addPassword.value };
      unwrap(await api.POST("/api/v1/users", { body: user }));
      done(`user ${user.name} added (${user.role})`);
      addForm.reset();
      addRole.value = "operator";
    } catch (e) {
      fail(e);
    }
    await load();
  });
  resetCancel.addEventListener("click", () => {
    resetPanel.hidden = true;
    resetForm.reset();
  });
  resetForm.addEventListener("submit", async (ev) => {
    ev.preventDefault();
    const name = resetting;
    if (!name) return;
    if (resetPassword.value !== resetAgain.value) return fail("the two passwords differ");
    try {
      unwrap(
        await api.PUT("/api/v1/users/{name}/password", {
          params: { path: { name } },
          body: { password: resetPassword.value },
        }),
      );
      done(`password of ${name} reset; their sessions were signed out`);
      resetPanel.hidden = true;
      resetForm.reset();
    } catch (e) {
      fail(e);
    }
    await load();
  });

  void load();
  return () => {};
};
