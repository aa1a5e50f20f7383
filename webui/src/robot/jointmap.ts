// jointmap.ts -- the admin's editor of the joint map (robot.json): per joint a variable (with the
// running layout's variables to pick from), a scale and an offset; saving sends PUT /robot/joints,
// which stores and activates a new version of the running set.
import { escapeHtml, type JointMap, type RobotJoint } from "./format";

/** The map as the form holds it, or the first thing to fix (the agent checks the rest). */
export function readJointMap(form: HTMLElement): { joints: JointMap[] } | { error: string } {
  const joints: JointMap[] = [];
  for (const row of form.querySelectorAll<HTMLElement>("tr[data-joint]")) {
    const joint = row.dataset.joint!;
    const variable = row.querySelector<HTMLInputElement>("input[name=variable]")!.value.trim();
    const scaleText = row.querySelector<HTMLInputElement>("input[name=scale]")!.value.trim();
    const offsetText = row.querySelector<HTMLInputElement>("input[name=offset]")!.value.trim();
    const scale = scaleText === "" ? 1 : Number(scaleText);
    const offset = offsetText === "" ? 0 : Number(offsetText);
    if (!Number.isFinite(scale)) return { error: `${joint}: the scale "${scaleText}" is not a number` };
    if (!Number.isFinite(offset)) return { error: `${joint}: the offset "${offsetText}" is not a number` };
    joints.push({ joint, variable: variable === "" ? null : variable, scale, offset });
  }
  return { joints };
}

/** The editor's form; `variables` are the layout's paths offered in the variable fields. */
export function jointMapForm(joints: RobotJoint[], variables: string[]): HTMLFormElement {
  const form = document.createElement("form");
  form.dataset.testid = "joint-map";
  form.className = "robot-jointmap";
  form.innerHTML = `
    <h3>Joint map</h3>
    <p class="muted">Which shared variable drives each joint: position = value × scale + offset.
      Saving stores a new version of the running set and activates it (every module is kept).</p>
    <datalist id="robot-variables">${variables.map((v) => `<option value="${escapeHtml(v)}"></option>`).join("")}</datalist>
    <table>
      <thead><tr><th>joint</th><th>variable</th><th>scale</th><th>offset</th></tr></thead>
      <tbody>${joints
        .map(
          (j) => `<tr data-joint="${escapeHtml(j.joint)}">
            <td>${escapeHtml(j.joint)}</td>
            <td><input name="variable" list="robot-variables" size="44" placeholder="none: held at 0"
              data-testid="joint-map-variable" value="${escapeHtml(j.variable ?? "")}"></td>
            <td><input name="scale" type="text" inputmode="decimal" size="6" data-testid="joint-map-scale"
              value="${j.scale}"></td>
            <td><input name="offset" type="text" inputmode="decimal" size="6" data-testid="joint-map-offset"
              value="${j.offset}"></td></tr>`,
        )
        .join("")}</tbody>
    </table>
    <div class="robot-actions">
      <button type="submit" data-testid="joint-map-save">Save joint map</button>
      <span data-testid="joint-map-error" class="bad" role="alert"></span>
    </div>`;
  return form;
}
