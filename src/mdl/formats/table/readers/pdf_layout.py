"""A PDF page's characters and ruled lines, read with pdfium (pypdfium2) in the shape pdfplumber's
table finder takes (its `chars` and `edges`), so that the finder never waits for pdfminer's parse of
the page in Python: a tenth of the time a page.

The page is seen as a reader sees it: turned by its /Rotate, with `top` measured down from the top of
its media box, as pdfminer and pdfplumber measure it.
- A character is one that the page draws (pdfium's generated spaces and line ends are not; a space a
  page draws is), with its box and whether it stands upright on the turned page.
- An edge is each straight, level or plumb segment of a path the page fills or strokes (a rule, a
  side of a cell's box), inside form XObjects too, as pdfminer cuts its paths into segments; curves
  and slanted segments draw no table.
"""

from __future__ import annotations

import ctypes
import math
from bisect import bisect_left
from collections.abc import Iterator
from typing import Any

Matrix = tuple[float, float, float, float, float, float]
_IDENTITY: Matrix = (1.0, 0.0, 0.0, 1.0, 0.0, 0.0)
_FORM_DEPTH = 8  # forms inside forms: deeper ones are not walked
_TOLERANCE = 3.0  # points: pdfplumber's x_tolerance and y_tolerance, within which characters are one word, one line
_SAMPLE = 200  # characters whose slant tells which way a page's text runs
_THIN = 2.0  # a path no wider (or taller) than this, in points, is a rule: one edge


def _then(m: Matrix, n: Matrix) -> Matrix:
    """`m` then `n` (PDF matrices, row vectors: p * m * n)."""
    a, b, c, d, e, f = m
    a2, b2, c2, d2, e2, f2 = n
    return (
        a * a2 + b * c2,
        a * b2 + b * d2,
        c * a2 + d * c2,
        c * b2 + d * d2,
        e * a2 + f * c2 + e2,
        e * b2 + f * d2 + f2,
    )


