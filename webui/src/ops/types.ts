// types.ts -- the shapes of the answers the OpenAPI document leaves open (irpd's status, schedule
// and module records pass through the agent as they are; docs/control-protocol.md), and short
// names for the declared ones.
import type { components } from "../api/schema";

type S = components["schemas"];
export type HostLoad = S["HostLoad"];
export type EventsPage = S["EventsPage"];
export type AgentEvent = S["Event"];
export type ChangesReport = S["ChangesReport"];
export type ModuleChange = S["ModuleChange"];
export type SwapReport = S["SwapReport"];
export type SetSummary = S["SetSummary"];
export type SetPublic = S["SetPublic"];
export type Validation = S["Validation"];
export type VariableChanges = S["VariableChanges"];

/** GET /health (no token). */
export interface Health {
  agent: string;
  version?: string;
  irpd: string; // "ok" or "unreachable"
  running?: boolean;
  detail?: string;
}

/** GET /status: irpd's status. */
export interface Status {
  set: string | null;
  set_id: string | null;
  generation: number;
  running: boolean;
  realtime: boolean;
  pid: number;
  basic_period_ns: number;
  macro_period_ns: number;
  uptime_ns: number;
  cycles: number;
  modules: number;
  overruns: number;
  missed: number;
  skipped: number;
  caught_up: number;
  events: number;
  /** the minimum basic period irpd accepts (added by the agent) */
  min_basic_period_ns?: number;
  /** why a fault stopped the set (docs/faults.md), or null */
  stopped_by_fault?: string | null;
  /** the crash record irpd took in at start (docs/supervision.md), or null */
  last_crash?: {
    signal?: string;
    module?: string;
    executor?: string;
    time?: string;
    cause?: "fault" | "abort" | "watchdog" | "signal";
    sender_pid?: number | null;
  } | null;
  /** modules a crash left out of their set */
  left_out_after_crash?: { module: string; set: string }[];
  shared_memory?: Record<string, string>;
}

export type OperationType = "periodic" | "sporadic" | "non-real" | string;

/** A module as the slot table lists it. */
export interface ScheduleModule {
  name: string;
  moduletype: string;
  operationtype: OperationType;
  period_ns: number;
  deadline_ns: number;
  priority: number;
  executor: string;
}

export interface Slot {
  index: number;
  offset_ns: number;
  /** names, in run order (priority, then file order) */
  modules: string[];
}

/** GET /schedule: the paper's Table 3. */
export interface Schedule {
  basic_period_ns: number;
  macro_period_ns: number;
  slots: Slot[];
  modules: ScheduleModule[];
}

export interface Percentiles {
  count: number;
  min: number;
  max: number;
  mean: number;
  p50: number;
  p99: number;
  p999: number;
}

/** GET /modules: one module's stats record and its configuration. */
export interface ModuleInfo {
  name: string;
  executor: string;
  kind: string;
  period_ns: number;
  runs: number;
  jitter_ns: Percentiles;
  latency_ns: Percentiles;
  exec_ns: Percentiles;
  overruns: number;
  missed: number;
  skipped: number;
  errors: number;
  state: string;
  priority: number;
  budget_ns: number;
  moduletype: string;
  operationtype: OperationType;
  deadline_ns: number;
  enabled: boolean;
  file?: string;
  sha256?: string;
  properties?: Record<string, string>;
  last_error?: string;
}
