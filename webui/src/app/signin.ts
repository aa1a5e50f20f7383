// signin.ts -- signing in with a user name and a password (POST /api/v1/session: the agent sets an
// HttpOnly session cookie and answers the CSRF token).  When no user exists yet, the first-run form
// creates the first admin with the admin token the agent wrote at its first start, then signs in.
// Nothing is kept in the browser's storage but a notice to show after a reload.
import { ApiError, makeApi, unwrap } from "../api/client";
import type { components } from "../api/schema";
import type { Role, Session } from "./context";

type SessionState = components["schemas"]["SessionState"];

const NOTICE = "indurop.notice";

/** Shows `text` on the sign-in form after the next reload (e.g. why the session ended). */
export function noticeAfterReload(text: string): void {
  sessionStorage.setItem(NOTICE, text);
}

function takeNotice(): string {
  const text = sessionStorage.getItem(NOTICE) ?? "";
  sessionStorage.removeItem(NOTICE);
  return text;
}

function sessionOf(s: SessionState): Session {
  return { name: s.name ?? "", role: (s.role ?? "viewer") as Role, csrf: s.csrf_token ?? "" };
}

function messageOf(e: unknown): string {
  if (e instanceof ApiError) return e.status === 422 ? e.message : `${e.status}: ${e.message}`;
  return e instanceof TypeError ? "the agent did not answer (network error)" : String(e);
}

async function signInWith(name: string, password: string): Promise<Session> {
  return sessionOf(unwrap(await makeApi().POST("/api/v1/session", { body: { name, password } })));
}

const SIGN_IN = `
  <form class="signin" data-testid="signin">
    <h1>indurop</h1>
    <p class="notice" data-testid="signin-notice"></p>
    <label>User name <input name="user" autocomplete="username" autocapitalize="off" spellcheck="false" data-testid="user-name" required /></label>
    <label>Password <input type="password" name="password" autocomplete="current-password" data-testid="password" required /></label>
    <button type="submit" data-testid="sign-in">Sign in</button>
    <p class="error" data-testid="signin-error"></p>
  </form>`;

const FIRST_RUN = `
  <form class="signin" data-testid="first-run">
    <h1>indurop: the first admin</h1>
    <p>No user exists yet. Give the admin token the agent wrote at its first start
      (<code>&lt;data-dir&gt;/admin-token</code>) and choose the first admin's name and password.</p>
    <label>Admin token <input type="password" name="token" autocomplete="off" data-testid="admin-token" required /></label>
    <label>User name <input name="user" autocomplete="username" autocapitalize="off" spellcheck="false" data-testid="first-name" required /></label>
    <label>Password <input type="password" name="password" autocomplete="new-password" data-testid="first-password" required /></label>
    <label>The same again <input type="password" name="again" autocomplete="new-password" data-testid="first-password-again" required /></label>
    <p class="hint">At least 12 characters, not containing the user name.</p>
    <button type="submit" data-testid="create-admin">Create and sign in</button>
    <p class="error" data-testid="signin-error"></p>
  </form>`;

/** Resolves with the session: the one the browser has, or one signed in through the form. */
export async function signIn(root: HTMLElement): Promise<Session> {
  const notice = takeNotice();
  const state = unwrap(await makeApi().GET("/api/v1/session"));
  if (state.signed_in) return sessionOf(state);
  return new Promise((resolve) => {
    const showError = (e: unknown) => {
      root.querySelector<HTMLElement>("[data-testid=signin-error]")!.textContent = messageOf(e);
    };
    if (state.first_run) {
      root.innerHTML = FIRST_RUN;
      const f = root.querySelector<HTMLFormElement>("form")!;
      f.addEventListener("submit", async (ev) => {
        ev.preventDefault();
        const name = f.user.value.trim();
        const password = f.password.value;
        if (password !== f.again.value) return showError("the two passwords differ");
        try {
          const admin = makeApi({ token: f.token.value.trim() });
          unwrap(await admin.POST("/api/v1/users", { body: { name, role: "admin", password } }));
          resolve(await signInWith(name, password));
        } catch (e) {
          showError(e);
        }
      });
      return;
    }
    root.innerHTML = SIGN_IN;
    root.querySelector<HTMLElement>("[data-testid=signin-notice]")!.textContent = notice;
    const f = root.querySelector<HTMLFormElement>("form")!;
    f.addEventListener("submit", async (ev) => {
      ev.preventDefault();
      try {
        resolve(await signInWith(f.user.value.trim(), f.password.value));
      } catch (e) {
        f.password.value = "";
        showError(e);
      }
    });
  });
}

/** Signs out on the agent (the session ends there; its cookie is refused from then on). */
export async function signOut(csrf: string): Promise<void> {
  await makeApi({ csrf }).DELETE("/api/v1/session");
}