def _text_turn(page: Any, c: Any) -> int | None:
    """The quarter turns (clockwise) that stand most of the page's characters upright, or None for a
    page without text. A page is read the way its text runs: a sheet printed sideways onto a page
    (the Heidelberg wallbox's register table) reads as its text does, whatever the page's /Rotate
    says, and a page turned by its /Rotate to stand its text upright reads as it is shown."""
    text = c.FPDFText_LoadPage(page.raw)
    if not text:
        return None
    try:
        count = c.FPDFText_CountChars(text)
        votes = [0, 0, 0, 0]
        for i in range(0, count, max(1, count // _SAMPLE)):
            angle = c.FPDFText_GetCharAngle(text, i)  # radians, counter-clockwise on the unturned page
            if angle >= 0 and c.FPDFText_IsGenerated(text, i) != 1:
                votes[round(angle / (math.pi / 2)) % 4] += 1
    finally:
        c.FPDFText_ClosePage(text)
    if not any(votes):
        return None
    return votes.index(max(votes))


class Page:
    """One page: `chars`, `edges`, `bbox`, `height` as pdfplumber's Page gives them (the parts its
    TableFinder and utils.extract_text read)."""

    def __init__(self, page: Any) -> None:
        import pypdfium2.raw as pdfium_c  # type: ignore[import-untyped]

        self._c = pdfium_c
        self._page = page
        x0, y0, x1, y1 = (float(v) for v in page.get_mediabox())
        turn = _text_turn(page, pdfium_c)
        if turn is None:
            turn = int(pdfium_c.FPDFPage_GetRotation(page.raw)) % 4
        self._turn = turn
        # pdfminer's own matrix for a turned page, then y measured down from the top
        width, height = (y1 - y0, x1 - x0) if turn in (1, 3) else (x1 - x0, y1 - y0)
        ctm: Matrix = {
            0: (1.0, 0.0, 0.0, 1.0, -x0, -y0),
            1: (0.0, -1.0, 1.0, 0.0, -y0, x1),
            2: (-1.0, 0.0, 0.0, -1.0, x1, y1),
            3: (0.0, 1.0, -1.0, 0.0, y1, -x0),
        }[turn]
        self._ctm = _then(ctm, (1.0, 0.0, 0.0, -1.0, 0.0, height))
        self.width, self.height = width, height
        self.bbox = (0.0, 0.0, width, height)
        self._chars: list[dict[str, Any]] | None = None
        self._edges: list[dict[str, Any]] | None = None
        self._by_middle: tuple[list[dict[str, Any]], list[float]] | None = None

    @property
    def chars(self) -> list[dict[str, Any]]:
        if self._chars is None:
            self._chars = list(self._read_chars())
        return self._chars

    @property
    def edges(self) -> list[dict[str, Any]]:
        if self._edges is None:
            self._edges = list(self._segments())
        return self._edges

    def has_text(self) -> bool:
        """Whether the page draws any character (a scanned page draws none)."""
        c = self._c
        text = c.FPDFText_LoadPage(self._page.raw)
        if not text:
            return False
        try:
            return bool(c.FPDFText_CountChars(text) > 0)
        finally:
            c.FPDFText_ClosePage(text)

    def texts(self, table: Any) -> list[list[str | None]]:
        """The texts of a table's cells (pdfplumber's Table.extract: a character belongs to the cell over
        its middle; None where the grid has no cell), each row's characters found by bisection."""
        if self._by_middle is None:
            chars = sorted(self.chars, key=lambda ch: ch["top"] + ch["bottom"])
            self._by_middle = (chars, [ch["top"] + ch["bottom"] for ch in chars])
        chars, middles = self._by_middle
        out: list[list[str | None]] = []
        for row in table.rows:
            _, top, _, bottom = row.bbox
            on_row = chars[bisect_left(middles, 2 * top) : bisect_left(middles, 2 * bottom)]
            texts: list[str | None] = []
            for cell in row.cells:
                if cell is None:
                    texts.append(None)
                    continue
                x0, top, x1, bottom = cell
                inside = [
                    ch
                    for ch in on_row
                    if x0 <= (ch["x0"] + ch["x1"]) / 2 < x1 and 2 * top <= ch["top"] + ch["bottom"] < 2 * bottom
                ]
                texts.append(cell_text(inside))
            out.append(texts)
        return out

    def _read_chars(self) -> Iterator[dict[str, Any]]:
        c = self._c
        text = c.FPDFText_LoadPage(self._page.raw)
        if not text:
            return
        unicode, generated, loose, angle = (
            c.FPDFText_GetUnicode,
            c.FPDFText_IsGenerated,
            c.FPDFText_GetLooseCharBox,
            c.FPDFText_GetCharAngle,  # radians, counter-clockwise on the unturned page
        )
        a, b, cc, d, e, f = self._ctm
        turn = self._turn * math.pi / 2
        box = c.FS_RECTF()
        at = ctypes.byref(box)
        try:
            last: dict[str, Any] | None = None
            for i in range(c.FPDFText_CountChars(text)):
                code = unicode(text, i)
                if code in (0, 10, 13, 0xFFFE, 0xFFFF) or 0xD800 <= code <= 0xDFFF:
                    continue
                if generated(text, i) == 1:
                    # pdfium's own space between two words, where the page draws none (or one it
                    # folded into its own): a space on the line of the character before it
                    if code == 32 and last is not None and last["text"] != " ":
                        last = dict(last, text=" ", x0=last["x1"])
                        yield last
                    continue
                if not loose(text, i, at):
                    continue
                xa, ya = box.left * a + box.bottom * cc + e, box.left * b + box.bottom * d + f
                xb, yb = box.right * a + box.top * cc + e, box.right * b + box.top * d + f
                slant = angle(text, i)
                turned = (slant - turn) % (2 * math.pi) if slant >= 0 else 0.0
                top = ya if ya < yb else yb
                last = {
                    "text": "-" if code == 2 else chr(code),  # 2: pdfium's mark of a hyphen ending a line
                    "x0": xa if xa < xb else xb,
                    "x1": xb if xa < xb else xa,
                    "top": top,
                    "doctop": top,
                    "bottom": yb if ya < yb else ya,
                    "upright": turned < 0.1 or turned > 2 * math.pi - 0.1,
                }
                yield last
        finally:
            c.FPDFText_ClosePage(text)

    def _objects(self) -> Iterator[tuple[Any, Matrix]]:
        """The page's path objects, inside forms too (to _FORM_DEPTH), each with the matrix of the forms
        around it."""
        c = self._c
        path, form = c.FPDF_PAGEOBJ_PATH, c.FPDF_PAGEOBJ_FORM
        get_type = c.FPDFPageObj_GetType
        page = self._page.raw
        fs = c.FS_MATRIX()
        walks: list[tuple[Any, Matrix, int]] = [(None, _IDENTITY, 0)]  # (form or None: the page, matrix, depth)
        while walks:
            holder, outer, depth = walks.pop()
            count = c.FPDFPage_CountObjects(page) if holder is None else c.FPDFFormObj_CountObjects(holder)
            for i in range(count):
                obj = c.FPDFPage_GetObject(page, i) if holder is None else c.FPDFFormObj_GetObject(holder, i)
                kind = get_type(obj)
                if kind == path:
                    yield obj, outer
                elif kind == form and depth < _FORM_DEPTH and c.FPDFPageObj_GetMatrix(obj, ctypes.byref(fs)):
                    walks.append((obj, _then((fs.a, fs.b, fs.c, fs.d, fs.e, fs.f), outer), depth + 1))

    def _segments(self) -> Iterator[dict[str, Any]]:
        """Each painted path's level and plumb segments. Most rules are paths no wider or taller than a
        line (a thin filled box, a stroked line): their box, in the space of the forms around them, is
        the edge, read in one call; other paths segment by segment."""
        c = self._c
        draw_mode, get_bounds = c.FPDFPath_GetDrawMode, c.FPDFPageObj_GetBounds
        fill, stroke = ctypes.c_int(), ctypes.c_int()
        modes = (ctypes.byref(fill), ctypes.byref(stroke))
        bounds = [ctypes.c_float() for _ in range(4)]
        box = tuple(ctypes.byref(v) for v in bounds)
        fs = c.FS_MATRIX()
        outer_seen: Matrix | None = None
        a = b = cc = d = e = f = 0.0
        for obj, outer in self._objects():
            if not draw_mode(obj, *modes) or (fill.value == 0 and not stroke.value):  # paints nothing
                continue
            if not get_bounds(obj, *box):
                continue
            if outer is not outer_seen:
                a, b, cc, d, e, f = _then(outer, self._ctm)
                outer_seen = outer
            left, bottom, right, top = (v.value for v in bounds)
            corners = ((left, bottom), (left, top), (right, bottom), (right, top))
            xs = [x * a + y * cc + e for x, y in corners]
            ys = [x * b + y * d + f for x, y in corners]
            x0, x1, y0, y1 = min(xs), max(xs), min(ys), max(ys)
            if x1 - x0 < _THIN and y1 - y0 < _THIN:
                continue  # a dot
            if x1 - x0 < _THIN:
                yield from _edge(((x0 + x1) / 2, y0), ((x0 + x1) / 2, y1))
            elif y1 - y0 < _THIN:
                yield from _edge((x0, (y0 + y1) / 2), (x1, (y0 + y1) / 2))
            elif c.FPDFPageObj_GetMatrix(obj, ctypes.byref(fs)):
                m = _then((fs.a, fs.b, fs.c, fs.d, fs.e, fs.f), outer)
                yield from self._path_edges(obj, _then(m, self._ctm))

    def _path_edges(self, obj: Any, m: Matrix) -> Iterator[dict[str, Any]]:
        c = self._c
        get, point, kind, closes = (
            c.FPDFPath_GetPathSegment,
            c.FPDFPathSegment_GetPoint,
            c.FPDFPathSegment_GetType,
            c.FPDFPathSegment_GetClose,
        )
        moveto = c.FPDF_SEGMENT_MOVETO
        a, b, cc, d, e, f = m
        x, y = ctypes.c_float(), ctypes.c_float()
        xy = (ctypes.byref(x), ctypes.byref(y))
        start: tuple[float, float] | None = None
        at: tuple[float, float] | None = None
        for k in range(c.FPDFPath_CountSegments(obj)):
            segment = get(obj, k)
            if not segment or not point(segment, *xy):
                continue
            here = (x.value * a + y.value * cc + e, x.value * b + y.value * d + f)
            if at is None or kind(segment) == moveto:
                start = at = here
                continue
            yield from _edge(at, here)
            at = here
            if closes(segment) and start is not None:
                yield from _edge(at, start)
                at = start


def _edge(p: tuple[float, float], q: tuple[float, float]) -> Iterator[dict[str, Any]]:
    """The segment p-q as an edge if it is level or plumb (within a hundredth of a point)."""
    (xa, ya), (xb, yb) = p, q
    if abs(ya - yb) < 0.01:
        orientation = "h"
        ya = yb = (ya + yb) / 2
    elif abs(xa - xb) < 0.01:
        orientation = "v"
        xa = xb = (xa + xb) / 2
    else:
        return
    x0, x1, top, bottom = min(xa, xb), max(xa, xb), min(ya, yb), max(ya, yb)
    yield {
        "object_type": "line",
        "x0": x0,
        "x1": x1,
        "top": top,
        "bottom": bottom,
        "width": x1 - x0,
        "height": bottom - top,
        "orientation": orientation,
    }


def cell_text(chars: list[dict[str, Any]]) -> str:
    """A cell's text as pdfplumber's extract_text gives it: characters whose tops lie within 3 points
    of each other (in a chain) are a line, read left to right; a space, a gap of more than 3 points
    or a step back starts a new word; words are joined by a space and lines by a line end; a mark set
    small above the line follows a caret (`High^5`). Characters that do not stand upright are read the
    same way along the page."""
    out: list[str] = []
    line: list[dict[str, Any]] = []
    last_top = -1e9
    for ch in sorted(chars, key=_top):
        if line and ch["top"] > last_top + _TOLERANCE:
            out.append(_line_text(line))
            line = []
        line.append(ch)
        last_top = ch["top"]
    if line:
        out.append(_line_text(line))
    return "\n".join(text for text in out if text)


def _top(ch: dict[str, Any]) -> float:
    return float(ch["top"])


def _line_text(chars: list[dict[str, Any]]) -> str:
    height = max(ch["bottom"] - ch["top"] for ch in chars)
    base = max(ch["bottom"] for ch in chars)
    words: list[str] = []
    word = ""
    before: dict[str, Any] | None = None
    raised = False
    for ch in sorted(chars, key=lambda ch: ch["x0"]):
        if ch["text"].isspace():
            if word:
                words.append(word)
            word, before, raised = "", None, False
            continue
        if before is not None and (ch["x0"] > before["x1"] + _TOLERANCE or ch["x0"] < before["x0"]):
            words.append(word)
            word, raised = "", False
        # a smaller character set above the line (a footnote mark, an exponent) is written after a caret:
        # `Sensor ID High^5`, `2^16`; run into the word it would make another word (`High5`)
        superscript = ch["bottom"] - ch["top"] < 0.75 * height and ch["bottom"] < base - 0.25 * height
        if superscript and not raised and word:
            word += "^"
        raised = superscript
        word += ch["text"]
        before = ch
    if word:
        words.append(word)
    return " ".join(words)
