"""Write the shipped margin-rule results (``vtrack_gym/data/exact_margins.json``, ``tracks.exact_margin``): the
rule's margin for every shipped car on both ISO 3888 tests, computed here and now from the exact planner. An entry
already stored must hold the same margin (an error otherwise: a shipped result is never rewritten).

    python tests/record_exact_margins.py
"""

from __future__ import annotations

import json

from vtrack_gym.tracks import exact_margin
from vtrack_gym.tracks.feasibility import EXACT_GATED_MANEUVERS
from vtrack_gym.vehicle.catalog import list_vehicles, load_vehicle


def computed_entries() -> list[dict[str, object]]:
    """One entry per shipped car and ISO 3888 test: its rule inputs, car, margin [m] and peak ratio [-]."""
    entries = []
    for car in list_vehicles():
        for name in EXACT_GATED_MANEUVERS:
            vehicle = load_vehicle(car)
            choice = exact_margin.rule_margin(name, vehicle)
            entries.append({"inputs": exact_margin.rule_inputs(name, vehicle), "car": car, "maneuver": name,
                            "margin_m": choice.margin_m, "peak_ratio": round(choice.peak_ratio, 6)})
            print(f"{car:16s} {name}: margin {choice.margin_m * 100:.1f} cm, peak {choice.peak_ratio:.4f} x the "
                  f"least line's", flush=True)
    return entries


def main() -> int:
    file = exact_margin.STORE_FILE
    old = {e["inputs"]: e for e in json.loads(file.read_text())["entries"]} if file.exists() else {}
    for entry in computed_entries():
        if entry["inputs"] in old and old[entry["inputs"]]["margin_m"] != entry["margin_m"]:
            raise ValueError(f"{entry['car']} on {entry['maneuver']}: stored {old[entry['inputs']]['margin_m']} m, "
                             f"computed {entry['margin_m']} m")
        old.setdefault(entry["inputs"], entry)
    file.write_text(json.dumps({"entries": list(old.values())}, indent=1, sort_keys=True) + "\n")
    print(f"{len(old)} entries in {file}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
