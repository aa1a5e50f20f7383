// st_view.ts -- how the Programs page writes a unified diff (pure, unit-tested): its lines by kind
// for colouring.  (The check's errors are listed by ops/problems-view.ts, as an upload's are.)

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
