"""Self-contained HTML reports: headings, text, figures (embedded PNG), tables, parameter lists.

One ``.html`` file with inline CSS and base64 images: it opens offline, mails as one
attachment and prints cleanly. Only matplotlib and pandas are used.

>>> rep = Report("Double pendulum drop")
>>> rep.add_text("Released from rest; **HHT** with α = -0.05.")
>>> rep.add_figure(quicklook(df, ["lower.x [m]", "lower.z [m]"]), "Tip of the lower link")
>>> rep.add_table(df.describe(), "Summary")
>>> rep.save("drop.html")
"""

from __future__ import annotations

import base64
import datetime as _dt
import fnmatch
import html as _html
import io
import re
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path

from ..errors import DataError

__all__ = ["Report", "quicklook"]

_CSS = """
:root { --fg: #1d1d1f; --muted: #5f6368; --rule: #d0d4d9; --head: #f3f5f7; --accent: #1f5fa8; }
* { box-sizing: border-box; }
body { font: 15px/1.5 -apple-system, "Segoe UI", Roboto, "Helvetica Neue", Arial, sans-serif;
       color: var(--fg); max-width: 60rem; margin: 2rem auto; padding: 0 1.5rem; }
header { border-bottom: 2px solid var(--accent); margin-bottom: 1.5rem; }
header h1 { margin: 0 0 .25rem 0; font-size: 1.8rem; }
header .meta { color: var(--muted); font-size: .85rem; margin-bottom: .6rem; }
h2 { font-size: 1.35rem; margin-top: 2rem; border-bottom: 1px solid var(--rule); padding-bottom: .2rem; }
h3 { font-size: 1.12rem; margin-top: 1.5rem; }
h4, h5, h6 { font-size: 1rem; margin-top: 1.2rem; }
p { margin: .6rem 0; }
code { font-family: "SFMono-Regular", Consolas, "Liberation Mono", monospace; font-size: .88em;
       background: var(--head); padding: 0 .25em; border-radius: 3px; }
figure { margin: 1.2rem 0; text-align: center; page-break-inside: avoid; break-inside: avoid; }
figure img { max-width: 100%; height: auto; }
figcaption, caption { color: var(--muted); font-size: .9rem; margin: .4rem 0; text-align: left; }
caption { caption-side: top; }
.table-wrap { overflow-x: auto; margin: 1rem 0; page-break-inside: avoid; break-inside: avoid; }
table { border-collapse: collapse; font-size: .88rem; font-variant-numeric: tabular-nums; }
th, td { border: 1px solid var(--rule); padding: .25rem .6rem; }
th { background: var(--head); text-align: left; font-weight: 600; }
td.num { text-align: right; }
th .unit { font-weight: 400; color: var(--muted); }
footer { margin-top: 3rem; border-top: 1px solid var(--rule); color: var(--muted); font-size: .8rem; padding-top: .5rem; }
@media print {
  body { max-width: none; margin: 0; font-size: 11pt; }
  h2, h3 { page-break-after: avoid; break-after: avoid; }
  .table-wrap { overflow: visible; }
  a { color: inherit; }
}
"""


# ------------------------------------------------------------------------------------------
# Markdown-ish text
# ------------------------------------------------------------------------------------------
_INLINE = [
    (re.compile(r"\*\*(.+?)\*\*"), r"<strong>\1</strong>"),
    (re.compile(r"(?<![\w*])\*(?!\s)(.+?)(?<!\s)\*(?![\w*])"), r"<em>\1</em>"),
    (re.compile(r"\[([^\]]+)\]\(([^)\s]+)\)"), r'<a href="\2">\1</a>'),
]


def _inline(text: str) -> str:
    """Escape, then apply `code`, **bold**, *italic* and [links](url); code spans stay literal."""
    out, pos = [], 0
    for m in re.finditer(r"`([^`]+)`", text):
        out.append(_inline_plain(text[pos : m.start()]))
        out.append(f"<code>{_html.escape(m.group(1))}</code>")
        pos = m.end()
    out.append(_inline_plain(text[pos:]))
    return "".join(out)


def _inline_plain(text: str) -> str:
    s = _html.escape(text, quote=True)
    for pat, rep in _INLINE:
        s = pat.sub(rep, s)
    return s


