"""Short text forms shared by the progress lines, the report, the figures and the command: a duration, a row's
model."""

from __future__ import annotations

from typing import Any


def _fmt_duration(seconds: float) -> str:
    seconds = max(0.0, seconds)
    if seconds < 60:
        return f"{seconds:.0f}s"
    minutes, s = divmod(int(round(seconds)), 60)
    if minutes < 60:
        return f"{minutes}m{s:02d}s"
    hours, m = divmod(minutes, 60)
    return f"{hours}h{m:02d}m"


def model_text(row: dict[str, Any]) -> str:
    """``"case 3, Λ = 2, [16,16]"``: a row's title with its levels."""
    return f"{row['title']}, [{','.join(map(str, row['levels']))}]"
