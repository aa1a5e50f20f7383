# lexer.py -- .glb text -> tokens.  Line ends are tokens (NEWLINE), because a declaration may
# end at the end of its line; `//` and `/* */` comments are dropped (a block comment that spans
# lines counts as a line end).

from __future__ import annotations

from dataclasses import dataclass

from .errors import GlbError, Loc, Source

IDENT, NUMBER, PUNCT, NEWLINE, EOF = "identifier", "number", "punctuation", "end of line", "end of file"

# Punctuation the parser knows, longest first.  Other printable characters are refused here.
PUNCTUATION = ("::", ";", "{", "}", "[", "]", ".", "#", "-", "+", ",", "=", "(", ")", "*", ":", "<", ">", "&")


@dataclass(frozen=True)
class Token:
    kind: str
    text: str
    loc: Loc

    @property
    def end(self) -> Loc:
        """The position just after this token (where a missing `;` would go)."""
        return Loc(self.loc.source, self.loc.line, self.loc.col + len(self.text))

    def describe(self) -> str:
        """How an error message names this token: `'short'`, `end of line`."""
        if self.kind in (NEWLINE, EOF):
            return self.kind
        return f"'{self.text}'"

    def is_punct(self, text: str) -> bool:
        return self.kind == PUNCT and self.text == text

    def is_word(self, text: str) -> bool:
        return self.kind == IDENT and self.text == text


def _is_ident_start(c: str) -> bool:
    return c == "_" or ("a" <= c <= "z") or ("A" <= c <= "Z")


def _is_ident_char(c: str) -> bool:
    return _is_ident_start(c) or ("0" <= c <= "9")


def tokenize(src: Source) -> list[Token]:
    text = src.text
    tokens: list[Token] = []
    i, line, line_start = 0, 1, 0
    n = len(text)
    if text.startswith("\ufeff"):  # a UTF-8 byte order mark
        i = line_start = 1

    def loc(at: int, length: int = 1) -> Loc:
        return Loc(src, line, at - line_start + 1, length)

    while i < n:
        c = text[i]
        if c == "\n":
            tokens.append(Token(NEWLINE, "\n", loc(i)))
            i += 1
            line, line_start = line + 1, i
        elif c in " \t\r\f\v":
            i += 1
        elif text.startswith("//", i):
            while i < n and text[i] != "\n":
                i += 1
        elif text.startswith("/*", i):
            opened = loc(i, 2)
            close = text.find("*/", i + 2)
            if close < 0:
                raise GlbError("unterminated /* comment: expected '*/' before the end of the file", opened)
            newlines = text.count("\n", i, close)
            if newlines:
                # The comment ends the line it started on, as if it were a line end.
                tokens.append(Token(NEWLINE, "\n", loc(i)))
                line += newlines
                line_start = text.rfind("\n", i, close) + 1
            i = close + 2
        elif _is_ident_start(c):
            j = i + 1
            while j < n and _is_ident_char(text[j]):
                j += 1
            tokens.append(Token(IDENT, text[i:j], loc(i, j - i)))
            i = j
        elif "0" <= c <= "9":
            # A C preprocessing number: digits, letters, '_' and '.' (so `1.5` and `9lives` are one
            # token, refused by the parser with a clear message).
            j = i + 1
            while j < n and (_is_ident_char(text[j]) or text[j] == "."):
                j += 1
            tokens.append(Token(NUMBER, text[i:j], loc(i, j - i)))
            i = j
        else:
            for p in PUNCTUATION:
                if text.startswith(p, i):
                    tokens.append(Token(PUNCT, p, loc(i, len(p))))
                    i += len(p)
                    break
            else:
                shown = c if c.isprintable() else f"U+{ord(c):04X}"
                raise GlbError(
                    f"unexpected character '{shown}': expected a declaration, a comment or a #define", loc(i)
                )
    # End of file: just after the last visible token (or 1:1 in a file without one), which is
    # where a missing `}` or name is best shown.
    last = next((t for t in reversed(tokens) if t.kind != NEWLINE), None)
    tokens.append(Token(EOF, "", last.end if last else Loc(src, 1, 1)))
    return tokens