def _markdownish(text: str) -> str:
    """Paragraphs separated by blank lines; lines starting '- ' or '* ' form a bullet list,
    '1. ' a numbered list; inline `code`, **bold**, *italic*, [text](url)."""
    blocks = re.split(r"\n\s*\n", text.strip())
    out = []
    for block in blocks:
        lines = [ln.strip() for ln in block.strip().splitlines()]
        if lines and all(re.match(r"[-*] ", ln) for ln in lines):
            out.append("<ul>" + "".join(f"<li>{_inline(ln[2:])}</li>" for ln in lines) + "</ul>")
        elif lines and all(re.match(r"\d+[.)] ", ln) for ln in lines):
            out.append("<ol>" + "".join(f"<li>{_inline(ln.split(' ', 1)[1])}</li>" for ln in lines) + "</ol>")
        elif lines:
            out.append("<p>" + _inline(" ".join(lines)) + "</p>")
    return "\n".join(out)


def _header_cell(name) -> str:
    """Column header with a trailing ``[unit]`` set in a lighter span."""
    s = str(name)
    m = re.match(r"^(.*?)\s*(\[[^\]]*\])\s*$", s)
    if m and m.group(1):
        return f'{_html.escape(m.group(1))} <span class="unit">{_html.escape(m.group(2))}</span>'
    return _html.escape(s)


def _format_value(v, float_format) -> tuple[str, bool]:
    """(html text, is_numeric) of one cell."""
    import numbers

    import numpy as np

    if v is None or (isinstance(v, float) and np.isnan(v)):
        return "", False
    if isinstance(v, bool | np.bool_):
        return _html.escape(str(v)), False
    if isinstance(v, numbers.Integral):
        return str(int(v)), True
    if isinstance(v, numbers.Real):
        text = float_format(float(v)) if callable(float_format) else format(float(v), float_format)
        return _html.escape(text), True
    if isinstance(v, np.ndarray | list | tuple):
        arr = np.asarray(v)
        if arr.dtype.kind in "fiu":
            f = (lambda x: float_format(float(x))) if callable(float_format) else (lambda x: format(float(x), float_format))
            return _html.escape("[" + ", ".join(f(x) for x in arr.ravel()) + "]"), False
    return _inline(str(v)), False


