// password-dialog.ts -- the signed-in user changes their own password (from the bar's "password"
// button): the present one, the new one twice; PUT /api/v1/users/{name}/password.  The agent ends the
// user's other sessions; this one goes on.
import { type Api, ApiError, unwrap } from "../api/client";
import { h } from "../ops/dom";

function messageOf(e: unknown): string {
  if (e instanceof ApiError) return e.status === 422 ? e.message : `${e.status}: ${e.message}`;
  return String(e);
}

/** Opens the dialog; `done` is told once the password has changed. */
export function openPasswordDialog(api: Api, name: string, done: (message: string) => void): void {
  const current = h("input", {
    type: "password",
    autocomplete: "current-password",
    required: true,
    "data-testid": "pw-current",
  });
  const fresh = h("input", { type: "password", autocomplete: "new-password", required: true, "data-testid": "pw-new" });
  const again = h("input", {
    type: "password",
    autocomplete: "new-password",
    required: true,
    "data-testid": "pw-again",
  });
  const error = h("p", { class: "error", "data-testid": "pw-error" });
  const cancel = h("button", { type: "button", "data-testid": "pw-cancel" }, "Cancel");
  const form = h(
    "form",
    { class: "signin", method: "dialog" },
    h("h3", {}, `Change the password of ${name}`),
    h("label", {}, "Present password ", current),
    h("label", {}, "New password ", fresh),
    h("label", {}, "The same again ", again),
    h("p", { class: "hint" }, "At least 12 characters, not containing the user name, not the present one."),
    h("div", {}, h("button", { type: "submit", "data-testid": "pw-save" }, "Change"), " ", cancel),
    error,
  );
  const dialog = h("dialog", { class: "password-dialog", "data-testid": "password-dialog" }, form);
  const close = () => {
    dialog.close();
    dialog.remove();
  };
  cancel.addEventListener("click", close);
  form.addEventListener("submit", async (ev) => {
    ev.preventDefault();
    if (fresh.value !== again.value) {
      error.textContent = "the two new passwords differ";
      return;
    }
    try {
      unwrap(
        await api.PUT("/api/v1/users/{name}/password", {
          params: { path: { name } },
          body: { password: fresh.value, current_password: current.value },
        }),
      );
      close();
      done("password changed; your other sessions were signed out");
    } catch (e) {
      error.textContent = messageOf(e);
    }
  });
  document.body.append(dialog);
  dialog.showModal();
  current.focus();
}
