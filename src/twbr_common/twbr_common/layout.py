"""Named slots of the flat float64 vectors the compiled kernels share (parameters, settings, memories, outputs).

numba takes module-level integers as compile-time constants, so a kernel indexes a vector with one
(`p[P_R]`) at no cost. Each vector is declared once, as a Layout built from a tuple of names (a spec's
parameter names where the slots hold parameters), and every index constant is looked up in it by name:
adding a slot touches the tuple and the code that uses the slot, and a name that is not in the layout
fails at import instead of reading a neighbour's value.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping

import numpy as np


class Layout:
    """Slot names of one vector, in order; an entry `(name, size)` is a block of `size` slots (a nested layout)."""

    def __init__(self, entries: Iterable[str | tuple[str, int]]) -> None:
        self.names: tuple[str, ...] = ()
        self._index: dict[str, int] = {}
        self._size: dict[str, int] = {}
        offset = 0
        for entry in entries:
            name, size = (entry, 1) if isinstance(entry, str) else entry
            if name in self._index:
                raise ValueError(f"layout: slot {name!r} declared twice")
            if size < 1:
                raise ValueError(f"layout: block {name!r} must have at least one slot")
            self._index[name] = offset
            self._size[name] = size
            self.names += (name,)
            offset += size
        self.size = offset

    def __len__(self) -> int:
        return self.size

    def __getitem__(self, name: str) -> int:
        """The index of a slot (of a block: its first slot)."""
        try:
            return self._index[name]
        except KeyError:
            raise KeyError(f"layout has no slot {name!r} (slots: {', '.join(self.names)})") from None

    def block(self, name: str) -> slice:
        """The slots of a block."""
        start = self[name]
        return slice(start, start + self._size[name])

    def pack(self, values: Mapping[str, float]) -> np.ndarray:
        """A vector with every single slot taken from `values` by name (blocks are left zero for the caller)."""
        v = np.zeros(self.size)
        for name in self.names:
            if self._size[name] == 1:
                v[self._index[name]] = values[name]
        return v

    def unpack(self, vector: np.ndarray) -> dict[str, float]:
        """The single slots of a vector by name."""
        return {name: float(vector[self._index[name]]) for name in self.names if self._size[name] == 1}
