// st_view.ts -- how the Programs page writes what the agent answered (pure, unit-tested): an error as
// stc prints it, and a unified diff's lines by kind for colouring.
import type { CheckError } from "./st_text";

/** `main.st:8:8: error[type]: cannot assign BOOL to DINT`, as stc and the upload panel print it. */
export function errorLine(e: CheckError): string {
  return `${e.file}:${e.line}:${e.column}: error[${e.code}]: ${e.message}`;
}

export type DiffKind = "added" | "removed" | "hunk" | "file" | "same";

/** A unified diff's lines with their kind ("+" added, "-" removed, "@@" a hunk, "---"/"+++" the files). */
export function diffLines(diff: string): { kind: DiffKind; text: string }[] {
  return diff
    .split("\n")
    .filter((l, i, all) => l !== "" || i < all.length - 1)
    .map((text) => {
      const kind: DiffKind =
        text.startsWith("+++") || text.startsWith("---")
          ? "file"
          : text.startsWith("@@")
            ? "hunk"
            : text.startsWith("+")
              ? "added"
              : text.startsWith("-")
                ? "removed"
                : "same";
      return { kind, text };
    });
}
