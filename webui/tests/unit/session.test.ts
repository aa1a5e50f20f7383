// session.test.ts -- what the API client adds to a request signed in by the session cookie: the
// CSRF token on changes only, and the background mark once the user has been away.
import { describe, expect, it } from "vitest";
import { AWAY_AFTER_MS, isChange, sessionHeaders, userAway, watchPresence } from "../../src/api/client";

describe("the session's headers", () => {
  it("carry the CSRF token on every change and on nothing else", () => {
    for (const m of ["POST", "PUT", "PATCH", "DELETE", "post"])
      expect(sessionHeaders(m, "c", false)).toEqual({ "X-CSRF-Token": "c" });
    for (const m of ["GET", "HEAD", "OPTIONS"]) expect(sessionHeaders(m, "c", false)).toEqual({});
    expect(isChange("GET")).toBe(false);
  });

  it("mark the UI's own requests once the user has not touched the page for a while", () => {
    expect(sessionHeaders("GET", "c", true)).toEqual({ "X-Indurop-Background": "1" });
    const target = document.createElement("div");
    watchPresence(target);
    target.dispatchEvent(new Event("keydown"));
    const now = Date.now();
    expect(userAway(now)).toBe(false);
    expect(userAway(now + AWAY_AFTER_MS + 1)).toBe(true);
    target.dispatchEvent(new Event("pointerdown"));
    expect(userAway(Date.now() + AWAY_AFTER_MS - 1000)).toBe(false);
  });
});
