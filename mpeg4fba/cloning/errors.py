"""What the cloners say when something goes wrong or is left out, and the check of a
choice option they share.

No step of a paper: Pandzic's Facial Motion Cloning only says that motions whose
transforms can't be identified "are ignored and a warning is issued"
(:class:`CloneWarning`); Kong et al.'s local frames assume one mesh
(:class:`TopologyError`).  Both cloners import these from here, so neither imports the
other.

>>> check_choice("overlap", "front", ("front", "nearest"))
>>> check_choice("overlap", "back", ("front", "nearest"))
Traceback (most recent call last):
...
ValueError: overlap must be one of ('front', 'nearest'), not 'back'
"""
from __future__ import annotations

from typing import Sequence

__all__ = ["CloneWarning", "LocalFrameWarning", "TopologyError", "check_choice"]


class CloneWarning(UserWarning):
    """Something of the source's motion could not be carried to the target."""


class LocalFrameWarning(UserWarning):
    """A w-point coordinate too small to scale by."""


class TopologyError(ValueError):
    """Local-frame cloning needs faces that share a mesh."""


def check_choice(name: str, value, allowed: Sequence) -> None:
    """ValueError naming the option ``name``, the ``allowed`` values and the value given,
    unless ``value`` is one of them."""
    if value not in allowed:
        raise ValueError(f"{name} must be one of {allowed}, not {value!r}")
