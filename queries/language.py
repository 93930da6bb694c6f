"""The query language: a small SQL-like text compiled to library calls.

    SELECT ditch FROM v2020 WHERE bbox(500000, 5500000, 500400, 5500400) AND length > 20 AT LEVEL 2
    SELECT tiles FROM v2020 WHERE category IN (10, 16, 22)
    SELECT changes FROM v2020 TO v2024 WHERE bbox(...) AND kind = 'ditch dug' AT LEVEL 2
    SELECT ditch FROM v2020 WHERE depth > 0.5 ORDER BY length DESC LIMIT 10

Names may be quoted ("2020") when they are not plain words; text values take single
quotes ('ditch dug'), as in SQL. Errors carry line and column with a caret. Values
reach the database only as bound parameters.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

from tdb.errors import QueryError
from tdb.tiles import LEVELS

TOKEN = re.compile(
    r"""(?P<ws>\s+)|(?P<number>-?\d+(?:\.\d*)?(?:[eE][-+]?\d+)?)|(?P<name>[A-Za-z_][A-Za-z0-9_]*)"""
    r"""|(?P<string>"[^"\n]*")|(?P<text>'[^'\n]*')|(?P<op><=|>=|!=|=|<|>)|(?P<punct>[(),])"""
)
KEYWORDS = {
    *("select", "from", "to", "where", "and", "at", "level", "in", "bbox", "category"),
    *("order", "by", "asc", "desc", "limit", "within"),
}
NEAR_KINDS = ("trees", "buildings")  # what a result may be required to lie within a distance of
ATTRIBUTES = {"length", "tiles", "depth", "height", "shoulder", "width", "area", "dz", "lod", "crown_diameter"}
TEXT_ATTRIBUTES = {"kind", "description"}


@dataclass
class Condition:
    attribute: str
    op: str  # a comparison, or "in" (value: a tuple of texts)
    value: float | str | tuple[str, ...]


@dataclass(frozen=True)
class Near:
    """``within(distance, kind)``: a result lies within ``distance`` m of a tree or building."""

    kind: str
    distance: float


@dataclass
class Query:
    what: str
    version: str
    to_versions: list[str] = field(default_factory=list)  # SELECT changes FROM a TO b [TO c …]
    bbox: tuple[float, float, float, float] | None = None
    categories: list[int] | None = None
    conditions: list[Condition] = field(default_factory=list)
    near: list[Near] = field(default_factory=list)
    level: int | None = None
    order_by: str | None = None
    descending: bool = False
    limit: int | None = None

    @property
    def to_version(self) -> str | None:
        """The first version after ``FROM``'s, if any."""
        return self.to_versions[0] if self.to_versions else None


@dataclass(frozen=True)
class Token:
    kind: str
    text: str
    pos: int


def _quoting_hint(before: list[Token], text: str, pos: int) -> str:
    """Where the character at ``pos`` interrupts a version's name after FROM or TO (a name such
    as ``survey-2020``), how to write the name."""
    if len(before) < 2 or before[-2].kind != "kw" or before[-2].text not in ("from", "to"):
        return ""
    name = before[-1]
    if name.kind not in ("name", "number") or name.pos + len(name.text) != pos:
        return ""
    return _quoted(before[-2].text, text, name.pos)


def _quoted(keyword: str, text: str, start: int) -> str:
    """The hint that the version name starting at ``start`` is written in double quotes."""
    whole = text[start:].split()[0]
    return f' (a version name holding it is written in double quotes: {keyword.upper()} "{whole}")'


def tokenize(text: str) -> list[Token]:
    out: list[Token] = []
    pos = 0
    while pos < len(text):
        m = TOKEN.match(text, pos)
        if not m:
            raise QueryError(
                f"unexpected character {text[pos]!r}{_quoting_hint(out, text, pos)}", text=text, position=pos
            )
        kind = m.lastgroup or ""
        if kind != "ws":
            value = m.group()
            if kind == "name" and value.lower() in KEYWORDS:
                kind, value = "kw", value.lower()
            elif kind == "string":
                kind, value = "name", value[1:-1]
            elif kind == "text":
                value = value[1:-1]
            out.append(Token(kind, value, pos))
        pos = m.end()
    out.append(Token("end", "", len(text)))
    return out


