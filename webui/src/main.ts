// main.ts -- the shell: sign-in, the navigation bar with the alarm and force banners and the user's menu
// (password, sign out), the hash router (#/overview, #/modules, ...) and the status bar.  Each page
// lives in src/pages/<name>.ts and gets an AppContext.  When the agent says the session has ended
// (a 401, a WebSocket closed with 4401), the page reloads onto the sign-in form, saying why.
import "uplot/dist/uPlot.min.css";
import "./styles/app.css";
import { makeApi, watchPresence } from "./api/client";
import { AlarmFeed } from "./app/alarm-feed";
import { type AppContext, type Page, type Role, roleAtLeast, type Session } from "./app/context";
import { bannerText, ForceFeed, forcesTitle } from "./app/force-feed";
import { openPasswordDialog } from "./app/password-dialog";
import { noticeAfterReload, signIn, signOut } from "./app/signin";
import { bannerOf } from "./ops/alarms";
import { setClass, setText } from "./ops/dom";
import { alarmsPage } from "./pages/alarms";
import { forcesPage } from "./pages/forces";
import { jitterPage } from "./pages/jitter";
import { linePage } from "./pages/line";
import { modulesPage } from "./pages/modules";
import { opcuaPage } from "./pages/opcua";
import { overviewPage } from "./pages/overview";
import { programsPage } from "./pages/programs";
import { robotPage } from "./pages/robot";
import { schedulePage } from "./pages/schedule";
import { scopePage } from "./pages/scope";
import { systemPage } from "./pages/system";
import { usersPage } from "./pages/users";
import { variablesPage } from "./pages/variables";
import { watchPage } from "./pages/watch";
import { StreamClient } from "./stream/stream";

const ALL_PAGES: { id: string; title: string; page: Page; role: Role }[] = [
  { id: "overview", title: "Overview", page: overviewPage, role: "viewer" },
  { id: "modules", title: "Modules", page: modulesPage, role: "viewer" },
  { id: "schedule", title: "Schedule", page: schedulePage, role: "viewer" },
  { id: "jitter", title: "Jitter", page: jitterPage, role: "viewer" },
  { id: "programs", title: "Programs", page: programsPage, role: "viewer" },
  { id: "variables", title: "Variables", page: variablesPage, role: "viewer" },
  { id: "watch", title: "Watch", page: watchPage, role: "viewer" },
  { id: "forces", title: "Forces", page: forcesPage, role: "viewer" },
  { id: "scope", title: "Scope", page: scopePage, role: "viewer" },
  { id: "robot", title: "Robot", page: robotPage, role: "viewer" },
  { id: "alarms", title: "Alarms", page: alarmsPage, role: "viewer" },
  { id: "line", title: "Line", page: linePage, role: "viewer" },
  { id: "opcua", title: "OPC UA", page: opcuaPage, role: "viewer" },
  { id: "users", title: "Users", page: usersPage, role: "admin" },
  { id: "system", title: "System", page: systemPage, role: "admin" },
];

function socketUrl(path: string): string {
  const u = new URL(path, window.location.href.replace(/#.*$/, ""));
  u.protocol = u.protocol === "https:" ? "wss:" : "ws:";
  return u.toString();
}

let ending = false;
/** The session ended on the agent: back to the sign-in form, which says why. */
function sessionEnded(): void {
  if (ending) return;
  ending = true;
  noticeAfterReload("Your session has ended (signed out, idle too long, or changed by an admin): sign in again.");
  location.reload();
}

async function start(root: HTMLElement): Promise<void> {
  watchPresence(window);
  const session: Session = await signIn(root);
  const api = makeApi({ csrf: session.csrf, onSignedOut: sessionEnded });
  const stream = new StreamClient(socketUrl("api/v1/stream"));
  const alarms = new AlarmFeed(socketUrl("api/v1/alarms/live"));
  stream.onSignedOut = sessionEnded;
  alarms.onSignedOut = sessionEnded;
  const pages = ALL_PAGES.filter((p) => roleAtLeast(session.role, p.role));
  root.innerHTML = `
    <header class="bar">
      <span class="brand">indurop</span>
      <nav>${pages.map((p) => `<a href="#/${p.id}" data-page="${p.id}">${p.title}</a>`).join("")}</nav>
      <a class="alarm-banner muted" href="#/alarms" data-testid="alarm-banner" role="status"></a>
      <a class="force-banner" href="#/forces" data-testid="force-banner" role="status" hidden></a>
      <span class="who" data-testid="who"></span>
      <button class="link" data-testid="change-password">password</button>
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
  const forces = new ForceFeed(api);
  const forceBanner = root.querySelector<HTMLElement>("[data-testid=force-banner]")!;
  forces.listen((list) => {
    setText(forceBanner, bannerText(list.length));
    forceBanner.hidden = list.length === 0;
    forceBanner.title = forcesTitle(list);
    forceBanner.dataset.count = String(list.length);
  });
  root.querySelector<HTMLElement>("[data-testid=who]")!.textContent = `${session.name} · ${session.role}`;
  root.querySelector("[data-testid=sign-out]")!.addEventListener("click", async () => {
    ending = true; // the 401s of pages still polling are expected now
    try {
      await signOut(session.csrf);
    } finally {
      location.reload();
    }
  });
  root
    .querySelector("[data-testid=change-password]")!
    .addEventListener("click", () => openPasswordDialog(api, session.name, (message) => ctx.notify(message)));
  const ctx: AppContext = {
    api,
    session,
    stream,
    alarms,
    forces,
    can: (role: Role) => roleAtLeast(session.role, role),
    notify(message, kind = "info") {
      notice.textContent = message;
      notice.className = kind;
    },
  };
  let unmount: (() => void) | null = null;
  const route = () => {
    const id = location.hash.replace(/^#\/?/, "").split(/[/?]/)[0] || "overview";
    const p = pages.find((x) => x.id === id) ?? pages[0];
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
