// robot.ts -- the robot page: the running set's robot in 3D (the agent's viewer, viser or meshcat,
// in an iframe through the agent's proxy), the joint readouts beside it, live from the stream, and
// for an admin the joint map editor.  docs/robot-view.md describes the view.
import { ApiError, unwrap } from "../api/client";
import type { Page } from "../app/context";
import { escapeHtml, type RobotView } from "../robot/format";
import { jointMapForm, readJointMap } from "../robot/jointmap";
import { JointReadouts } from "../robot/readouts";
import "../robot/robot.css";

const POLL_MS = 5000;

/** What decides the page's layout: a change re-renders it (a new ticket alone does not). */
function shape(v: RobotView): string {
  return JSON.stringify([v.available, v.detail, v.viewer, v.urdf, v.set_id, v.joints]);
}

export const robotPage: Page = (root, ctx) => {
  root.classList.add("robot-page");
  root.innerHTML = `<h2>Robot</h2><div data-testid="robot-body"><p class="muted">loading…</p></div>`;
  const body = root.querySelector<HTMLElement>("[data-testid=robot-body]")!;
  let closed = false;
  let unsubscribe: (() => void) | null = null;
  let frame = 0;
  let shown = "";
  let variables: string[] | null = null;

  const stopStream = () => {
    unsubscribe?.();
    unsubscribe = null;
    if (frame) cancelAnimationFrame(frame);
    frame = 0;
  };

  const render = (view: RobotView) => {
    stopStream();
    shown = shape(view);
    if (!view.available || !view.viewer_url) {
      body.innerHTML = `
        <div class="panel robot-unavailable" data-testid="robot-unavailable">
          <p><strong>No 3D view.</strong> <span data-testid="robot-detail">${escapeHtml(view.detail ?? "")}</span></p>
          <p class="muted">The view needs a robot.json in the running set: it names the URDF and the variable
            that drives each joint (docs/robot-view.md).</p>
        </div>`;
      return;
    }
    body.innerHTML = `
      <div class="robot-layout">
        <div class="robot-view">
          <iframe data-testid="robot-viewer" title="3D view of the robot" src="${escapeHtml(view.viewer_url)}"></iframe>
          <div class="robot-caption">
            <span data-testid="robot-caption">${escapeHtml(view.urdf ?? "")} · viewer ${escapeHtml(view.viewer)}${
              view.set_id ? ` · set ${escapeHtml(view.set_id)}` : ""
            }</span>
            <button type="button" class="link" data-testid="robot-viewer-reload">reload view</button>
          </div>
          ${view.detail ? `<p class="warn" data-testid="robot-detail">${escapeHtml(view.detail)}</p>` : ""}
        </div>
        <div class="robot-side"></div>
      </div>
      <div class="robot-editor"></div>`;
    const side = body.querySelector<HTMLElement>(".robot-side")!;
    const readouts = new JointReadouts(view.joints);
    side.append(readouts.el);
    body.querySelector("[data-testid=robot-viewer-reload]")!.addEventListener("click", () => void refresh(true));

    // Live readouts: the newest sample of each mapped variable, drawn once per animation frame.
    const latest = new Map<string, number>();
    const paths = readouts.variables();
    if (paths.length) {
      unsubscribe = ctx.stream.subscribe(paths, (s) => {
        for (const [p, col] of s.values) if (col.length) latest.set(p, col[col.length - 1]);
        if (!frame)
          frame = requestAnimationFrame(() => {
            frame = 0;
            readouts.update(latest);
          });
      });
    }
    if (ctx.can("admin")) void editor(body.querySelector<HTMLElement>(".robot-editor")!, view);
  };

  const editor = async (place: HTMLElement, view: RobotView) => {
    if (variables === null) {
      try {
        const list = unwrap(await ctx.api.GET("/api/v1/variables")) as { variables: { path: string }[] };
        variables = list.variables.map((v) => v.path);
      } catch {
        variables = []; // the editor still works; the agent checks every name
      }
    }
    if (closed || shape(view) !== shown) return;
    const form = jointMapForm(view.joints, variables);
    const error = form.querySelector<HTMLElement>("[data-testid=joint-map-error]")!;
    const save = form.querySelector<HTMLButtonElement>("[data-testid=joint-map-save]")!;
    form.addEventListener("submit", async (ev) => {
      ev.preventDefault();
      const map = readJointMap(form);
      if ("error" in map) {
        error.textContent = map.error;
        return;
      }
      error.textContent = "";
      save.disabled = true;
      save.textContent = "Saving…";
      try {
        const next = unwrap(await ctx.api.PUT("/api/v1/robot/joints", { body: { joints: map.joints } })) as RobotView;
        ctx.notify(`joint map saved: set ${next.set_id ?? "?"} is active`);
        if (!closed) render(next);
      } catch (e) {
        error.textContent = e instanceof ApiError ? e.message : String(e);
        ctx.notify(`joint map not saved: ${error.textContent}`, "error");
      } finally {
        save.disabled = false;
        save.textContent = "Save joint map";
      }
    });
    place.append(form);
  };

  /** Asks the agent; re-renders when the robot, the map or its availability changed (or on `force`). */
  const refresh = async (force = false) => {
    try {
      const view = unwrap(await ctx.api.GET("/api/v1/robot")) as RobotView;
      if (closed) return;
      const editing = body.querySelector("[data-testid=joint-map]")?.contains(document.activeElement);
      if (force || (shape(view) !== shown && !editing)) render(view);
    } catch (e) {
      if (closed) return;
      if (!shown)
        body.innerHTML = `<p class="bad" data-testid="robot-detail">${escapeHtml(String(e instanceof Error ? e.message : e))}</p>`;
      ctx.notify(`robot view: ${e instanceof Error ? e.message : e}`, "error");
    }
  };

  void refresh(true);
  const poll = setInterval(() => void refresh(), POLL_MS);
  return () => {
    closed = true;
    clearInterval(poll);
    stopStream();
    root.classList.remove("robot-page");
    const iframe = body.querySelector<HTMLIFrameElement>("iframe");
    if (iframe) iframe.src = "about:blank"; // closes the viewer's WebSocket
  };
};