class _Parser:
    def __init__(self, text: str):
        self.text = text
        self.tokens = tokenize(text)
        self.i = 0

    def peek(self) -> Token:
        return self.tokens[self.i]

    def error(self, message: str, tok: Token | None = None) -> QueryError:
        t = tok or self.peek()
        return QueryError(
            f"{message}, found {t.text!r}" if t.text else f"{message}, found end of query",
            text=self.text,
            position=t.pos,
        )

    def expect(self, kind: str, text: str | None = None) -> Token:
        t = self.peek()
        if t.kind != kind or (text is not None and t.text != text):
            raise self.error(f"expected {text or kind}")
        self.i += 1
        return t

    def accept(self, kind: str, text: str | None = None) -> Token | None:
        t = self.peek()
        if t.kind == kind and (text is None or t.text == text):
            self.i += 1
            return t
        return None

    def number(self) -> float:
        return float(self.expect("number").text)

    def parse(self) -> Query:
        """query := SELECT name FROM version [TO version] [WHERE cond {AND cond}] [AT LEVEL n]
        [ORDER BY attr [ASC|DESC]] [LIMIT n]"""
        self.expect("kw", "select")
        what = self.expect("name").text.lower()
        self.expect("kw", "from")
        q = Query(what, self.version())
        while self.accept("kw", "to"):
            q.to_versions.append(self.version())
        if self.accept("kw", "where"):
            self.condition(q)
            while self.accept("kw", "and"):
                self.condition(q)
        if self.accept("kw", "at"):
            self.level(q)
        if self.accept("kw", "order"):
            self.order(q)
        if self.accept("kw", "limit"):
            self.limit(q)
        self.expect("end")
        return q

    def level(self, q: Query) -> None:
        self.expect("kw", "level")
        tok = self.peek()
        level = self.number()
        if level not in LEVELS:
            raise self.error(f"level must be one of {', '.join(map(str, LEVELS))}", tok)
        q.level = int(level)

    def order(self, q: Query) -> None:
        self.expect("kw", "by")
        t = self.peek()
        if t.kind == "name" or (t.kind == "kw" and t.text == "category"):
            self.i += 1
        else:
            raise self.error("expected an attribute to order by")
        q.order_by = t.text.lower()
        if self.accept("kw", "desc"):
            q.descending = True
        else:
            self.accept("kw", "asc")

    def limit(self, q: Query) -> None:
        tok = self.peek()
        count = self.number()
        if count != int(count) or count < 0:
            raise self.error("LIMIT takes a whole number", tok)
        q.limit = int(count)

    def version(self) -> str:
        t = self.peek()
        if t.kind in ("name", "number"):
            self.i += 1
            after = self.peek()
            if after.kind != "end" and after.pos == t.pos + len(t.text):  # a name such as survey-2020
                keyword = self.tokens[self.i - 2].text
                raise QueryError(
                    f"unexpected {after.text!r} in a version name{_quoted(keyword, self.text, t.pos)}",
                    text=self.text,
                    position=after.pos,
                )
            return t.text
        raise self.error("expected a version name")

    def condition(self, q: Query) -> None:
        """cond := bbox(x0, y0, x1, y1) | category IN (n, …) | attr op number | text-attr (= | !=) 'text'
        | text-attr IN ('text', …) | within(distance, trees|buildings)"""
        t = self.peek()
        if self.accept("kw", "bbox"):
            self.bbox(q, t)
        elif self.accept("kw", "within"):
            self.within(q, t)
        elif self.accept("kw", "category"):
            self.categories(q, t)
        elif t.kind == "name" and t.text.lower() in ATTRIBUTES:
            self.i += 1
            op = self.expect("op").text
            q.conditions.append(Condition(t.text.lower(), op, self.number()))
        elif t.kind == "name" and t.text.lower() in TEXT_ATTRIBUTES:
            self.i += 1
            self.text_condition(q, t.text.lower())
        else:
            names = ", ".join(sorted(ATTRIBUTES | TEXT_ATTRIBUTES))
            raise self.error(f"expected bbox(...), category IN (...), within(...) or one of {names}")

    def numbers(self) -> list[float]:
        """( n {, n} )"""
        self.expect("punct", "(")
        values = [self.number()]
        while self.accept("punct", ","):
            values.append(self.number())
        self.expect("punct", ")")
        return values

    def bbox(self, q: Query, at: Token) -> None:
        vals = self.numbers()
        if len(vals) != 4:
            raise self.error("bbox takes four numbers: x0, y0, x1, y1", at)
        if not (vals[2] > vals[0] and vals[3] > vals[1]):
            raise self.error("bbox needs x0 < x1 and y0 < y1", at)
        q.bbox = (vals[0], vals[1], vals[2], vals[3])

    def within(self, q: Query, at: Token) -> None:
        self.expect("punct", "(")
        distance = self.number()
        if not (distance >= 0 and distance < float("inf")):
            raise self.error("within takes a distance of 0 m or more", at)
        self.expect("punct", ",")
        kind = self.peek()
        if kind.kind != "name" or kind.text.lower() not in NEAR_KINDS:
            raise self.error(f"within(distance, kind): kind is one of {', '.join(NEAR_KINDS)}", kind)
        self.i += 1
        self.expect("punct", ")")
        q.near.append(Near(kind.text.lower(), distance))

    def categories(self, q: Query, at: Token) -> None:
        self.expect("kw", "in")
        codes = self.numbers()
        if any(c != int(c) or not 0 <= c <= 255 for c in codes):
            raise self.error("category codes are whole numbers 0..255", at)
        q.categories = [int(c) for c in codes]

    def text_condition(self, q: Query, attribute: str) -> None:
        if self.accept("kw", "in"):
            self.expect("punct", "(")
            texts = [self.expect("text").text]
            while self.accept("punct", ","):
                texts.append(self.expect("text").text)
            self.expect("punct", ")")
            q.conditions.append(Condition(attribute, "in", tuple(texts)))
            return
        compare = self.peek()
        if not self.accept("op", "=") and not self.accept("op", "!="):
            raise self.error("text compares with =, != or IN (...)", compare)
        q.conditions.append(Condition(attribute, compare.text, self.expect("text").text))


def parse(text: str) -> Query:
    """Parse a query; raise :class:`QueryError` (with line, column and caret) on any error."""
    if not isinstance(text, str):
        raise QueryError("a query is text")
    return _Parser(text).parse()
