// format.ts -- numbers of the robot page: a joint's position from its variable (value · scale +
// offset, as the agent's view computes it), rad and degrees, limits, and HTML escaping.
import type { components } from "../api/schema";

export type RobotView = components["schemas"]["RobotView"];
export type RobotJoint = components["schemas"]["RobotJoint"];
export type JointMap = components["schemas"]["JointMap"];

/** Angular joints show rad and degrees; prismatic ones metres. */
export function isAngular(j: RobotJoint): boolean {
  return j.type !== "prismatic";
}

/** The joint's position from its variable's value; a joint without a variable is held at 0. */
export function jointPosition(j: RobotJoint, value: number | undefined): number {
  if (!j.variable || value === undefined) return 0;
  return value * j.scale + j.offset;
}

export function degrees(rad: number): number {
  return (rad * 180) / Math.PI;
}

export function num(x: number | null | undefined, digits = 4): string {
  if (x === null || x === undefined || !Number.isFinite(x)) return "—";
  return x.toFixed(digits);
}

/** "−170.0° … 170.0°" (or metres, or "none" for a continuous joint). */
export function limitsText(j: RobotJoint): string {
  if (j.lower === null || j.upper === null || j.lower === undefined || j.upper === undefined) return "none";
  return isAngular(j)
    ? `${degrees(j.lower).toFixed(1)}° … ${degrees(j.upper).toFixed(1)}°`
    : `${j.lower.toFixed(3)} … ${j.upper.toFixed(3)} m`;
}

export function outsideLimits(j: RobotJoint, position: number): boolean {
  return (
    (j.lower !== null && j.lower !== undefined && position < j.lower - 1e-9) ||
    (j.upper !== null && j.upper !== undefined && position > j.upper + 1e-9)
  );
}

export function escapeHtml(s: string): string {
  return s.replace(/[&<>"']/g, (c) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;", "'": "&#39;" })[c]!);
}
