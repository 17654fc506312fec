"""Morph targets (blend shapes) -> a Facial Animation Table.

A morph-target set is a neutral face plus sculpted shapes, each the face at one FAP
value, or showing one viseme or expression in full.  :func:`fat_from_morph_targets`
turns such a set into a :class:`~mpeg4fba.fba.fat.FAT` that reproduces every target
exactly when the face is posed at that target's value, and interpolates linearly in
between (see the evaluation rules in :mod:`mpeg4fba.fba.fat`).

Target names
------------
:func:`parse_target_name` reads what a target is from a short text::

    name       := fap "@" value | visual
    fap        := FAP number 3-68 | "fap" number | FAP name
    visual     := ("viseme" | "expression") sep (name | number)
    sep        := ":" | "_"

* ``open_jaw@1024``, ``3@1024``, ``fap3@1024``, ``raise_b_midlip@-512``: the face at
  that value of a low-level FAP.  FAP names are looked up as ``FAP[...]`` does (the
  Visual naming of ISO/IEC 14496-2, and BIFS FAP-node names where they name no other
  FAP); case does not matter.  The value is a non-zero whole number in FAP units
  (FAT interval borders are integers).
* ``viseme:PP``, ``viseme:1``, ``expression:joy``, ``expression:1`` (or with ``_``
  for ``:``, which file systems prefer): the full viseme / expression.  These take no
  value: a full shape is value 63 of FAP 1 / FAP 2.
* FAPs 1 and 2 by number or name (``1@63``, ``viseme@63``) are refused: say which
  viseme or expression the shape is.

How targets become tables
-------------------------
* The targets of one low-level FAP sorted by value, with the neutral at 0, give the
  interval borders (``[0, v]`` for one positive target, ``[-a, 0, b]`` for one each
  side, more for more).  Each interval's displacement is the difference of the shapes
  at its two borders divided by its width, so the face passes through every target.
* A viseme or expression becomes a FaceDefTable of FAP 1 / 2 (``select`` = its
  number) with borders ``[0, 63]`` and displacement ``(target - neutral) / 63``.
* Only vertices that move (some coordinate differs from the neutral by more than
  ``tol``; the default 0 keeps every vertex that moves at all) are listed.

Example
-------
>>> neutral = {"Skin": np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])}
>>> jaw = MorphTarget("open_jaw@1024", None, {"Skin": [[0, 0, 0], [1, 0, 0], [0, 0.5, 0]]})
>>> fat = fat_from_morph_targets(neutral, [jaw])
>>> m = fat[3].meshes[0]
>>> m.borders.tolist(), m.indices.tolist(), (m.displacements[:, 0] * 1024).tolist()
([0.0, 1024.0], [2], [[0.0, -0.5, 0.0]])
"""
from __future__ import annotations

import difflib
import math
import re
import warnings
from dataclasses import dataclass, field
from typing import Mapping, Optional, Sequence, Union

import numpy as np

from .fat import FAT, FaceDefMesh, FaceDefTable
from .tables import EXPRESSIONS, FAP, N_FAPS, VISEMES

__all__ = ["TargetKey", "MorphTarget", "MorphTargetWarning", "parse_target_name",
           "fat_from_morph_targets", "FULL_SHAPE"]

#: The FAP 1 / FAP 2 value of a full viseme or expression.
FULL_SHAPE = 63.0

#: A target whose vertices moved by more than this share of the mesh's bounding-box
#: diagonal (median over the vertices, centroids removed) was probably saved with its
#: vertices in another order.
ORDER_CHECK = 0.25

_VISUAL = re.compile(r"^(viseme|expression)[:_](.+)$", re.IGNORECASE)
_FAPNUM = re.compile(r"^(?:fap)?(\d+)$", re.IGNORECASE)


class MorphTargetWarning(UserWarning):
    """A morph target that is usable but probably not what was meant."""


@dataclass(frozen=True)
class TargetKey:
    """What a morph target shows: a low-level FAP (``select`` 0), or viseme / expression
    ``select`` of FAP 1 / FAP 2.

    >>> str(TargetKey(3)), str(TargetKey(1, 1)), str(TargetKey(2, 1))
    ('open_jaw', 'viseme:PP', 'expression:joy')
    """

    fap: int
    select: int = 0

    @property
    def high_level(self) -> bool:
        return self.fap <= 2

    def __str__(self) -> str:
        if self.fap == 1:
            return f"viseme:{VISEMES[self.select].name}"
        if self.fap == 2:
            return f"expression:{EXPRESSIONS[self.select].name}"
        return FAP[self.fap].name


