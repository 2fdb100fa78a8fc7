"""The race's observation layout: the longitudinal modes' layout (``envs.observation``) with three fields at the
very end, so that every index of that layout stays where it is and an agent of the longitudinal modes reads a
race observation by name.

``edge_left_m`` and ``edge_right_m`` [m]: the distance from the car's CG to the left and to the right edge of the
track at its station (``w_left - e_y`` and ``w_right + e_y``; negative beyond that edge); ``lap_fraction`` [-]:
the car's centre-line station as a fraction of the lap, s* / L in [0, 1) (where on the track the car is, for a
policy with a map of it, e.g. a racing line).
"""

from __future__ import annotations

from dataclasses import dataclass, fields

from vtrack_gym.envs.observation import ObservationField, ObservationLayout

RACE_FIELDS: tuple[ObservationField, ...] = (
    ObservationField("edge_left_m", "m", 200.0, None, 0.0, 5.0,
                     "distance from the CG to the left track edge at s* (w_left - e_y; negative beyond it)"),
    ObservationField("edge_right_m", "m", 200.0, None, 0.0, 5.0,
                     "distance from the CG to the right track edge at s* (w_right + e_y; negative beyond it)"),
    ObservationField("lap_fraction", "-", 1.0, None, 0.5, 0.5, "the centre-line station as a fraction of the lap"),
)
"""The race's fields, after the longitudinal modes' tracking errors."""


@dataclass(frozen=True)
class RaceLayout(ObservationLayout):
    """An ``ObservationLayout`` (the same parameters) whose observation ends with ``RACE_FIELDS``."""

    @classmethod
    def of(cls, base: ObservationLayout) -> RaceLayout:
        """The race layout extending ``base`` (its preview and tracking-error settings)."""
        return cls(**{f.name: getattr(base, f.name) for f in fields(ObservationLayout)})

    @property
    def base_size(self) -> int:
        """Length of the observation without the race fields (what the env's compiled step writes)."""
        return super().size

    @property
    def size(self) -> int:
        """Length of the observation vector (the base layout's and the race fields)."""
        return self.base_size + len(RACE_FIELDS)

    @property
    def speed_preview(self) -> slice:
        """Slice of the reference-speed preview samples."""
        start = self.n_scalars + self.n_preview
        return slice(start, start + self.n_speed_preview)

    @property
    def names(self) -> tuple[str, ...]:
        """Every entry's name: the base layout's, then ``edge_left_m``, ``edge_right_m``, ``lap_fraction``."""
        return super().names + tuple(f.name for f in RACE_FIELDS)

    def index(self, name: str) -> int:
        """Index of a named entry; ``KeyError`` listing the valid names if unknown."""
        if name in self.names:
            return self.names.index(name)
        try:
            return super().index(name)
        except KeyError as err:
            raise KeyError(f"{err.args[0]}, {', '.join(f.name for f in RACE_FIELDS)}") from None

    def fields(self) -> tuple[ObservationField, ...]:
        """The table row of every entry, in observation order."""
        return super().fields() + RACE_FIELDS
