"""What the drawings write: state and transition labels, and how wide a text is drawn (for box sizes)."""

from __future__ import annotations

import json
import unicodedata
from typing import Any

from .layout import inline_machine

_SKIP = {"type", "from", "to", "layout", "label", "description"}


def edge_label(tr: dict[str, Any]) -> str:
    """How a transition is labelled: its UML label, else its type and parameters."""
    label = tr.get("label")
    if isinstance(label, str) and label:
        return label
    params = _params(tr, plain=False)
    typ = str(tr.get("type", ""))
    return typ + (" " + ", ".join(params) if params else "")


def _params(tr: dict[str, Any], plain: bool) -> list[str]:
    """A transition's parameters as ``key=value`` (JSON but for strings); with ``plain``, no list or object."""
    return [f"{k}={v if isinstance(v, str) else json.dumps(v)}" for k, v in tr.items()
            if k not in _SKIP and not (plain and isinstance(v, (dict, list)))]


#: The widest an arrow's label is drawn (at ``LABEL_FONT``); a longer one is shortened (:func:`short_edge_label`).
LABEL_MAX_W = 240.0


def short_edge_label(tr: dict[str, Any], max_w: float = LABEL_MAX_W) -> str:
    """An arrow's label as the drawing writes it: :func:`edge_label` when it is at most ``max_w`` wide, else the
    event type with as many of its plain (not list or object) parameters as fit, in order, and an ellipsis; a
    UML label or a type too long for that is cut with an ellipsis. The full text goes into the label's hover
    title."""
    full = edge_label(tr)
    if text_width(full, LABEL_FONT) <= max_w:
        return full
    if not (isinstance(tr.get("label"), str) and tr["label"]):
        text = _typed_short(tr, max_w)
        if text_width(text, LABEL_FONT) <= max_w:
            return text
    return full[:_kept(full, max_w, LABEL_FONT)].rstrip() + "…"


def _typed_short(tr: dict[str, Any], max_w: float) -> str:
    """The event type with as many of its plain parameters as fit ``max_w`` (with the ellipsis), and an ellipsis."""
    typ = str(tr.get("type", ""))
    plain = _params(tr, plain=True)
    text = typ
    for i in range(len(plain)):
        longer = f"{typ} " + ", ".join(plain[:i + 1])
        if text_width(longer + ", …", LABEL_FONT) > max_w:
            break
        text = longer
    return text + (", …" if text != typ else " …")


def _kept(text: str, avail: float, size: float, bold: bool = False) -> int:
    """How many of ``text``'s characters fit ``avail`` with an ellipsis after them."""
    k = len(text)
    while k > 0 and text_width(text[:k] + "…", size, bold) > avail:
        k -= 1
    return k


def state_label(st: dict[str, Any]) -> str:
    typ = st.get("type")
    if typ == "Idle" or inline_machine(st) is not None:  # (an inline machine is an FSMState's)
        return str(st.get("id"))
    return f"{st.get('id')} ({typ})"


def sub_machines(st: dict[str, Any]) -> list[dict[str, Any]]:
    m = inline_machine(st)
    if m is not None:
        return [m]
    regions = st.get("regions")
    if st.get("type") == "Parallel" and isinstance(regions, list):
        return [r for r in regions if isinstance(r, dict) and isinstance(r.get("states"), list)]
    return []


#: Advance widths (1/100 em) of the printable ASCII characters (space .. ~) in DejaVu Sans, the widest of the
#: fonts the SVG names or falls back to; text measured with it fits when drawn in Helvetica or Arial too.
_WIDTHS = (
    32, 40, 46, 84, 64, 95, 78, 27, 39, 39, 50, 84, 32, 36, 32, 34, 64, 64, 64, 64, 64, 64, 64, 64, 64, 64, 34, 34,
    84, 84, 84, 53, 100, 68, 69, 70, 77, 63, 58, 77, 75, 29, 29, 66, 56, 86, 75, 79, 60, 79, 69, 63, 61, 73, 68, 99,
    69, 61, 69, 39, 34, 39, 84, 50, 50, 61, 63, 55, 63, 62, 35, 63, 63, 28, 28, 58, 28, 97, 63, 61, 63, 63, 41, 52,
    39, 63, 59, 82, 59, 59, 52, 64, 34, 64, 84,
)
FONT, LABEL_FONT, SMALL_FONT, MIN_FONT = 12, 11, 10, 8
BOX_MARGIN = 8  # text keeps this far from a box's left and right border
FINAL_ICON = 30  # a final state's box: room for the bull's eye at its left


def text_width(text: str, size: float, bold: bool = False) -> float:
    """An estimate (on the wide side) of how wide ``text`` is drawn at font size ``size``."""
    total = 0
    for ch in text:
        code = ord(ch)
        if 32 <= code < 127:
            total += _WIDTHS[code - 32]
        elif unicodedata.east_asian_width(ch) in ("W", "F"):
            total += 100
        else:
            base = unicodedata.normalize("NFKD", ch)[:1]
            total += _WIDTHS[ord(base) - 32] if base and 32 <= ord(base) < 127 else 84
    return total / 100 * size * (1.15 if bold else 1.0)


def final_text(st: dict[str, Any]) -> str:
    """A final state's text: ``id → outcome``, or the id alone when it is its outcome."""
    sid = str(st.get("id"))
    outcome = str(st.get("outcome", "succeeded"))
    return sid if outcome == sid else f"{sid} → {outcome}"


def fit(text: str, avail: float, size: float, bold: bool = False) -> tuple[str, float]:
    """``text`` at the largest size down to ``MIN_FONT`` that fits ``avail``; shortened with … if none does."""
    s = float(size)
    while s > MIN_FONT and text_width(text, s, bold) > avail:
        s -= 0.5
    if text_width(text, s, bold) <= avail:
        return text, s
    k = _kept(text, avail, s, bold)
    return (text[:k] + "…" if k else ""), s
