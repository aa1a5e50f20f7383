// main.ts -- the shell: sign-in, the navigation bar with the alarm banner, the hash router
// (#/overview, #/modules, ...) and the status bar.  Each page lives in src/pages/<name>.ts and gets
// an AppContext.
import "uplot/dist/uPlot.min.css";
import "./styles/app.css";
import { makeApi } from "./api/client";
import { AlarmFeed } from "./app/alarm-feed";
import { type AppContext, type Page, type Role, roleAtLeast, type Session } from "./app/context";
import { forgetToken, signIn, storedToken } from "./app/signin";
import { bannerOf } from "./ops/alarms";
import { setClass, setText } from "./ops/dom";
import { alarmsPage } from "./pages/alarms";
import { jitterPage } from "./pages/jitter";
import { modulesPage } from "./pages/modules";
import { overviewPage } from "./pages/overview";
import { robotPage } from "./pages/robot";
import { schedulePage } from "./pages/schedule";
import { systemPage } from "./pages/system";
import { variablesPage } from "./pages/variables";
import { StreamClient } from "./stream/stream";

const PAGES: { id: string; title: string; page: Page }[] = [
  { id: "overview", title: "Overview", page: overviewPage },
  { id: "modules", title: "Modules", page: modulesPage },
  { id: "schedule", title: "Schedule", page: schedulePage },
  { id: "jitter", title: "Jitter", page: jitterPage },
  { id: "variables", title: "Variables", page: variablesPage },
  { id: "robot", title: "Robot", page: robotPage },
  { id: "alarms", title: "Alarms", page: alarmsPage },
  { id: "system", title: "System", page: systemPage },
];

function socketUrl(path: string): string {
  const u = new URL(path, window.location.href.replace(/#.*$/, ""));
  u.protocol = u.protocol === "https:" ? "wss:" : "ws:";
  return u.toString();
}

async function start(root: HTMLElement): Promise<void> {
  const session: Session = await signIn(root, storedToken());
  const api = makeApi(session.token);
  const stream = new StreamClient(socketUrl("api/v1/stream"), session.token);
  const alarms = new AlarmFeed(socketUrl("api/v1/alarms/live"), session.token);
  root.innerHTML = `
    <header class="bar">
      <span class="brand">indurop</span>
      <nav>${PAGES.map((p) => `<a href="#/${p.id}" data-page="${p.id}">${p.title}</a>`).join("")}</nav>
      <a class="alarm-banner muted" href="#/alarms" data-testid="alarm-banner" role="status"></a>
      <span class="who" data-testid="who">${session.name} · ${session.role}</span>
      <button class="link" data-testid="sign-out">sign out</button>
    </header>
    <main id="page"></main>
    <footer class="status"><span data-testid="notice"></span></footer>`;
  const main = root.querySelector<HTMLElement>("#page")!;
  const notice = root.querySelector<HTMLElement>("[data-testid=notice]")!;
  const banner = root.querySelector<HTMLElement>("[data-testid=alarm-banner]")!;
  alarms.listen((view, connected) => {
    const b = bannerOf(view, connected);
    setText(banner, b.text);
    setClass(banner, `alarm-banner ${b.level}`);
    banner.title = b.title;
    banner.dataset.active = String(view.counts.active);
    banner.dataset.unacknowledged = String(view.counts.unacknowledged);
  });
  root.querySelector("[data-testid=sign-out]")!.addEventListener("click", () => {
    forgetToken();
    location.reload();
  });
  const ctx: AppContext = {
    api,
    session,
    stream,
    alarms,
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
