"""HTML of the session report: number formatting, tables, embedded figures, the page.

The page is self-contained: inline CSS, figures as base64 PNG, no script, no
link to anything outside the page.
"""

from __future__ import annotations

import base64
import csv
import html
import json
import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, SupportsFloat, SupportsIndex, SupportsInt

import numpy as np
import numpy.typing as npt

if TYPE_CHECKING:
    from tribo_bringup.report.provenance import Provenance

FloatArray = npt.NDArray[np.float64]


def fmt(x: object, digits: int = 4) -> str:
    """Format a number with ``digits`` significant digits ('n/a' for None/NaN)."""
    if x is None:
        return 'n/a'
    if isinstance(x, bool):
        return 'yes' if x else 'no'
    if isinstance(x, int):
        return str(x)
    if isinstance(x, float):
        if not math.isfinite(x):
            return 'n/a'
        return f'{x:.{digits}g}'
    return str(x)


def as_float(x: object) -> float:
    """Return a JSON number as float.

    Raises
    ------
    TypeError
        ``x`` is no number (as ``float()`` raises it, e.g. for None).
    """
    if isinstance(x, str | SupportsFloat | SupportsIndex):
        return float(x)
    raise TypeError(f'expected a number, got {type(x).__name__}')


def as_opt_float(x: object) -> float | None:
    """Return a JSON number as float, None as None (see :func:`as_float`)."""
    return None if x is None else as_float(x)


def as_int(x: object) -> int:
    """Return a JSON integer as int.

    Raises
    ------
    TypeError
        ``x`` is no integer (as ``int()`` raises it, e.g. for None).
    """
    if isinstance(x, str | SupportsInt | SupportsIndex):
        return int(x)
    raise TypeError(f'expected an integer, got {type(x).__name__}')


def as_mapping(x: object) -> Mapping[str, object]:
    """Return a JSON object (a mapping) as such.

    Raises
    ------
    TypeError
        ``x`` is no mapping.
    """
    if isinstance(x, Mapping):
        return x
    raise TypeError(f'expected a mapping, got {type(x).__name__}')


def as_list(x: object) -> list[object]:
    """Return a JSON array (list or tuple) as a list.

    Raises
    ------
    TypeError
        ``x`` is no list or tuple.
    """
    if isinstance(x, list | tuple):
        return list(x)
    raise TypeError(f'expected a list, got {type(x).__name__}')


def finite(values: Iterable[float | None]) -> FloatArray:
    """Return the finite values of ``values`` (None and NaN dropped) as an array."""
    arr = np.array([np.nan if v is None else float(v) for v in values], dtype=np.float64)
    return arr[np.isfinite(arr)]


