"""Self-contained HTML leaderboard report: one file, sortable table, figures inlined, no network access.

Everything is inline (CSS, a small sort script, PNG figures as base64 ``data:`` URIs) and a Content-Security-
Policy forbids any fetch, so the file opens offline and cannot call home. Every string from the store is HTML-
escaped; the sort script reads cell text and ``data-sort`` attributes only (never ``innerHTML``).
"""

from __future__ import annotations

import base64
import datetime as dt
import html
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from vtrack_gym.evaluation.leaderboard.report_formats import format_estimate, visible_controls

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
MAX_FIGURE_BYTES = 32 * 2**20
"""Largest PNG a report embeds [bytes] (32 MiB; larger ones and non-regular files are skipped)."""

_CSP = ("default-src 'none'; img-src data:; style-src 'unsafe-inline'; script-src 'unsafe-inline'; "
        "base-uri 'none'; form-action 'none'")

_STYLE = """
body { font-family: system-ui, sans-serif; margin: 1.5em; color: #111; background: #fff; }
table { border-collapse: collapse; font-size: 14px; }
th, td { border: 1px solid #888; padding: 4px 8px; white-space: nowrap; }
th { background: #dde4f0; cursor: pointer; user-select: none; }
td.num { text-align: right; font-variant-numeric: tabular-nums; }
tbody tr:nth-child(even) { background: #f2f2f2; }
figure { margin: 1em 0; } figure img { max-width: 100%; border: 1px solid #ccc; }
"""

_SCRIPT = """
(function () {
  'use strict';
  var table = document.getElementById('board');
  if (!table) { return; }
  var body = table.tBodies[0];
  var headers = table.tHead.rows[0].cells;
  function key(cell) {
    var s = cell.getAttribute('data-sort');
    if (s !== null) { return s === '' ? Infinity : parseFloat(s); }
    return cell.textContent;
  }
  function sortBy(col) {
    var th = headers[col];
    var asc = th.getAttribute('aria-sort') !== 'ascending';
    for (var i = 0; i < headers.length; i++) { headers[i].removeAttribute('aria-sort'); }
    th.setAttribute('aria-sort', asc ? 'ascending' : 'descending');
    var rows = Array.prototype.slice.call(body.rows);
    rows.sort(function (a, b) {
      var x = key(a.cells[col]), y = key(b.cells[col]);
      var c = (typeof x === 'number' && typeof y === 'number') ? (x === y ? 0 : (x < y ? -1 : 1))
                                                               : String(x).localeCompare(String(y));
      return asc ? c : -c;
    });
    rows.forEach(function (r) { body.appendChild(r); });
  }
  Array.prototype.forEach.call(headers, function (th, i) {
    th.addEventListener('click', function () { sortBy(i); });
  });
})();
"""


def _esc(text: str) -> str:
    return html.escape(visible_controls(text), quote=True)


def _cell(value: Any, digits: int) -> str:
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        number = float(value)
        if number != number or number in (float("inf"), float("-inf")):
            return '<td class="num" data-sort="">–</td>'
        return f'<td class="num" data-sort="{number!r}">{_esc(format_estimate(value, digits))}</td>'
    if value is None:
        return '<td class="num" data-sort="">–</td>'
    return f"<td>{_esc(str(value))}</td>"


def figure_data_uri(path: str | Path) -> str | None:
    """``data:image/png;base64,...`` of a PNG file, or None if it is not a PNG or larger than ``MAX_FIGURE_BYTES``."""
    p = Path(path)
    try:
        if not p.is_file() or p.stat().st_size > MAX_FIGURE_BYTES:
            return None
        data = p.read_bytes()
    except OSError:
        return None
    if not data.startswith(PNG_SIGNATURE):
        return None
    return "data:image/png;base64," + base64.b64encode(data).decode("ascii")


def to_html(board: list[dict[str, Any]], title: str = "vtrack leaderboard", figures: Sequence[str | Path] = (),
            notes: Sequence[str] = (), digits: int = 3) -> str:
    """The report as one HTML document (figures that are not PNG files are skipped)."""
    stamp = dt.datetime.now(dt.timezone.utc).isoformat(timespec="seconds")
    parts = ["<!DOCTYPE html>", '<html lang="en">', "<head>", '<meta charset="utf-8">',
             f'<meta http-equiv="Content-Security-Policy" content="{_CSP}">',
             '<meta name="viewport" content="width=device-width, initial-scale=1">',
             f"<title>{_esc(title)}</title>", f"<style>{_STYLE}</style>", "</head>", "<body>",
             f"<h1>{_esc(title)}</h1>", f"<p>Generated {_esc(stamp)} by vtrack_gym. Click a column header to sort."
             "</p>"]
    parts += [f"<p>{_esc(n)}</p>" for n in notes]
    if board:
        cols = list(board[0])
        parts.append('<table id="board"><thead><tr>' + "".join(f'<th scope="col">{_esc(c)}</th>' for c in cols)
                     + "</tr></thead><tbody>")
        for entry in board:
            parts.append("<tr>" + "".join(_cell(entry[c], digits) for c in cols) + "</tr>")
        parts.append("</tbody></table>")
    else:
        parts.append("<p>(no results)</p>")
    for fig in figures:
        uri = figure_data_uri(fig)
        if uri is not None:
            name = _esc(Path(fig).name)
            run = _esc(f"{Path(fig).parent.parent.name}/{Path(fig).parent.name}/")  # the run's folder
            parts.append(f'<figure><img alt="{name}" src="{uri}"><figcaption>{run}{name}</figcaption></figure>')
    parts += [f"<script>{_SCRIPT}</script>", "</body>", "</html>"]
    return "\n".join(parts) + "\n"
