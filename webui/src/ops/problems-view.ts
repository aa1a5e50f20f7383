// problems-view.ts -- a set's validation errors, or an upload's ST compile errors, as a list: each
// with its place (file:line:column, module, field), read from the fields given, its code, its message.
import { type Place, placeText } from "../api/place";
import { h } from "./dom";

/** An error with its place, and the ST compiler's code when it has one (`type`, `syntax`, ...). */
export type PlacedProblem = Place & { message: string; code?: string | null };

export function problemList(v: { errors: string[]; problems?: PlacedProblem[] | null }): HTMLElement {
  // A set stored before validations kept problems has its errors only.
  const problems: PlacedProblem[] = v.problems?.length ? v.problems : v.errors.map((message) => ({ message }));
  return h(
    "ul",
    { class: "ops-issues" },
    ...problems.map((p) => {
      const where = placeText(p);
      return h(
        "li",
        { class: "bad", "data-testid": "problem" },
        where ? h("span", { class: "mono", "data-testid": "problem-where" }, `${where}: `) : null,
        p.code ? h("span", { class: "mono", "data-testid": "problem-code" }, `error[${p.code}]: `) : null,
        h("span", { class: "mono" }, p.message),
      );
    }),
  );
}
