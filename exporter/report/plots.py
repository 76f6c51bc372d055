"""Inline SVG strip plots for the report: one column of dots per LoD level, a median bar per column.

Data form: ``series`` is a list of ``(label, points)`` with ``points`` a list of ``(name, value)``
(the name becomes the dot's tooltip). Output is an ``<svg>`` element as text, sized in CSS pixels,
with no script and no external reference, so the page works offline from ``file://``.

Dots are spread sideways by a fixed low-discrepancy sequence (golden-ratio offsets) rather than
random jitter, so the same data always draws the same picture.
"""

from __future__ import annotations

import math
from html import escape

GOLDEN = (math.sqrt(5.0) - 1.0) / 2.0


def nice_ticks(low: float, high: float, count: int = 5) -> list[float]:
    """About ``count`` round tick values covering [low, high] (steps of 1, 2, 2.5 or 5 times 10^k)."""
    if not high > low:
        return [low]
    raw = (high - low) / max(count - 1, 1)
    magnitude = 10.0 ** math.floor(math.log10(raw))
    step = next(m * magnitude for m in (1.0, 2.0, 2.5, 5.0, 10.0) if m * magnitude >= raw)
    first = math.ceil(low / step - 1e-9) * step
    ticks = []
    value = first
    while value <= high + step * 1e-9:
        ticks.append(round(value, 12))
        value += step
    return ticks


def value_range(series: list, fixed: tuple[float, float] | None = None) -> tuple[float, float]:
    """The y range: ``fixed`` when given, else the data's range widened to include 0."""
    if fixed is not None:
        return fixed
    values = [v for _, points in series for _, v in points]
    low, high = min(values + [0.0]), max(values + [0.0])
    if high - low < 1e-12:
        high = low + 1.0
    pad = (high - low) * 0.05
    return low - (pad if low < 0 else 0.0), high + pad


def _format(value: float) -> str:
    return f"{value:.3g}"


def strip_plot_svg(
    title: str,
    series: list[tuple[str, list[tuple[str, float]]]],
    y_range: tuple[float, float] | None = None,
    width: int = 240,
    height: int = 170,
) -> str:
    """An SVG strip plot of ``series`` (see module doc) titled ``title``; ``y_range`` fixes the
    vertical axis (e.g. (0, 1) for ratios), else it follows the data. Sizes in CSS pixels."""
    left, right, top, bottom = 40, 8, 22, 22
    plot_w, plot_h = width - left - right, height - top - bottom
    low, high = value_range(series, y_range)

    def y_of(value: float) -> float:
        clamped = min(max(value, low), high)
        return top + plot_h * (1.0 - (clamped - low) / (high - low))

    parts = [
        f'<svg xmlns="http://www.w3.org/2000/svg" class="plot" width="{width}" height="{height}" '
        f'viewBox="0 0 {width} {height}" role="img" aria-label="{escape(title)}">',
        f'<text x="{width / 2:.1f}" y="14" text-anchor="middle" class="plot-title">{escape(title)}</text>',
        f'<rect x="{left}" y="{top}" width="{plot_w}" height="{plot_h}" class="plot-frame"/>',
    ]
    for tick in nice_ticks(low, high, 5):
        y = y_of(tick)
        parts.append(
            f'<line x1="{left}" x2="{left + plot_w}" y1="{y:.1f}" y2="{y:.1f}" class="plot-grid"/>'
        )
        parts.append(
            f'<text x="{left - 4}" y="{y + 3.5:.1f}" text-anchor="end" class="plot-tick">{_format(tick)}</text>'
        )
    column_w = plot_w / max(len(series), 1)
    for i, (label, points) in enumerate(series):
        center = left + column_w * (i + 0.5)
        parts.append(
            f'<text x="{center:.1f}" y="{height - 6}" text-anchor="middle" class="plot-tick">{escape(label)}</text>'
        )
        spread = column_w * 0.6
        for j, (name, value) in enumerate(points):
            x = center + spread * (((j * GOLDEN) % 1.0) - 0.5)
            parts.append(
                f'<circle cx="{x:.1f}" cy="{y_of(value):.1f}" r="3" class="plot-dot"><title>{escape(name)}: {_format(value)}</title></circle>'
            )
        if points:
            values = sorted(v for _, v in points)
            middle = len(values) // 2
            median = (
                values[middle] if len(values) % 2 else (values[middle - 1] + values[middle]) / 2.0
            )
            y = y_of(median)
            parts.append(
                f'<line x1="{center - column_w * 0.4:.1f}" x2="{center + column_w * 0.4:.1f}" y1="{y:.1f}" y2="{y:.1f}" class="plot-median"><title>median {_format(median)}</title></line>'
            )
        else:
            parts.append(
                f'<text x="{center:.1f}" y="{top + plot_h / 2:.1f}" text-anchor="middle" class="plot-tick">no data</text>'
            )
    parts.append("</svg>")
    return "".join(parts)
