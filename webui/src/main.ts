// main.ts -- the shell: sign-in, the navigation bar, the hash router (#/overview, #/modules, ...)
// and the status bar.  Each page lives in src/pages/<name>.ts and gets an AppContext.
import "uplot/dist/uPlot.min.css";
import "./styles/app.css";
import { makeApi } from "./api/client";
import { type AppContext, type Page, type Role, roleAtLeast, type Session } from "./app/context";
import { forgetToken, signIn, storedToken } from "./app/signin";
import { jitterPage } from "./pages/jitter";
import { modulesPage } from "./pages/modules";
import { overviewPage } from "./pages/overview";
import { robotPage } from "./pages/robot";
import { schedulePage } from "./pages/schedule";
import { variablesPage } from "./pages/variables";
import { StreamClient } from "./stream/stream";

const PAGES: { id: string; title: string; page: Page }[] = [
  { id: "overview", title: "Overview", page: overviewPage },
  { id: "modules", title: "Modules", page: modulesPage },
  { id: "schedule", title: "Schedule", page: schedulePage },
  { id: "jitter", title: "Jitter", page: jitterPage },
  { id: "variables", title: "Variables", page: variablesPage },
  { id: "robot", title: "Robot", page: robotPage },
];

function streamUrl(): string {
  const u = new URL("api/v1/stream", window.location.href.replace(/#.*$/, ""));
  u.protocol = u.protocol === "https:" ? "wss:" : "ws:";
  return u.toString();
}

async function start(root: HTMLElement): Promise<void> {
  const session: Session = await signIn(root, storedToken());
  const api = makeApi(session.token);
  const stream = new StreamClient(streamUrl(), session.token);
  root.innerHTML = `
    <header class="bar">
      <span class="brand">indurop</span>
      <nav>${PAGES.map((p) => `<a href="#/${p.id}" data-page="${p.id}">${p.title}</a>`).join("")}</nav>
      <span class="who" data-testid="who">${session.name} · ${session.role}</span>
      <button class="link" data-testid="sign-out">sign out</button>
    </header>
    <main id="page"></main>
    <footer class="status"><span data-testid="notice"></span></footer>`;
  const main = root.querySelector<HTMLElement>("#page")!;
  const notice = root.querySelector<HTMLElement>("[data-testid=notice]")!;
  root.querySelector("[data-testid=sign-out]")!.addEventListener("click", () => {
    forgetToken();
    location.reload();
  });
  const ctx: AppContext = {
    api,
    session,
    stream,
    can: (role: Role) => roleAtLeast(session.role, role),
    notify(message, kind = "info") {
      notice.textContent = message;
      notice.className = kind;
    },
  };
  let unmount: (() => void) | null = null;
  const route = () => {
    const id = location.hash.replace(/^#\/?/, "").split(/[/?]/)[0] || "overview";
    const p = PAGES.find((x) => x.id === id) ?? PAGES[0];
    unmount?.();
    main.innerHTML = "";
    main.dataset.page = p.id;
    for (const a of root.querySelectorAll<HTMLAnchorElement>("nav a"))
      a.classList.toggle("active", a.dataset.page === p.id);
    unmount = p.page(main, ctx);
  };
  window.addEventListener("hashchange", route);
  route();
}

void start(document.getElementById("app")!);