def _hint(word: str, names: Sequence[str]) -> str:
    close = difflib.get_close_matches(word.lower(), names, n=3, cutoff=0.6)
    return f"; did you mean {', '.join(close)}?" if close else ""


def _visual(kind: str, which: str, text: str) -> TargetKey:
    table, fap = (VISEMES, 1) if kind == "viseme" else (EXPRESSIONS, 2)
    record = table.get(which)
    if record is None:
        names = [r.name for r in table if r.number]
        hint = _hint(which, [n.lower() for n in names])
        listing = hint.replace("did you mean ", f"did you mean {kind}:") if hint else \
            f" ({kind}s: {', '.join(names)}, or 1-{len(names)})"
        raise ValueError(f"target {text!r}: no {kind} {which!r}{listing}")
    if record.number == 0:
        raise ValueError(f"target {text!r}: {kind} 0 ({record.name}) is the neutral face, "
                         f"which is no target")
    return TargetKey(fap, record.number)


def _fap(word: str, text: str) -> int:
    m = _FAPNUM.match(word)
    if m:
        number = int(m.group(1))
        if not 1 <= number <= N_FAPS:
            raise ValueError(f"target {text!r}: there is no FAP {number} (FAPs are 1-{N_FAPS})")
    else:
        record = FAP.get(word)
        if record is None:
            names = list(dict.fromkeys([r.name for r in FAP] + [r.bifs_name for r in FAP if r.bifs_name]))
            hint = _hint(word, names)
            if not hint and (VISEMES.get(word) or EXPRESSIONS.get(word)):
                kind = "viseme" if VISEMES.get(word) else "expression"
                hint = f"; did you mean {kind}:{word}?"
            raise ValueError(f"target {text!r}: no FAP named {word!r}{hint}")
        number = record.number
    if number <= 2:
        kind = "viseme:<name>" if number == 1 else "expression:<name>"
        raise ValueError(f"target {text!r}: FAP {number} selects a shape; name the shape as "
                         f"{kind} instead (e.g. {'viseme:PP' if number == 1 else 'expression:joy'})")
    return number


def parse_target_name(text: str) -> tuple:
    """``(TargetKey, value)`` of a target name; value is None for visemes and expressions.

    The grammar is in the module docstring.  ValueError (naming ``text``) for anything
    else.

    >>> parse_target_name("open_jaw@1024")
    (TargetKey(fap=3, select=0), 1024.0)
    >>> parse_target_name("fap4@-512"), parse_target_name("viseme_PP"), parse_target_name("expression:6")
    ((TargetKey(fap=4, select=0), -512.0), (TargetKey(fap=1, select=1), None), (TargetKey(fap=2, select=6), None))
    >>> parse_target_name("opem_jaw@10")
    Traceback (most recent call last):
    ...
    ValueError: target 'opem_jaw@10': no FAP named 'opem_jaw'; did you mean open_jaw?
    """
    s = str(text).strip()
    word, at, value_text = s.partition("@")
    word = word.strip()
    m = _VISUAL.match(word)
    if m:
        key = _visual(m.group(1).lower(), m.group(2).strip(), s)
        if at:
            kind = "a viseme" if key.fap == 1 else "an expression"
            raise ValueError(f"target {s!r}: {kind} takes no @value (a target "
                             f"is the full shape, value {FULL_SHAPE:g}); write {str(key)!r}")
        return key, None
    if not word:
        raise ValueError(f"target {s!r}: no FAP, viseme or expression named")
    number = _fap(word, s)
    if not at:
        raise ValueError(f"target {s!r}: give the FAP value the shape shows, "
                         f"e.g. '{FAP[number].name}@1024'")
    return TargetKey(number), _value(value_text.strip(), s)


