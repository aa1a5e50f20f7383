// shared_projects.ts -- where the shared PLCopen projects (real files drawn in other tools) are read in
// place, found as tests/python/plcopen/plcopen_live.py finds them: $INDUROP_SHARED_PLCOPEN, else
// ../shared/plcopen beside the repository, beside its main checkout (a git worktree), or beside the
// checkout it was cloned from (a fresh clone of a local checkout, as the CI's).
import { execFileSync } from "node:child_process";
import { existsSync } from "node:fs";
import { dirname, resolve } from "node:path";
import { ROOT } from "./server";

function git(...args: string[]): string {
  try {
    return execFileSync("git", ["-C", ROOT, ...args], { encoding: "utf8", stdio: ["ignore", "pipe", "ignore"] }).trim();
  } catch {
    return "";
  }
}

function find(): string | undefined {
  const named = process.env.INDUROP_SHARED_PLCOPEN;
  if (named) return existsSync(named) ? named : undefined;
  const candidates = [resolve(ROOT, "../shared/plcopen")];
  const common = git("rev-parse", "--path-format=absolute", "--git-common-dir");
  if (common) candidates.push(resolve(dirname(dirname(common)), "shared/plcopen"));
  const origin = git("remote", "get-url", "origin").replace(/^file:\/\//, "");
  if (origin.startsWith("/")) candidates.push(resolve(dirname(resolve(origin)), "shared/plcopen"));
  return candidates.find((c) => existsSync(c));
}

export const SHARED_PLCOPEN = find();
export const NOT_SHARED =
  "the shared PLCopen projects are not there ($INDUROP_SHARED_PLCOPEN, or ../shared/plcopen beside the repository or the checkout it was cloned from)";
