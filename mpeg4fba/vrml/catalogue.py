"""The node catalogue: every VRML97 node and the MPEG-4 face nodes, read from data.

The table is ``data/nodes.tsv`` (one row per field, in the spec's order); this module
only turns it into typed records.

Example
-------
>>> NODE_TYPES["Transform"].fields["translation"].default
(0.0, 0.0, 0.0)
>>> NODE_TYPES["Shape"].fields["geometry"].accepts
('geometry',)
>>> NODE_TYPES["FAP"].field("raise_b_lip_lm").name   # Visual spelling -> BIFS field
'lower_b_lip_lm'
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field as _field
from importlib import resources
from typing import Any, Optional

from .fields import FIELD_TYPES, FieldType, parse_numbers, unquote_string

__all__ = ["FieldDecl", "Interface", "NodeType", "NODE_TYPES", "EVENT_KINDS", "VRML97_NODES"]

EVENT_KINDS = ("eventIn", "eventOut", "field", "exposedField")


@dataclass(eq=False)
class FieldDecl:
    """One field or event of a node interface: ``exposedField SFVec3f translation 0 0 0``.

    ``default`` is the value (for PROTO and Script declarations, the declared value);
    ``accepts`` the node classes an SFNode/MFNode field may hold (None: any).
    """

    kind: str
    type: FieldType
    name: str
    default: Any = None
    accepts: Optional[tuple] = None
    pos: Optional[int] = _field(default=None, repr=False)
    origin: Optional[str] = None   # "X3D" for fields X3D added to a VRML97 node

    @property
    def has_value(self) -> bool:
        return self.kind in ("field", "exposedField")

    def __eq__(self, other):
        from .scene import values_equal  # the equality of values lives with the scene graph
        return (isinstance(other, FieldDecl) and (self.kind, self.type, self.name)
                == (other.kind, other.type, other.name)
                and values_equal(self.type, self.default, other.default))


class Interface:
    """Field lookup shared by built-in node types, PROTOs and EXTERNPROTOs."""

    name: str
    fields: dict
    aliases: dict = {}
    alias_origin: dict = {}

    def field(self, name: str) -> Optional[FieldDecl]:
        """The declaration of field ``name`` (or of an alias of it), or None."""
        decl = self.fields.get(name)
        if decl is None and name in self.aliases:
            decl = self.fields.get(self.aliases[name])
        return decl

    def event(self, name: str) -> Optional[tuple]:
        """(declaration, direction) for an event name; direction is "in" or "out".

        An exposedField ``x`` answers to ``x``, ``set_x`` (in) and ``x_changed`` (out);
        a plain ``x`` of an exposedField is returned with direction "inout".
        """
        decl = self.field(name)
        if decl is not None:
            return decl, {"eventIn": "in", "eventOut": "out", "field": "field",
                          "exposedField": "inout"}[decl.kind]
        if name.startswith("set_"):
            decl = self.field(name[4:])
            if decl is not None and decl.kind == "exposedField":
                return decl, "in"
        if name.endswith("_changed"):
            decl = self.field(name[:-8])
            if decl is not None and decl.kind == "exposedField":
                return decl, "out"
        return None

    @property
    def classes(self) -> Optional[frozenset]:
        """Node classes of nodes of this type (None: unknown, fits anywhere)."""
        return None


class NodeType(Interface):
    """A built-in node type: name, node classes, fields in spec order, aliases."""

    def __init__(self, name: str, classes: frozenset, fields: dict, aliases: dict):
        self.name = name
        self._classes = classes
        self.fields = fields
        self.aliases = aliases
        self.alias_origin: dict = {}

    @property
    def classes(self) -> frozenset:
        return self._classes

    def __repr__(self) -> str:
        return f"<NodeType {self.name}>"


_STRING_RE = re.compile(r'"(?:[^"\\]|\\.)*"')


def _default(ftype: FieldType, text: str) -> Any:
    """A catalogue default from its VRML text: NULL, TRUE/FALSE, numbers, strings or
    ``[]`` are all the table holds, so it is read here without building the parser
    (``import mpeg4fba.vrml`` stays quick); ``tests/test_vrml_reader.py`` checks every
    default against the reader's own :func:`~mpeg4fba.vrml.reader.parse_value`."""
    body = text.strip()
    bracketed = body.startswith("[")
    if bracketed:
        body = body[1:-1].strip()
    if ftype.kind == "node":
        if body not in ("", "NULL"):
            raise ValueError(f"a node default must be NULL or [], not {text!r}")
        return [] if ftype.mf else None
    if ftype.kind == "bool":
        return body == "TRUE"
    if ftype.kind == "string":
        values = [unquote_string(m) for m in _STRING_RE.findall(body)]
        return values if ftype.mf else values[0]
    if not body:
        return ftype.empty()
    return ftype.from_numbers(parse_numbers(body, integer=ftype.kind in ("int", "image")),
                              bracketed)


def _load() -> dict:
    text = resources.files(__package__).joinpath("data", "nodes.tsv").read_text("utf-8")
    types: dict = {}
    lines = text.splitlines()
    for lineno, line in enumerate(lines[1:], start=2):
        if not line.strip() or line.startswith("#"):
            continue
        node, kind, ftype, name, default, accepts, origin = line.split("\t")
        if kind == "node":
            types[node] = NodeType(node, frozenset(ftype.split(",")), {}, {})
        elif kind == "alias":
            types[node].aliases[name] = default
            if origin:
                types[node].alias_origin[name] = origin
        else:
            t = FIELD_TYPES[ftype]
            value = _default(t, default) if default else t.empty()
            acc = None if not accepts or accepts == "any" else tuple(accepts.split(","))
            types[node].fields[name] = FieldDecl(kind, t, name, value, acc, origin=origin or None)
    return types


NODE_TYPES: dict[str, NodeType] = _load()

#: The 54 standard nodes of VRML97 (the rest of NODE_TYPES are MPEG-4 face nodes).
VRML97_NODES = frozenset(n for n in NODE_TYPES if n not in {
    "Face", "FAP", "FDP", "FIT", "FaceDefTables", "FaceDefMesh", "FaceDefTransform",
    "Viseme", "Expression"})
