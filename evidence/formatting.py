"""How the rendered passages write numbers: intervals, times, percentages, signs."""

from __future__ import annotations

from typing import Any


def minutes(seconds: float) -> str:
    whole = round(seconds)
    return f"{whole // 60} min {whole % 60:02d} s"


def shown(x: float | None, digits: int = 2) -> str:
    """A number to ``digits`` decimals, or 'open' where the runs leave it open (None)."""
    return "open" if x is None else f"{x:.{digits}f}"


def interval(entry: list[float | None], digits: int = 2) -> str:
    """'[lo, hi]' of [value, lower, upper]."""
    return f"[{shown(entry[1], digits)}, {shown(entry[2], digits)}]"


def ends(entry: list[float | None], digits: int = 2) -> str:
    """'v m [lo, hi]' of [value, lower, upper] (an open end: 'open')."""
    return f"{shown(entry[0], digits)} m {interval(entry, digits)}"


def bracketed(entry: list[float], digits: int = 3, sign: str = "") -> str:
    """'v [lo, hi]' of [value, lower, upper] (``sign`` "+": the value's sign always shown)."""
    value, lower, upper = entry
    return f"{value:{sign}.{digits}f} [{lower:.{digits}f}, {upper:.{digits}f}]"


def r2(entry: dict[str, Any]) -> str:
    return bracketed(entry["r2"])


def half(entry: list[float | None]) -> float:
    lower, upper = entry[-2], entry[-1]
    return float("inf") if lower is None or upper is None else (upper - lower) / 2.0


def power(value: float) -> str:
    """A power of ten as '1e-3'."""
    return f"{value:.0e}".replace("e-0", "e-").replace("e+0", "e")


def r2_interval(row: dict[str, Any]) -> str:
    """An ood_surrogate.json row's R² with its bootstrap interval."""
    return bracketed([row["r2"], row["r2_low"], row["r2_high"]])


def true_minus(text: str) -> str:
    """``text`` with its hyphen-minus signs written as a true minus sign, as the docs write them."""
    return text.replace("-", "−")


def signed_percent(fraction: float) -> str:
    """'+0.9 %' / '−3.1 %'."""
    return true_minus(f"{100 * fraction:+.1f} %")


def order_text(entry: list[float] | None) -> str:
    """A mesh_order entry [lower, value, upper] as 'v [lo, hi]', or that it has no asymptotic range."""
    return "no asymptotic range" if entry is None else f"{entry[1]:.2f} [{entry[0]:.2f}, {entry[2]:.2f}]"


def pct(value: float) -> str:
    """A fraction as a percentage to one decimal."""
    return f"{100 * value:.1f} %"