# ------------------------------------------------------------------------------------------
# The report
# ------------------------------------------------------------------------------------------
class Report:
    """A self-contained HTML report assembled block by block.

    Parameters
    ----------
    title : str
        Shown as the page title and the top heading.
    subtitle : str, optional
        A line under the title (model, date of the run, who made it).

    Every ``add_*`` method returns the report, so calls can be chained. ``figures`` and
    ``tables`` list the captions added so far (for tests and tables of contents).
    """

    def __init__(self, title: str, subtitle: str = ""):
        self.title = str(title)
        self.subtitle = str(subtitle)
        self._blocks: list[str] = []
        self.figures: list[str] = []
        self.tables: list[str] = []

    # -- blocks ------------------------------------------------------------------------------
    def add_heading(self, text: str, level: int = 2) -> Report:
        """A heading ``<h{level}>``; the title is level 1, so sections are 2 and subsections 3."""
        level = int(level)
        if not 1 <= level <= 6:
            raise ValueError(f"Heading level must be 1 to 6, got {level}.")
        anchor = re.sub(r"[^\w-]+", "-", str(text).lower()).strip("-")
        self._blocks.append(f'<h{level} id="{_html.escape(anchor)}">{_html.escape(str(text))}</h{level}>')
        return self

    def add_text(self, text: str) -> Report:
        """Paragraphs of markdown-ish text: blank lines separate paragraphs, ``- `` starts a
        bullet, ``1. `` a numbered item; inline ``**bold**``, ``*italic*``, ```code```,
        ``[text](url)``. Everything else is escaped."""
        self._blocks.append(_markdownish(str(text)))
        return self

    def add_figure(self, fig, caption: str = "", *, dpi: int = 120) -> Report:
        """Embed a matplotlib Figure as a base64 PNG and close it.

        Parameters
        ----------
        fig : matplotlib.figure.Figure
        caption : str
            Shown under the figure as "Figure n. caption".
        dpi : int, default 120
            Resolution of the embedded PNG (120 keeps a 6.4 x 4.8 in figure near 100 kB).
        """
        from matplotlib.figure import Figure

        if not isinstance(fig, Figure):
            raise TypeError(f"add_figure expects a matplotlib Figure, got {type(fig).__name__}.")
        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=dpi, bbox_inches="tight", metadata={"Software": None})
        _close(fig)
        data = base64.b64encode(buf.getvalue()).decode("ascii")
        n = len(self.figures) + 1
        self.figures.append(str(caption))
        cap = f"<figcaption><strong>Figure {n}.</strong> {_inline(str(caption))}</figcaption>" if caption else ""
        alt = _html.escape(str(caption) or f"Figure {n}", quote=True)
        self._blocks.append(f'<figure><img src="data:image/png;base64,{data}" alt="{alt}">{cap}</figure>')
        return self

    def add_table(self, data, caption: str = "", float_format="{:.6g}", *, index: bool | None = None) -> Report:
        """A table from a DataFrame, a list of dicts (records) or a dict of columns.

        Put units in the column names (``"time [s]"``, ``"lower.x [m]"``); they are shown in
        the header in a lighter face.

        Parameters
        ----------
        data : pandas.DataFrame, Series, list of dict, or dict of lists
        caption : str
            Shown above the table as "Table n. caption".
        float_format : str or callable, default ``"{:.6g}"``
            A ``str.format`` pattern (``"{:.3f}"``), a format spec (``".3f"``) or a function
            float → str, applied to every real number.
        index : bool, optional
            Show the DataFrame index; default only when it is not a plain 0..n-1 range.
        """
        import pandas as pd

        if isinstance(data, pd.Series):
            df = data.to_frame()
        elif isinstance(data, pd.DataFrame):
            df = data
        else:
            df = pd.DataFrame(data)
        if index is None:
            index = not isinstance(df.index, pd.RangeIndex) or df.index.name is not None
        fmt = float_format
        if isinstance(fmt, str) and "{" in fmt:
            fmt = fmt.format
        n = len(self.tables) + 1
        self.tables.append(str(caption))
        cap = f"<caption><strong>Table {n}.</strong> {_inline(str(caption))}</caption>" if caption else ""
        self._blocks.append(_table_html(df, cap, fmt, index))
        return self

    def add_parameters(self, rows: Iterable[Sequence], caption: str = "Parameters") -> Report:
        """A parameter table citing sources: rows of ``(name, value, unit, source)``.

        ``source`` says where the value comes from (a paper and equation, a datasheet, "measured",
        "assumed"); 3-tuples leave it empty. Values may be numbers, arrays or text.
        """
        records = []
        for r in rows:
            r = tuple(r)
            if len(r) not in (3, 4):
                raise ValueError(f"add_parameters expects rows (name, value, unit[, source]), got {r!r}.")
            name, value, unit, *src = r
            records.append({"Parameter": name, "Value": value, "Unit": unit, "Source": src[0] if src else ""})
        return self.add_table(records or {"Parameter": [], "Value": [], "Unit": [], "Source": []}, caption, index=False)

    def add_key_values(self, mapping: Mapping, caption: str = "") -> Report:
        """A two-column table of ``key: value`` lines (settings, run summary, solver statistics)."""
        records = [{"Quantity": k, "Value": v} for k, v in mapping.items()]
        return self.add_table(records or {"Quantity": [], "Value": []}, caption, index=False)

    def add_html(self, html: str) -> Report:
        """Raw HTML, inserted as is (for what the other blocks do not cover)."""
        self._blocks.append(str(html))
        return self

    # -- output ------------------------------------------------------------------------------
    def to_html(self) -> str:
        """The whole page as one string."""
        stamp = _dt.datetime.now().strftime("%Y-%m-%d %H:%M")
        version = _version()
        sub = f'<div class="meta">{_html.escape(self.subtitle)}</div>' if self.subtitle else ""
        body = "\n".join(self._blocks)
        return (
            "<!DOCTYPE html>\n"
            '<html lang="en">\n<head>\n<meta charset="utf-8">\n'
            '<meta name="viewport" content="width=device-width, initial-scale=1">\n'
            f"<title>{_html.escape(self.title)}</title>\n<style>{_CSS}</style>\n</head>\n<body>\n"
            f"<header><h1>{_html.escape(self.title)}</h1>{sub}"
            f'<div class="meta">Generated {stamp} by proleg {version}</div></header>\n'
            f"<main>\n{body}\n</main>\n"
            f"<footer>{len(self.figures)} figures, {len(self.tables)} tables. "
            "All values in SI units (m, kg, s, N, rad) unless a column says otherwise.</footer>\n"
            "</body>\n</html>\n"
        )

    def save(self, path) -> Path:
        """Write the report to ``path`` (one self-contained .html file); return the path."""
        path = Path(path)
        if path.suffix.lower() not in (".html", ".htm"):
            path = path.with_suffix(".html")
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(self.to_html(), encoding="utf-8")
        return path

    def _repr_html_(self) -> str:  # Jupyter
        return self.to_html()

    def __repr__(self):
        return f"Report({self.title!r}: {len(self._blocks)} blocks, {len(self.figures)} figures, {len(self.tables)} tables)"


