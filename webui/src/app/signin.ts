// signin.ts -- the sign-in form: a token, checked against GET /api/v1/auth/me, kept in
// sessionStorage (gone when the tab closes).  ?token=... in the URL signs in directly.
import { ApiError, makeApi, unwrap } from "../api/client";
import type { Role, Session } from "./context";

const KEY = "indurop.token";

export function storedToken(): string | null {
  const fromUrl = new URLSearchParams(location.search).get("token");
  if (fromUrl) {
    sessionStorage.setItem(KEY, fromUrl);
    history.replaceState(null, "", location.pathname + location.hash);
  }
  return sessionStorage.getItem(KEY);
}

export function forgetToken(): void {
  sessionStorage.removeItem(KEY);
}

async function whoAmI(token: string): Promise<Session> {
  const me = unwrap(await makeApi(token).GET("/api/v1/auth/me")) as { name: string; role: Role };
  return { token, name: me.name, role: me.role };
}

/** Resolves with a session once a token is accepted. */
export function signIn(root: HTMLElement, token: string | null): Promise<Session> {
  return new Promise((resolve) => {
    const form = () => {
      root.innerHTML = `
        <form class="signin" data-testid="signin">
          <h1>indurop</h1>
          <label>Token <input type="password" name="token" autocomplete="current-password" data-testid="token" required /></label>
          <button type="submit" data-testid="sign-in">Sign in</button>
          <p class="error" data-testid="signin-error"></p>
        </form>`;
      const f = root.querySelector<HTMLFormElement>("form")!;
      f.addEventListener("submit", (ev) => {
        ev.preventDefault();
        void attempt(f.token.value.trim());
      });
    };
    const attempt = async (t: string) => {
      try {
        const s = await whoAmI(t);
        sessionStorage.setItem(KEY, t);
        resolve(s);
      } catch (e) {
        if (!root.querySelector("form")) form();
        const msg = e instanceof ApiError ? `${e.status}: ${e.message}` : String(e);
        root.querySelector<HTMLElement>("[data-testid=signin-error]")!.textContent = msg;
      }
    };
    form();
    if (token) void attempt(token);
  });
}