def _value(text: str, name: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise ValueError(f"target {name!r}: FAP value {text!r} is not a number") from None
    if not math.isfinite(v):
        raise ValueError(f"target {name!r}: FAP value {text!r} is not finite")
    if v == 0:
        raise ValueError(f"target {name!r}: a FAP value of 0 is the neutral face; a target "
                         f"needs a non-zero value")
    if v != round(v) or abs(v) > 2**31 - 1:
        raise ValueError(f"target {name!r}: FAP value {text!r} is not a whole number (FAP "
                         f"values and FAT interval borders are 32-bit integers)")
    return v


@dataclass(eq=False)
class MorphTarget:
    """One sculpted shape: ``key`` (a :class:`TargetKey`, FAP number or name, or a target
    name as :func:`parse_target_name` reads it), the FAP ``value`` it shows (None for
    visemes and expressions, or when ``key`` holds ``@value``), and ``meshes``, mesh
    name -> target vertices [n, 3].  ``name`` (default: the canonical text) is what error
    messages call it.

    >>> t = MorphTarget("open_jaw", 1024, {})
    >>> t.key, t.value, t.name
    (TargetKey(fap=3, select=0), 1024.0, 'open_jaw@1024')
    """

    key: Union[TargetKey, int, str]
    value: Optional[float] = None
    meshes: dict = field(default_factory=dict)
    name: Optional[str] = None

    def __post_init__(self):
        label = self.name or str(self.key)
        if isinstance(self.key, TargetKey):
            key, parsed = self.key, None
        elif isinstance(self.key, int) or (isinstance(self.key, str) and "@" not in self.key
                                           and not _VISUAL.match(self.key.strip())):
            key, parsed = TargetKey(_fap(str(self.key).strip(), label)), None
        else:
            key, parsed = parse_target_name(self.key)
        if key.high_level:
            if self.value is not None:
                raise ValueError(f"target {label!r}: {'a viseme' if key.fap == 1 else 'an expression'} "
                                 f"takes no value (a target is the full shape, value "
                                 f"{FULL_SHAPE:g}); got {self.value!r}")
            value = None
        else:
            if parsed is not None and self.value is not None and float(self.value) != parsed:
                raise ValueError(f"target {label!r}: value {self.value!r} given besides @{int(parsed)}")
            if parsed is None and self.value is None:
                raise ValueError(f"target {label!r}: give the FAP value the shape shows, e.g. "
                                 f"'{FAP[key.fap].name}@1024'")
            value = parsed if parsed is not None else _value(str(self.value), label)
        self.key, self.value = key, value
        if self.name is None:
            self.name = str(key) if value is None else f"{key}@{int(value)}"
        self.meshes = dict(self.meshes)


def _neutral_arrays(neutral) -> dict:
    """Mesh name -> float array [n, 3] from a dict of arrays / FaceMeshes or a FaceModel."""
    meshes = getattr(neutral, "meshes", neutral)
    out = {}
    for name, v in meshes.items():
        v = np.asarray(getattr(v, "vertices", v), dtype=np.float64)
        if v.size % 3:
            raise ValueError(f"neutral mesh {name}: {v.size} coordinates are not a whole "
                             f"number of xyz vertices")
        out[name] = v.reshape(-1, 3)
    return out


def _check_target(target: MorphTarget, neutral: dict, order_check: Optional[float]) -> dict:
    """The target's meshes as float arrays shaped like the neutral's, or ValueError."""
    names, want = set(target.meshes), set(neutral)
    if names != want:
        parts = []
        if want - names:
            parts.append(f"lacks mesh{'es' if len(want - names) > 1 else ''} "
                         f"{', '.join(sorted(want - names))}")
        if names - want:
            parts.append(f"has mesh{'es' if len(names - want) > 1 else ''} "
                         f"{', '.join(sorted(names - want))} that the neutral has not")
        raise ValueError(f"target {target.name!r} {' and '.join(parts)} (the neutral has "
                         f"{', '.join(sorted(want)) or 'no meshes'})")
    out = {}
    for name, n0 in neutral.items():
        v = np.asarray(target.meshes[name], dtype=np.float64)
        if v.size % 3 or (v.ndim == 2 and v.shape[1] != 3):
            raise ValueError(f"target {target.name!r} mesh {name}: vertices must be an "
                             f"[n, 3] array, got shape {v.shape}")
        v = v.reshape(-1, 3)
        if len(v) != len(n0):
            raise ValueError(f"target {target.name!r} mesh {name} has {len(v)} vertices, "
                             f"the neutral {len(n0)}")
        if not np.isfinite(v).all():
            raise ValueError(f"target {target.name!r} mesh {name} has a NaN or infinite "
                             f"coordinate")
        if order_check is not None and len(v) > 2:
            diagonal = float(np.linalg.norm(n0.max(axis=0) - n0.min(axis=0)))
            moved = np.linalg.norm((v - v.mean(axis=0)) - (n0 - n0.mean(axis=0)), axis=1)
            median = float(np.median(moved))
            if diagonal > 0 and median > order_check * diagonal:
                raise ValueError(
                    f"target {target.name!r} mesh {name}: half of its vertices moved more than "
                    f"{median / diagonal:.0%} of the mesh's size from the neutral; vertex order "
                    f"differs? (targets must list the neutral's vertices in the same order)")
        out[name] = v
    return out


def fat_from_morph_targets(neutral: Mapping, targets: Sequence[MorphTarget], tol: float = 0.0,
                           order_check: Optional[float] = ORDER_CHECK) -> FAT:
    """A FAT that reproduces each target at its value (the rules are in the module doc).

    ``neutral`` maps mesh names to neutral vertices [n, 3] (a FaceModel, or a dict of
    FaceMeshes, also do); every target must have the same meshes with the same vertex
    counts.  ``tol``: vertices moving by at most this (per coordinate, in every target of
    a table) are left out.  ``order_check``: the share of the bounding-box diagonal
    beyond which a target's median vertex motion (centroids removed) is taken for a
    different vertex order (None: no check).  ValueError naming the target for anything
    unusable; a target that moves nothing gives no table and a MorphTargetWarning.

    >>> neutral = {"Lip": np.zeros((2, 3))}
    >>> up = MorphTarget("raise_b_midlip@512", None, {"Lip": [[0, 1, 0], [0, 0, 0]]})
    >>> down = MorphTarget("raise_b_midlip@-256", None, {"Lip": [[0, -2, 0], [0, 0, 0]]})
    >>> m = fat_from_morph_targets(neutral, [up, down], order_check=None)[5].meshes[0]
    >>> m.borders.tolist(), m.displacement(-128).tolist(), m.displacement(1024).tolist()
    ([-256.0, 0.0, 512.0], [[0.0, -1.0, 0.0]], [[0.0, 2.0, 0.0]])
    """
    base = _neutral_arrays(neutral)
    groups: dict = {}
    for t in targets:
        if not isinstance(t, MorphTarget):
            raise TypeError(f"expected MorphTarget objects, got {type(t).__name__}")
        shapes = _check_target(t, base, order_check)
        group = groups.setdefault(t.key, {})
        if t.value in group:
            other = group[t.value][0]
            at = "" if t.value is None else f" at value {int(t.value)}"
            raise ValueError(f"targets {other.name!r} and {t.name!r} are both {t.key}{at}")
        group[t.value] = (t, shapes)
    tables = []
    for key in sorted(groups, key=lambda k: (k.fap, k.select)):
        group = groups[key]
        if key.high_level:
            borders = np.array([0.0, FULL_SHAPE])
            t, shapes = group[None]
            steps = {name: ((shapes[name] - base[name]) / FULL_SHAPE)[:, None] for name in base}
            deltas = {name: (shapes[name] - base[name])[None] for name in base}
        else:
            values = sorted(group)
            borders = np.array(sorted(values + [0.0]))
            deltas = {}
            steps = {}
            for name, n0 in base.items():
                # shapes at each border (neutral at 0) as deltas [borders, n, 3]
                at = np.stack([np.zeros_like(n0) if b == 0 else group[b][1][name] - n0
                               for b in borders])
                deltas[name] = at
                steps[name] = np.moveaxis(np.diff(at, axis=0) / np.diff(borders)[:, None, None], 0, 1)
        meshes = []
        for name in base:
            moving = np.flatnonzero((np.abs(deltas[name]) > tol).any(axis=(0, 2)))
            if len(moving):
                meshes.append(FaceDefMesh(name, borders, moving, steps[name][moving]))
        names = ", ".join(repr(t.name) for t, _ in group.values())
        if not meshes:
            warnings.warn(f"target{'s' if len(group) > 1 else ''} {names} move{'' if len(group) > 1 else 's'} "
                          f"no vertex; {key} gets no table", MorphTargetWarning, stacklevel=2)
            continue
        tables.append(FaceDefTable(key.fap, meshes, select=key.select if key.high_level else 1))
    return FAT(tables)