def _table_html(df, caption_html: str, fmt, index: bool) -> str:
    cols = list(df.columns)
    head = "".join(f"<th>{_header_cell(c)}</th>" for c in cols)
    if index:
        head = f"<th>{_header_cell(df.index.name or '')}</th>" + head
    rows = []
    for idx, row in zip(df.index, df.itertuples(index=False, name=None), strict=True):
        cells = []
        if index:
            cells.append(f"<th>{_html.escape(str(idx))}</th>")
        for v in row:
            text, numeric = _format_value(v, fmt)
            cells.append(f'<td class="num">{text}</td>' if numeric else f"<td>{text}</td>")
        rows.append("<tr>" + "".join(cells) + "</tr>")
    return (
        f'<div class="table-wrap"><table>{caption_html}<thead><tr>{head}</tr></thead>'
        f"<tbody>{''.join(rows)}</tbody></table></div>"
    )


def _close(fig) -> None:
    """Close a pyplot-managed figure (frees its memory); a bare Figure needs nothing."""
    import sys

    plt = sys.modules.get("matplotlib.pyplot")
    if plt is not None:
        plt.close(fig)


def _version() -> str:
    try:
        from importlib.metadata import version

        return version("proleg")
    except Exception:  # noqa: BLE001 - not installed (running from a source tree)
        return "(source)"


# ------------------------------------------------------------------------------------------
# Quick-look plot of time histories
# ------------------------------------------------------------------------------------------
def _unit(col: str) -> str:
    m = re.search(r"\[([^\]]*)\]\s*$", str(col))
    return m.group(1) if m else ""


def quicklook(
    df,
    columns: str | Sequence[str] | None = None,
    *,
    time: str = "time [s]",
    title: str | None = None,
    group_by_unit: bool = True,
    width: float = 7.0,
    panel_height: float = 2.2,
):
    """Plot time histories from a results DataFrame against time; return the Figure.

    Parameters
    ----------
    df : pandas.DataFrame
        Results with a time column (``"time [s]"``) and columns named ``"<what> [unit]"``,
        e.g. ``"lower.x [m]"``.
    columns : str or list of str, optional
        Column names or shell patterns (``"lower.*"``, ``"*.z [m]"``); default every column
        but time.
    time : str, default ``"time [s]"``
        The time column (or use the index when the frame has no such column).
    title : str, optional
        Figure title.
    group_by_unit : bool, default True
        One panel per unit, columns of the same unit overlaid with a legend; ``False`` gives one
        panel per column.

    Returns
    -------
    matplotlib.figure.Figure
        A figure not registered with pyplot (no GUI backend is touched, the global backend is
        left alone); pass it to :meth:`Report.add_figure` or ``fig.savefig``.

    Raises
    ------
    DataError
        If a column or pattern matches nothing, naming the columns there are.
    """
    from matplotlib.figure import Figure

    if time in df.columns:
        t = df[time].to_numpy()
        tlabel = time
        available = [c for c in df.columns if c != time]
    else:
        t = df.index.to_numpy()
        tlabel = df.index.name or time
        available = list(df.columns)
    if columns is None:
        selected = available
    else:
        patterns = [columns] if isinstance(columns, str) else list(columns)
        selected = []
        for pat in patterns:
            hits = [pat] if pat in available else fnmatch.filter(available, pat)
            if not hits:
                raise DataError(f"quicklook: no column matches {pat!r}. Columns are: {available}.")
            selected += [h for h in hits if h not in selected]
    if not selected:
        raise DataError("quicklook: there are no columns to plot besides time.")

    if group_by_unit:
        groups: dict[str, list[str]] = {}
        for c in selected:
            groups.setdefault(_unit(c), []).append(c)
        panels = list(groups.items())
    else:
        panels = [(_unit(c), [c]) for c in selected]

    fig = Figure(figsize=(width, max(panel_height * len(panels), 2.5)), layout="constrained")
    axes = fig.subplots(len(panels), 1, sharex=True, squeeze=False)[:, 0]
    for ax, (unit, cols) in zip(axes, panels, strict=True):
        for c in cols:
            label = re.sub(r"\s*\[[^\]]*\]\s*$", "", str(c))
            ax.plot(t, df[c].to_numpy(), label=label, lw=1.2)
        ax.set_ylabel(f"[{unit}]" if unit else (str(cols[0]) if len(cols) == 1 else ""))
        ax.grid(True, alpha=0.3)
        if len(cols) > 1 or group_by_unit:
            ax.legend(loc="best", fontsize="small", frameon=False)
    axes[-1].set_xlabel(tlabel)
    if title:
        fig.suptitle(title)
    return fig
