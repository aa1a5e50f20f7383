// overview.ts -- the overview page: is everything up (GET /health every second, a banner when the
// agent or irpd is not answering), the newest alarm (the alarm push), the running set and its
// periods, uptime, overrun and miss counters, the host's CPU load (GET /host), and a live tail of
// the event log (GET /events).
import "../ops/ops.css";
import { unwrap } from "../api/client";
import type { Page } from "../app/context";
import { bannerOf, stateLevel, stateText } from "../ops/alarms";
import { CounterWindow } from "../ops/counters";
import { errorText, h, poll, setClass, setPath, setText } from "../ops/dom";
import { emptyTail, eventLevel, mergeEvents, pageFull, resetCursors, type Tail } from "../ops/events";
import { faultSummary } from "../ops/faults";
import { bannerText, classifyHealth, type HealthWatch, nextWatch, probeHealth } from "../ops/health";
import type { HostLoad, Status } from "../ops/types";
import { formatBytes, formatCount, formatNs, formatPercent, formatTime, formatUptime } from "../ops/units";

const EVENT_LIMIT = 200;
const EVENTS_KEPT = 500;

export const overviewPage: Page = (root, ctx) => {
  const v = (testid: string, cls = "num") => h("td", { class: cls, "data-testid": testid }, "–");
  const row = (label: string, value: HTMLElement, unit = "") =>
    h("tr", {}, h("th", {}, label), value, h("td", { class: "unit" }, unit));

  const banner = h("div", { class: "ops-banner", "data-testid": "health-banner", role: "alert", hidden: true });

  const cells = {
    set: v("set-path", "mono"),
    setId: v("set-id", "mono"),
    generation: v("generation"),
    rt: v("rt-mode", ""),
    faults: v("faults", ""),
    pid: v("irpd-pid"),
    uptime: v("uptime"),
    cycles: v("cycles"),
    basic: v("basic-period"),
    macro: v("macro-period"),
    slots: v("slots"),
    overruns: v("overruns"),
    overrunsRecent: v("overruns-recent"),
    missed: v("missed"),
    missedRecent: v("missed-recent"),
    skipped: v("skipped"),
    caughtUp: v("caught-up"),
    statsDropped: v("stats-dropped"),
    agent: v("agent-health", ""),
    irpd: v("irpd-health", ""),
    version: v("agent-version", ""),
  };
  const statusError = h("div", { class: "ops-error", "data-testid": "status-error", hidden: true });

  const setPanel = h(
    "section",
    { class: "panel ops-panel" },
    h("h3", {}, "Running set"),
    h(
      "table",
      { class: "ops-kv" },
      row("set", cells.set),
      row("set id", cells.setId),
      row("generation", cells.generation),
      row("mode", cells.rt),
      row("faults", cells.faults),
      row("irpd pid", cells.pid),
      row("uptime", cells.uptime),
      row("basic periods run", cells.cycles),
    ),
    statusError,
  );
  const timingPanel = h(
    "section",
    { class: "panel ops-panel" },
    h("h3", {}, "Timing"),
    h(
      "table",
      { class: "ops-kv" },
      row("basic period", cells.basic),
      row("macro period", cells.macro),
      row("slots", cells.slots),
      row("overruns", cells.overruns, "total"),
      row("", cells.overrunsRecent, "last 60 s"),
      row("missed periods", cells.missed, "total"),
      row("", cells.missedRecent, "last 60 s"),
      row("skipped", cells.skipped),
      row("caught up", cells.caughtUp),
      row("figures lost", cells.statsDropped, "runs not in the statistics"),
    ),
  );
  const healthPanel = h(
    "section",
    { class: "panel ops-panel" },
    h("h3", {}, "Health"),
    h(
      "table",
      { class: "ops-kv" },
      row("agent", cells.agent),
      row("irpd", cells.irpd),
      row("agent version", cells.version),
    ),
  );

  const cpuBars = h("div", { class: "ops-cpus", "data-testid": "cpu-bars" });
  const hostCells = {
    load: v("load-avg", "num"),
    irpdCpu: v("irpd-cpu"),
    irpdRss: v("irpd-rss"),
    irpdThreads: v("irpd-threads"),
    agentCpu: v("agent-cpu"),
    agentRss: v("agent-rss"),
    agentThreads: v("agent-threads"),
    agentUptime: v("agent-uptime"),
  };
  const hostMessage = h("span", {});
  const hostRetry = h("button", { class: "small", "data-testid": "host-retry" }, "retry now");
  const hostError = h(
    "div",
    { class: "ops-error", "data-testid": "host-error", hidden: true },
    hostMessage,
    " ",
    hostRetry,
  );
  const hostPanel = h(
    "section",
    { class: "panel ops-panel ops-host", "data-testid": "host" },
    h("h3", {}, "Host load", h("span", { class: "ops-sub", "data-testid": "host-interval" }, "")),
    cpuBars,
    h(
      "table",
      { class: "ops-grid" },
      h("thead", {}, h("tr", {}, h("th", {}, ""), h("th", {}, "CPU"), h("th", {}, "RSS"), h("th", {}, "threads"))),
      h(
        "tbody",
        {},
        h("tr", {}, h("th", {}, "irpd"), hostCells.irpdCpu, hostCells.irpdRss, hostCells.irpdThreads),
        h("tr", {}, h("th", {}, "agent"), hostCells.agentCpu, hostCells.agentRss, hostCells.agentThreads),
      ),
    ),
    h(
      "table",
      { class: "ops-kv" },
      row("load average", hostCells.load, "1, 5, 15 min"),
      row("agent uptime", hostCells.agentUptime),
    ),
    hostError,
  );

  const tailBody = h("tbody", {});
  const tailInfo = h("span", { class: "ops-sub", "data-testid": "event-tail-info" }, "");
  const tailError = h("div", { class: "ops-error", "data-testid": "event-error", hidden: true });
  const tailPanel = h(
    "section",
    { class: "panel ops-panel ops-events" },
    h("h3", {}, "Events", tailInfo),
    tailError,
    h(
      "div",
      { class: "ops-scroll" },
      h(
        "table",
        { class: "ops-grid ops-dense", "data-testid": "event-tail" },
        h(
          "thead",
          {},
          h(
            "tr",
            {},
            h("th", {}, "time"),
            h("th", {}, "source"),
            h("th", {}, "kind"),
            h("th", {}, "module"),
            h("th", {}, "message"),
          ),
        ),
        tailBody,
      ),
    ),
  );

  const newest = h("div", { "data-testid": "newest-alarm" }, "–");
  const alarmCounts = h("span", { class: "ops-sub", "data-testid": "overview-alarm-counts" }, "");
  const alarmPanel = h(
    "section",
    { class: "panel ops-panel" },
    h("h3", {}, "Newest alarm", alarmCounts, " ", h("a", { href: "#/alarms", class: "ops-sub" }, "all alarms ›")),
    newest,
  );
  const stopAlarms = ctx.alarms.listen((view, connected) => {
    const b = bannerOf(view, connected);
    setText(alarmCounts, ` — ${b.text}`);
    const a = view.newest;
    if (!a) {
      newest.replaceChildren(h("span", { class: "muted" }, connected ? "none needs attention" : "–"));
      return;
    }
    newest.replaceChildren(
      h(
        "table",
        { class: "ops-kv" },
        h(
          "tr",
          {},
          h("th", {}, a.key),
          h(
            "td",
            { class: "wrap" },
            h(
              "span",
              { class: `state ${a.severity === "high" || a.severity === "critical" ? "bad" : "warn"}` },
              a.severity,
            ),
            " ",
            a.text,
            a.detail ? h("span", { class: "ops-sub" }, ` — ${a.detail}`) : null,
          ),
        ),
        h(
          "tr",
          {},
          h("th", {}, "since"),
          h("td", { class: "mono", title: a.raised ?? "" }, a.raised ? formatTime(a.raised) : "–"),
        ),
        h("tr", {}, h("th", {}, "state"), h("td", { class: `state ${stateLevel(a.state)}` }, stateText(a.state))),
      ),
    );
  });

  root.append(
    h(
      "div",
      { class: "ops-page", "data-testid": "overview" },
      banner,
      alarmPanel,
      h("div", { class: "ops-cols" }, setPanel, timingPanel, healthPanel, hostPanel),
      tailPanel,
    ),
  );

  let tail: Tail = emptyTail();

  // ---- health: every second, no token ------------------------------------------------------
  let watch: HealthWatch | null = null;
  let agentWasDown = false;
  const showHealth = () => {
    if (!watch) return;
    const text = bannerText(watch, Date.now());
    banner.hidden = text === "";
    setText(banner, text);
    setClass(banner, `ops-banner ${watch.state.kind === "agent-down" ? "bad" : "warn"}`);
    const hl = watch.state.health;
    setText(cells.agent, watch.state.kind === "agent-down" ? "unreachable" : "ok");
    setClass(cells.agent, watch.state.kind === "agent-down" ? "state bad" : "state good");
    setText(
      cells.irpd,
      watch.state.kind === "agent-down"
        ? "unknown (agent unreachable)"
        : hl?.irpd === "ok"
          ? hl.running
            ? "ok, running"
            : "ok, not running"
          : `unreachable${hl?.detail ? `: ${hl.detail}` : ""}`,
    );
    setClass(
      cells.irpd,
      watch.state.kind === "ok"
        ? hl?.running
          ? "state good"
          : "state warn"
        : watch.state.kind === "irpd-down"
          ? "state bad"
          : "state muted",
    );
    setText(cells.version, hl?.version ?? "–");
    for (const p of [setPanel, timingPanel, hostPanel, tailPanel])
      p.classList.toggle("stale-health", watch.state.kind !== "ok");
  };
  const healthPoll = poll(async () => {
    const s = classifyHealth(await probeHealth());
    const before = watch?.state.kind;
    watch = nextWatch(watch, s, Date.now());
    if (s.kind === "agent-down") agentWasDown = true;
    if (before && before !== s.kind) {
      if (s.kind === "ok") ctx.notify(before === "agent-down" ? "the agent answers again" : "irpd answers again");
      else ctx.notify(bannerText(watch, Date.now()), "error");
      statusPoll.now();
      hostPoll.now();
      eventPoll.now();
    }
    showHealth();
  }, 1000);

  // ---- status: every second ------------------------------------------------------------------
  const overruns = new CounterWindow();
  const missed = new CounterWindow();
  let irpdPid: number | null = null;
  const statusPoll = poll(
    async () => {
      const st = unwrap(await ctx.api.GET("/api/v1/status")) as unknown as Status;
      statusError.hidden = true;
      setPanel.classList.remove("stale");
      timingPanel.classList.remove("stale");
      if (irpdPid !== null && st.pid !== irpdPid) tail = resetCursors(tail, { irpd: true });
      irpdPid = st.pid;
      setPath(cells.set, st.set ?? "(none)");
      setText(cells.setId, st.set_id ?? "— (not from the store)");
      setText(cells.generation, String(st.generation));
      setText(cells.rt, st.realtime ? "real-time (SCHED_FIFO)" : "NOT real-time (SCHED_OTHER)");
      setClass(cells.rt, st.realtime ? "state good" : "state warn");
      const fault = faultSummary(st);
      setText(cells.faults, fault.text);
      setClass(cells.faults, `state ${fault.level}`);
      setText(cells.pid, String(st.pid));
      setText(cells.uptime, formatUptime(st.uptime_ns / 1e9));
      setText(cells.cycles, formatCount(st.cycles));
      setText(cells.basic, formatNs(st.basic_period_ns));
      setText(cells.macro, formatNs(st.macro_period_ns));
      setText(cells.slots, st.basic_period_ns ? String(Math.round(st.macro_period_ns / st.basic_period_ns)) : "–");
      const now = Date.now();
      const o = overruns.add(now, st.overruns, st.pid);
      const m = missed.add(now, st.missed, st.pid);
      setText(cells.overruns, formatCount(st.overruns));
      setText(cells.missed, formatCount(st.missed));
      setText(cells.skipped, formatCount(st.skipped));
      setText(cells.caughtUp, formatCount(st.caught_up));
      setText(cells.statsDropped, formatCount(st.stats_dropped));
      setClass(cells.statsDropped, `num ${st.stats_dropped > 0 ? "warn" : ""}`);
      setText(cells.overrunsRecent, `+${formatCount(o)}`);
      setText(cells.missedRecent, `+${formatCount(m)}`);
      setClass(cells.overrunsRecent, `num ${o > 0 ? "bad" : ""}`);
      setClass(cells.missedRecent, `num ${m > 0 ? "bad" : ""}`);
      setClass(cells.overruns, `num ${st.overruns > 0 ? "warn" : ""}`);
      setClass(cells.missed, `num ${st.missed > 0 ? "warn" : ""}`);
    },
    1000,
    (e) => {
      statusError.hidden = false;
      setText(statusError, `status: ${errorText(e)} — retrying`);
      setPanel.classList.add("stale");
      timingPanel.classList.add("stale");
    },
  );

  // ---- host load: every 2 s --------------------------------------------------------------------
  const renderHost = (hl: HostLoad) => {
    setText(root.querySelector("[data-testid=host-interval]")!, ` over ${hl.interval_s.toFixed(1)} s`);
    while (cpuBars.children.length > hl.cpus.length) cpuBars.lastElementChild!.remove();
    hl.cpus.forEach((c, i) => {
      let bar = cpuBars.children[i] as HTMLElement | undefined;
      if (!bar) {
        bar = h(
          "div",
          { class: "ops-cpu" },
          h("span", { class: "ops-cpu-name" }),
          h("span", { class: "ops-bar" }, h("span", { class: "ops-bar-fill" })),
          h("span", { class: "ops-cpu-val num" }),
        );
        cpuBars.append(bar);
      }
      bar.dataset.testid = `cpu-${c.cpu}`;
      const busy = Math.min(1, Math.max(0, c.busy));
      setText(bar.children[0], `cpu${c.cpu}`);
      const fill = bar.children[1].firstElementChild as HTMLElement;
      fill.style.width = `${(busy * 100).toFixed(1)}%`;
      setClass(fill, `ops-bar-fill ${busy > 0.9 ? "bad" : busy > 0.7 ? "warn" : ""}`);
      setText(bar.children[2], formatPercent(busy, 0));
    });
    setText(hostCells.load, hl.load_avg.map((x) => x.toFixed(2)).join("  "));
    const proc = (p: HostLoad["agent"] | null, cpu: HTMLElement, rss: HTMLElement, th: HTMLElement) => {
      setText(cpu, p ? formatPercent(p.cpu) : "– (not answering)");
      setText(rss, p ? formatBytes(p.rss_bytes) : "–");
      setText(th, p ? String(p.threads) : "–");
    };
    proc(hl.irpd, hostCells.irpdCpu, hostCells.irpdRss, hostCells.irpdThreads);
    proc(hl.agent, hostCells.agentCpu, hostCells.agentRss, hostCells.agentThreads);
    setText(hostCells.agentUptime, formatUptime(hl.agent_uptime_s));
  };
  const hostPoll = poll(
    async () => {
      renderHost(unwrap(await ctx.api.GET("/api/v1/host")));
      hostError.hidden = true;
      hostPanel.classList.remove("stale");
    },
    2000,
    (e) => {
      hostError.hidden = false;
      setText(hostMessage, `host load unavailable: ${errorText(e)} — retrying every 2 s`);
      hostPanel.classList.add("stale");
    },
  );
  hostRetry.addEventListener("click", () => hostPoll.now());

  // ---- event tail: every second, with cursors -------------------------------------------------
  const renderTail = () => {
    const have = new Map<string, HTMLTableRowElement>();
    for (const tr of Array.from(tailBody.children) as HTMLTableRowElement[]) have.set(tr.dataset.key!, tr);
    const rows = tail.events.map((e) => {
      const key = `${e.source}:${e.seq}:${e.time_ns}`;
      return (
        have.get(key) ??
        h(
          "tr",
          { "data-key": key, class: eventLevel(e.kind) ? `ev-${eventLevel(e.kind)}` : null, "data-kind": e.kind },
          h("td", { class: "mono nowrap", title: e.time }, formatTime(e.time)),
          h("td", {}, e.source),
          h("td", { class: "nowrap kind" }, e.kind),
          h("td", { class: "mono" }, e.module ?? ""),
          h("td", { class: "wrap" }, e.message),
        )
      );
    });
    tailBody.replaceChildren(...rows);
    const parts = [`${tail.events.length} shown, newest first`];
    if (tail.dropped) parts.push(`${tail.dropped} lost before they were read`);
    if (tail.irpd !== "ok") parts.push(`irpd's events missing: ${tail.irpd}`);
    setText(tailInfo, ` — ${parts.join(" · ")}`);
  };
  const eventPoll = poll(
    async () => {
      if (agentWasDown && watch?.state.kind !== "agent-down") {
        // the agent may have restarted: its sequence begins again; shown events are kept by key
        tail = resetCursors(tail, { agent: true });
        agentWasDown = false;
      }
      for (let round = 0; round < 10; round++) {
        const page = unwrap(
          await ctx.api.GET("/api/v1/events", {
            params: { query: { since: tail.since, agent_since: tail.agentSince, limit: EVENT_LIMIT } },
          }),
        );
        tail = mergeEvents(tail, page, EVENTS_KEPT);
        if (!pageFull(page, EVENT_LIMIT)) break;
      }
      tailError.hidden = true;
      renderTail();
    },
    1000,
    (e) => {
      tailError.hidden = false;
      setText(tailError, `events: ${errorText(e)} — retrying`);
    },
  );

  const clock = setInterval(showHealth, 1000);
  return () => {
    stopAlarms();
    clearInterval(clock);
    healthPoll.stop();
    statusPoll.stop();
    hostPoll.stop();
    eventPoll.stop();
  };
};
