"""The connections from local view cells to the grid cells and head-direction cells (NeuroSLAM eqs. 10–11).

A template learns, when it is first seen, where both activity packets were (NeuroSLAM eq. 10: the Hebbian
association, kept here as the packets' centres, which is what the injection of eq. 11 uses); seeing it
again injects activity there (eq. 11), weakened while the view keeps being seen (the decay below). With
several sessions, each association also remembers the map (component) it was learned in: a view learned
in another map does not move the packets until the maps merge.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["VIEW_DECAY_TIME", "ViewAssociations"]

VIEW_DECAY_TIME = 10.0  # s: how fast a repeatedly seen view regains its full calibration strength
_CAPACITY = 64


class ViewAssociations:
    """Per template: the grid code (3 cells) and head-direction code (2 cells) it was learned at, its
    calibration decay and last activation time (s), and the map component it was learned in.

    Attributes:
        grid: (capacity, 3). direction: (capacity, 2). decay: (capacity, 2): (decay, time of last
            activation). component: (capacity,) int. Rows at and beyond the number of templates are unused.
    """

    def __init__(self) -> None:
        self.grid = np.zeros((_CAPACITY, 3))
        self.direction = np.zeros((_CAPACITY, 2))
        self.decay = np.zeros((_CAPACITY, 2))
        self.component = np.zeros(_CAPACITY, dtype=np.int64)

    _NAMES = ("grid", "direction", "decay", "component")

    def learn(self, template: int, grid_code: np.ndarray, direction_code: np.ndarray, component: int,
              time: float) -> None:
        """NeuroSLAM eq. 10: a new template associates with the packets' centres (cells) at ``time`` (s)."""
        if template >= len(self.grid):
            for name in self._NAMES:
                array = getattr(self, name)
                setattr(self, name, np.concatenate([array, np.zeros_like(array)]))
        self.component[template] = component
        self.grid[template] = grid_code
        self.direction[template] = direction_code
        self.decay[template] = (1.0, time)

    def recall(self, template: int, time: float) -> float:
        """The strength factor of a familiar template's injection at ``time`` (s), NeuroSLAM eq. 11 with a decay:
        every activation adds 1 to the view's decay, which falls back exponentially (time constant
        :data:`VIEW_DECAY_TIME`); the factor is 1 / (1 + decay), so a view seen frame after frame (a robot
        standing still) does not overwhelm path integration."""
        decay, last = self.decay[template]
        decay = decay * math.exp(-(time - last) / VIEW_DECAY_TIME) + 1.0
        self.decay[template] = (decay, time)
        return 1.0 / (1.0 + decay)

    def forget_activations(self) -> None:
        """Every template at full strength again (a new session's clock starts afresh)."""
        self.decay[:] = 0.0

    def extend(self, other: ViewAssociations, first: int, added: int, component_offset: int) -> None:
        """Append ``other``'s first ``added`` associations after this one's first ``first`` (another map's
        templates, appended at ``first``), their components shifted by ``component_offset``."""
        capacity = max(_CAPACITY, 2 * (first + added))
        for name in self._NAMES:
            mine, theirs = getattr(self, name), getattr(other, name)
            grown = np.zeros((capacity, *mine.shape[1:]), dtype=mine.dtype)
            grown[:first] = mine[:first]
            grown[first: first + added] = theirs[:added]
            setattr(self, name, grown)
        self.component[first: first + added] += component_offset

    def state_dict(self, templates: int) -> dict[str, np.ndarray]:
        """The first ``templates`` associations as named arrays (``view_grid``, ...)."""
        return {f"view_{name}": getattr(self, name)[:templates].copy() for name in self._NAMES}

    def load_state_dict(self, state: dict[str, np.ndarray], templates: int) -> None:
        """Restore :meth:`state_dict` for ``templates`` templates. Raises ValueError (and changes nothing) for
        arrays that do not fit."""
        grid, direction, decay = (np.asarray(state[f"view_{name}"], dtype=float)
                                  for name in ("grid", "direction", "decay"))
        if grid.shape != (templates, 3) or direction.shape != (templates, 2) or decay.shape != (templates, 2):
            raise ValueError(f"the view associations do not match the {templates} templates")
        component = np.asarray(state["view_component"], dtype=np.int64)
        if component.shape != (templates,):
            raise ValueError(f"the view components do not match the {templates} templates")
        capacity = max(_CAPACITY, templates)
        self.grid, self.direction, self.decay = (
            np.concatenate([array, np.zeros((capacity - templates, array.shape[1]))])
            for array in (grid, direction, decay))
        self.component = np.concatenate([component, np.zeros(capacity - templates, dtype=np.int64)])