def clean_json(obj: object) -> object:
    """Strict-JSON copy: NaN/inf -> None, numpy scalars -> Python, tuples -> lists."""
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, Mapping):
        return {str(k): clean_json(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [clean_json(v) for v in obj]
    if isinstance(obj, np.generic):
        return clean_json(obj.item())
    return obj


def figure(draw: Callable[[Path], object], path: Path, caption: str) -> str:
    """Draw a figure into ``path`` (PNG) and embed it; a failing figure becomes a note."""
    try:
        draw(path)
        b64 = base64.b64encode(path.read_bytes()).decode('ascii')
    except Exception as exc:  # a figure never takes the report down
        why = html.escape(f'{type(exc).__name__}: {exc}')
        return f'<p class="na">Figure {html.escape(path.name)} unavailable: {why}</p>'
    return img(b64, caption)


def embed_png(path: Path, caption: str) -> str:
    """Embed an existing PNG file with its caption."""
    return img(base64.b64encode(path.read_bytes()).decode('ascii'), caption)


def img(b64: str, caption: str) -> str:
    """Wrap a base64 PNG in a figure with caption."""
    return (
        f'<figure><img alt="{html.escape(caption)}" src="data:image/png;base64,{b64}">'
        f'<figcaption>{html.escape(caption)}</figcaption></figure>'
    )


def table(
    rows: Sequence[Sequence[object]], header: Sequence[str], table_id: str = '', digits: int = 4
) -> str:
    """Render an HTML table; numbers formatted by :func:`fmt`."""
    tid = f' id="{table_id}"' if table_id else ''
    head = ''.join(f'<th>{html.escape(h)}</th>' for h in header)
    body = ''.join(
        '<tr>' + ''.join(f'<td>{html.escape(fmt(v, digits))}</td>' for v in row) + '</tr>'
        for row in rows
    )
    return f'<table{tid}><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>'


def kv(items: Mapping[str, object], table_id: str, units: Mapping[str, str] | None = None) -> str:
    """Render a key / value / unit table."""
    rows = []
    for k, v in items.items():
        unit = (units or {}).get(k, '')
        rows.append(
            f'<tr><th>{html.escape(k)}</th><td data-key="{html.escape(k)}">'
            f'{html.escape(fmt(v))}</td><td>{html.escape(unit)}</td></tr>'
        )
    return f'<table id="{table_id}" class="kv"><tbody>{"".join(rows)}</tbody></table>'


def json_html(data: object, depth: int = 0) -> str:
    """Nested mappings/lists as nested tables (three levels; long values cut)."""
    if isinstance(data, Mapping) and depth < 3:
        rows = ''.join(
            f'<tr><th>{html.escape(str(k))}</th><td>{json_html(v, depth + 1)}</td></tr>'
            for k, v in data.items()
        )
        return f'<table class="kv"><tbody>{rows}</tbody></table>'
    if isinstance(data, list) and data and depth < 3 and len(data) <= 20:
        return '<br>'.join(json_html(v, depth + 1) for v in data)
    text = json.dumps(clean_json(data)) if not isinstance(data, (int, float, str)) else fmt(data)
    if len(text) > 300:
        text = text[:300] + ' ...'
    return html.escape(text)


def write_csv(path: Path, rows: Sequence[Mapping[str, object]], columns: Sequence[str]) -> None:
    """Rows as CSV; floats in full precision (repr), None as empty."""
    with path.open('w', newline='', encoding='utf-8') as fh:
        w = csv.writer(fh)
        w.writerow(columns)
        for r in rows:
            w.writerow(
                [
                    ''
                    if r.get(c) is None
                    else repr(r[c])
                    if isinstance(r.get(c), float)
                    else r.get(c)
                    for c in columns
                ]
            )


@dataclass
class Section:
    """One part of the page."""

    key: str
    title: str
    body: str
    available: bool = True


def unavailable(key: str, title: str, reason: str) -> Section:
    """Make a section that says why it has nothing to show."""
    return Section(key, title, f'<p class="na">Unavailable: {html.escape(reason)}</p>', False)


CSS = """
body{font-family:system-ui,-apple-system,'Segoe UI',sans-serif;margin:2em auto;max-width:1100px;
color:#222;padding:0 1em}
h1{font-size:1.6em}h2{font-size:1.25em;border-bottom:1px solid #ccc;padding-bottom:.2em;
margin-top:1.8em}
table{border-collapse:collapse;margin:.6em 0;font-size:.88em}
th,td{border:1px solid #ddd;padding:.25em .6em;text-align:right}th{background:#f4f4f4}
table.kv th{text-align:left}td:first-child{text-align:left}
figure{margin:1em 0}img{max-width:100%}figcaption{font-size:.85em;color:#555}
.na{color:#a33;font-style:italic}.warn{color:#a60}.finding{font-weight:bold}
code{background:#f4f4f4;padding:0 .2em}nav a{margin-right:1em}
ul.summary li{margin:.2em 0}
"""


def render_html(
    title: str, summary: Sequence[str], sections: Sequence[Section], prov: Provenance
) -> str:
    """Render the whole page: summary, navigation, sections, provenance."""
    nav = ''.join(f'<a href="#{s.key}">{html.escape(s.title.split(" (")[0])}</a>' for s in sections)
    parts = [
        '<!DOCTYPE html><html lang="en"><head><meta charset="utf-8">',
        f'<title>{html.escape(title)}</title>',
        '<meta name="viewport" content="width=device-width,initial-scale=1">',
        f'<style>{CSS}</style></head><body>',
        f'<h1>{html.escape(title)}</h1>',
        '<ul class="summary" id="summary">',
        *[f'<li>{html.escape(line)}</li>' for line in summary],
        '</ul>',
        f'<nav>{nav}<a href="#provenance">Provenance</a></nav>',
    ]
    for s in sections:
        parts.append(f'<section id="{s.key}"><h2>{html.escape(s.title)}</h2>{s.body}</section>')
    vers = table(sorted(prov['versions'].items()), ('package', 'version'), 'versions')
    dirty = ' (working tree with uncommitted changes)' if prov.get('git_dirty') else ''
    parts.append(
        '<section id="provenance"><h2>Provenance</h2>'
        f'<p>Command: <code id="command">{html.escape(prov["command"])}</code></p>'
        f'<p>Git commit: <code>{html.escape(str(prov["git_commit"] or "unknown"))}</code>'
        f'{html.escape(dirty)}; '
        f'created {html.escape(prov["created"])} on {html.escape(prov["platform"])}.</p>'
        f'{vers}</section>'
    )
    parts.append('</body></html>')
    return '\n'.join(parts)
