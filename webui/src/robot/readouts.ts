// readouts.ts -- the joint readouts beside the 3D view: one row per joint (name, variable, position
// in rad and degrees, limits), fed with the newest sample of each mapped variable.
import {
  degrees,
  escapeHtml,
  isAngular,
  jointPosition,
  limitsText,
  num,
  outsideLimits,
  type RobotJoint,
} from "./format";

export class JointReadouts {
  readonly el: HTMLTableElement;
  private cells = new Map<string, { rad: HTMLElement; deg: HTMLElement; row: HTMLElement }>();

  constructor(private readonly joints: RobotJoint[]) {
    this.el = document.createElement("table");
    this.el.dataset.testid = "joint-readouts";
    this.el.className = "robot-readouts";
    this.el.innerHTML = `
      <thead><tr><th>joint</th><th>variable</th><th>rad</th><th>deg</th><th>limits</th></tr></thead>
      <tbody>${joints
        .map(
          (j) => `<tr data-testid="joint-row" data-joint="${escapeHtml(j.joint)}">
            <td>${escapeHtml(j.joint)}</td>
            <td class="variable">${j.variable ? escapeHtml(j.variable) : '<span class="muted">none: held at 0</span>'}</td>
            <td class="num" data-testid="joint-rad">${isAngular(j) ? num(0) : `${num(0)} m`}</td>
            <td class="num" data-testid="joint-deg">${isAngular(j) ? num(0, 2) : "—"}</td>
            <td class="num">${limitsText(j)}</td></tr>`,
        )
        .join("")}</tbody>`;
    for (const row of this.el.querySelectorAll<HTMLElement>("tr[data-joint]")) {
      this.cells.set(row.dataset.joint!, {
        row,
        rad: row.querySelector<HTMLElement>("[data-testid=joint-rad]")!,
        deg: row.querySelector<HTMLElement>("[data-testid=joint-deg]")!,
      });
    }
  }

  /** The variables the readouts need from the stream. */
  variables(): string[] {
    return [...new Set(this.joints.map((j) => j.variable).filter((v): v is string => !!v))];
  }

  /** Shows the joints for these variable values (variable path → newest value). */
  update(values: Map<string, number>): void {
    for (const j of this.joints) {
      const c = this.cells.get(j.joint);
      if (!c || !j.variable || !values.has(j.variable)) continue;
      const p = jointPosition(j, values.get(j.variable));
      c.rad.textContent = isAngular(j) ? num(p) : `${num(p)} m`;
      c.deg.textContent = isAngular(j) ? num(degrees(p), 2) : "—";
      c.row.classList.toggle("bad", outsideLimits(j, p));
    }
  }
}
