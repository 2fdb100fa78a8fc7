"""Seed sets written as text: ``0-9``, ``0,3,5``, ``0-4,10`` (what ``--seeds`` takes, and scripts too)."""

from __future__ import annotations

from vtrack_gym.evaluation.scoring.row_validation import MAX_SEED

MAX_SEEDS = 10_000
"""Most seeds one seed set holds."""


def _seed_text_ok(text: str) -> bool:
    """``text`` is a decimal integer in [0, 2^63 - 1] (checked on the text first: no 5000-digit conversions)."""
    return len(text) <= 19 and text.isascii() and text.isdigit() and int(text) <= MAX_SEED


def parse_seeds(text: str, name: str = "seeds") -> list[int]:
    """Seeds from ``0-9`` / ``0,3,5`` / ``0-4,10``: integers in [0, 2^63 - 1], ranges inclusive, duplicates
    dropped, first occurrence order kept. ``ValueError`` naming ``name`` (how the caller's user calls the set,
    e.g. ``--seeds``) and the bad item."""
    seeds: list[int] = []
    for item in (t.strip() for t in text.split(",")):
        if not item:
            continue
        lo, sep, hi = item.partition("-")
        lo, hi = lo.strip(), hi.strip()
        if not _seed_text_ok(lo) or (sep and not _seed_text_ok(hi)):
            raise ValueError(f"{name} must be integers in [0, 2^63 - 1 = {MAX_SEED}] or ranges A-B, "
                             f"comma-separated, e.g. 0-9 or 0,3,5 (got {item[:40]!r})")
        first, last = int(lo), int(hi) if sep else int(lo)
        if last < first or last - first >= MAX_SEEDS:
            raise ValueError(f"{name} range {item!r} must go up (A <= B) and take at most {MAX_SEEDS} seeds")
        seeds.extend(range(first, last + 1))
    seeds = list(dict.fromkeys(seeds))
    if not seeds:
        raise ValueError(f"{name} needs at least one seed, e.g. 0-4 or 0,1,2")
    if len(seeds) > MAX_SEEDS:
        raise ValueError(f"{name} takes at most {MAX_SEEDS} seeds (got {len(seeds)})")
    return seeds
