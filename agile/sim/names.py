"""Selection of joints and bodies by name regex."""

from __future__ import annotations

import re
from collections.abc import Sequence


def resolve_names(exprs: str | Sequence[str], names: Sequence[str], what: str = "joint",
                  preserve_order: bool = False) -> tuple[list[int], list[str]]:
    """Indices and names in `names` that fully match any of the regexes `exprs`.

    Each expression must match at least one name; otherwise the error lists the names that exist.
    With `preserve_order` the result follows the order of `exprs`, else the order of `names`.
    """
    if isinstance(exprs, str):
        exprs = [exprs]
    if not exprs:  # else the term would select nothing and fail later on something it derives from it
        raise ValueError(f"no {what} regex given: an empty list selects nothing; give at least one ('.*' selects all)")
    matched: dict[int, int] = {}
    for e_idx, expr in enumerate(exprs):
        try:
            pattern = re.compile(expr)
        except re.error as err:
            raise ValueError(f"invalid {what} regex '{expr}': {err}") from None
        hits = [i for i, n in enumerate(names) if pattern.fullmatch(n)]
        if not hits:
            raise ValueError(f"{what} regex '{expr}' matches no {what}. {what.capitalize()} names: {list(names)}")
        for i in hits:
            matched.setdefault(i, e_idx)
    ids = sorted(matched, key=lambda i: (matched[i], i)) if preserve_order else sorted(matched)
    return ids, [names[i] for i in ids]


def resolve_values(values: float | dict[str, float], names: Sequence[str], what: str = "joint") -> dict[int, float]:
    """{index in names: value} for a scalar (every name) or a {regex: value} dict."""
    if isinstance(values, dict):
        out: dict[int, float] = {}
        for expr, v in values.items():
            ids, _ = resolve_names(expr, names, what)
            for i in ids:
                out[i] = float(v)
        return out
    return {i: float(values) for i in range(len(names))}
