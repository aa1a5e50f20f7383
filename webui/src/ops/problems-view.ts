// problems-view.ts -- a set's validation errors as a list: each with its place (file:line:column,
// module, field), read from the fields irpd gives it, then its message.
import { type Place, placeText } from "../api/place";
import { h } from "./dom";
import type { Validation } from "./types";

export function problemList(v: Pick<Validation, "errors" | "problems">): HTMLElement {
  // A set stored before validations kept problems has its errors only.
  const problems: (Place & { message: string })[] = v.problems?.length
    ? v.problems
    : v.errors.map((message) => ({ message }));
  return h(
    "ul",
    { class: "ops-issues" },
    ...problems.map((p) => {
      const where = placeText(p);
      return h(
        "li",
        { class: "bad", "data-testid": "problem" },
        where ? h("span", { class: "mono", "data-testid": "problem-where" }, `${where}: `) : null,
        h("span", { class: "mono" }, p.message),
      );
    }),
  );
}
