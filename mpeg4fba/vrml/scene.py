"""The scene graph: Scene, Node, Proto, ExternProto, Route.

Nodes shared with DEF/USE are one Python object in several places.  Everything that
walks the graph here is iterative, so a 100,000-deep file costs no recursion.

Example
-------
>>> from mpeg4fba.vrml import Node, Scene
>>> box = Node("Shape", geometry=Node("Box", size=(1, 2, 3)))
>>> t = Node("Transform", translation=(0, 1, 0), children=[box, box])
>>> t["children"][0] is t["children"][1]
True
>>> t["scale"]                      # not set: the default
(1.0, 1.0, 1.0)
>>> Scene([t]) == Scene([t])
True
"""
from __future__ import annotations

from typing import Any, Iterator, Optional, Union

import numpy as np

from .catalogue import NODE_TYPES, FieldDecl, Interface, NodeType
from .errors import Source, VRMLError
from .fields import FIELD_TYPES, FieldType

__all__ = ["Node", "Proto", "ExternProto", "Route", "Scene", "values_equal", "iter_nodes"]


class Node:
    """One node: its type, the fields set explicitly, and for Script its own interface.

    ``node[name]`` gives the explicit value or the declared default; ``node[name] = v``
    sets (and type-checks) a field; ``node.fields`` holds only explicit values, in the
    order they were given.  ``name`` is the DEF name (or None).  In PROTO bodies,
    ``is_map`` maps a field or event of this node to the PROTO field it is bound to
    with IS.  ``statements`` keeps ROUTEs and PROTOs written inside the node's body.
    """

    __slots__ = ("type", "decl", "fields", "name", "_is_map", "_interface", "_statements",
                 "_source", "_pos", "__weakref__")

    def __init__(self, type: str, /, decl: Optional[Interface] = None, name: Optional[str] = None,
                 **fields: Any):
        # ``type`` is positional-only so that a field called "type" (NavigationInfo.type)
        # can be given as a keyword.
        self.type = type
        if decl is None:
            decl = NODE_TYPES.get(type)
            if decl is None:
                raise ValueError(f"unknown node type {type!r}; pass decl= for PROTO instances")
        self.decl = decl
        self.fields: dict = {}
        self.name = name
        # Most nodes have no IS, interface or statements: those three are made on first
        # use, which saves ~180 bytes a node (a million-node file: 180 MB).
        self._is_map = self._interface = self._statements = None
        self._source = None
        self._pos = None
        for k, v in fields.items():
            self[k] = v

    @classmethod
    def _raw(cls, type: str, decl: Optional[Interface], source, pos) -> "Node":
        """Fast constructor for the reader (no checks; ``decl`` None for generic nodes)."""
        n = cls.__new__(cls)
        n.type = type
        n.decl = decl
        n.fields = {}
        n.name = None
        n._is_map = n._interface = n._statements = None
        n._source = source
        n._pos = pos
        return n

    @property
    def is_map(self) -> dict:
        if self._is_map is None:
            self._is_map = {}
        return self._is_map

    @is_map.setter
    def is_map(self, value: dict) -> None:
        self._is_map = value

    @property
    def interface(self) -> list:
        if self._interface is None:
            self._interface = []
        return self._interface

    @interface.setter
    def interface(self, value: list) -> None:
        self._interface = value

    @property
    def statements(self) -> list:
        if self._statements is None:
            self._statements = []
        return self._statements

    @statements.setter
    def statements(self, value: list) -> None:
        self._statements = value

    # -- fields ---------------------------------------------------------------------------
    def field_decl(self, name: str) -> Optional[FieldDecl]:
        """Declaration of field ``name`` (Script interface fields included)."""
        for d in self._interface or ():
            if d.name == name:
                return d
        return self.decl.field(name) if self.decl is not None else None

    def __getitem__(self, name: str) -> Any:
        if name in self.fields:
            return self.fields[name]
        d = self.field_decl(name)
        if d is None:
            raise KeyError(f"{self.type} has no field {name!r}")
        if d.name in self.fields:  # an alias of an explicit field
            return self.fields[d.name]
        return d.default

    def get(self, name: str, default: Any = None) -> Any:
        try:
            return self[name]
        except KeyError:
            return default

    def __setitem__(self, name: str, value: Any) -> None:
        d = self.field_decl(name)
        if d is None:
            if self.decl is None:  # generic node: keep as given
                self.fields[name] = value
                return
            raise KeyError(f"{self.type} has no field {name!r}")
        if not d.has_value:
            raise KeyError(f"{self.type}.{name} is an {d.kind}; it holds no value")
        try:
            self.fields[d.name] = d.type.coerce(value)
        except (TypeError, ValueError) as e:
            raise ValueError(f"{self.type}.{name}: {e}") from None

    def __contains__(self, name: str) -> bool:
        return self.field_decl(name) is not None or name in self.fields

    def is_set(self, name: str) -> bool:
        d = self.field_decl(name)
        return (d.name if d is not None else name) in self.fields

    @property
    def classes(self) -> Optional[frozenset]:
        return self.decl.classes if self.decl is not None else None

    @property
    def is_proto_instance(self) -> bool:
        return isinstance(self.decl, (Proto, ExternProto))

    # -- where it came from ---------------------------------------------------------------
    @property
    def location(self) -> Optional[tuple]:
        """(path, line, column) where the node started in the text it was read from."""
        if self._source is None:
            return None
        return (self._source.path,) + self._source.line_column(self._pos)

    def children_nodes(self) -> list:
        """Nodes held directly in this node's SFNode/MFNode fields, in field order."""
        out = []
        for name, v in self.fields.items():
            if isinstance(v, Node):
                out.append(v)
            elif isinstance(v, list) and v and isinstance(v[0], Node):
                out.extend(v)
            elif isinstance(v, RawValue):
                out.extend(x for x in v.items if isinstance(x, Node))
        for d in self._interface or ():
            if d.type.kind == "node" and d.name not in self.fields:
                v = d.default
                if isinstance(v, Node):
                    out.append(v)
                elif isinstance(v, list):
                    out.extend(v)
        return out

    def __repr__(self) -> str:
        name = f"DEF {self.name} " if self.name else ""
        return f"<Node {name}{self.type} {{{' '.join(self.fields)}}}>"


class RawValue:
    """A field value of a node or field the reader did not know (lenient reading).

    ``items`` are the source texts of numbers, quoted strings, TRUE/FALSE/NULL, and
    Nodes, kept so that the writer gives them back unchanged.
    """

    __slots__ = ("items", "bracketed")

    def __init__(self, items: list, bracketed: bool):
        self.items = items
        self.bracketed = bracketed

    def __eq__(self, other):
        return (isinstance(other, RawValue) and self.bracketed == other.bracketed
                and len(self.items) == len(other.items)
                and all(isinstance(a, Node) and isinstance(b, Node) or a == b
                        for a, b in zip(self.items, other.items)))

    def __repr__(self):
        return f"RawValue({self.items!r}, bracketed={self.bracketed})"


class _Declared(Interface):
    """A node type the file declares: a name and an interface of FieldDecls."""

    def __init__(self, name: str, interface: Optional[list] = None):
        self.name = name
        self.fields = {d.name: d for d in (interface or [])}
        self._source = None
        self._pos = None

    @property
    def interface(self) -> list:
        return list(self.fields.values())


class Proto(_Declared):
    """A PROTO declaration: interface (declarations with defaults) and body statements."""

    def __init__(self, name: str, interface: Optional[list] = None, body: Optional[list] = None):
        super().__init__(name, interface)
        self.body: list = body or []

    @property
    def classes(self) -> Optional[frozenset]:
        """A PROTO's instances are of the type of its body's first node."""
        for s in self.body:
            if isinstance(s, Node):
                return s.classes
        return None

    def __repr__(self) -> str:
        return f"<Proto {self.name} [{' '.join(self.fields)}]>"


class ExternProto(_Declared):
    """An EXTERNPROTO declaration: interface without values, and the URLs."""

    def __init__(self, name: str, interface: Optional[list] = None, urls: Optional[list] = None):
        super().__init__(name, interface)
        self.urls: list = urls or []

    def __repr__(self) -> str:
        return f"<ExternProto {self.name} {self.urls!r}>"


class Route:
    """``ROUTE from_node.from_field TO to_node.to_field``, with the Node objects."""

    __slots__ = ("from_node", "from_field", "to_node", "to_field", "_source", "_pos")

    def __init__(self, from_node: Node, from_field: str, to_node: Node, to_field: str):
        self.from_node = from_node
        self.from_field = from_field
        self.to_node = to_node
        self.to_field = to_field
        self._source = None
        self._pos = None

    def __repr__(self) -> str:
        return (f"<ROUTE {self.from_node.name}.{self.from_field} TO "
                f"{self.to_node.name}.{self.to_field}>")


Statement = Union[Node, Proto, ExternProto, Route]


class Scene:
    """A VRML97 file: its statements (root nodes, PROTOs, ROUTEs) in order.

    ``nodes``, ``protos`` and ``routes`` are the statements of each kind at file level;
    ``defs`` maps DEF names to nodes (the last DEF of a name wins, as for USE).
    """

    def __init__(self, statements: Optional[list] = None, path: Optional[str] = None):
        self.statements: list = list(statements or [])
        self.path = path

    @property
    def nodes(self) -> list:
        return [s for s in self.statements if isinstance(s, Node)]

    @property
    def protos(self) -> list:
        return [s for s in self.statements if isinstance(s, (Proto, ExternProto))]

    @property
    def routes(self) -> list:
        """All ROUTEs of the file scope, including those written inside node bodies."""
        out = [s for s in self.statements if isinstance(s, Route)]
        for n in iter_nodes(self.nodes):
            out.extend(s for s in n._statements or () if isinstance(s, Route))
        return out

    @property
    def defs(self) -> dict:
        out = {}
        for n in iter_nodes(self.nodes):
            if n.name is not None:
                out[n.name] = n
        return out

    def find(self, name: str) -> Node:
        """The node DEF'd as ``name`` (the last one if the name is reused).

        >>> from mpeg4fba import vrml
        >>> vrml.loads('#VRML V2.0 utf8\\nDEF Head Transform {}').find("Head").type
        'Transform'
        """
        defs = self.defs
        if name not in defs:
            import difflib
            close = difflib.get_close_matches(name, list(defs), n=3)
            hint = f"; did you mean {', '.join(close)}?" if close else ""
            raise KeyError(f"no node DEF'd as {name!r} in the scene{hint}")
        return defs[name]

    def __iter__(self) -> Iterator[Node]:
        """Every distinct node of the file scope, depth-first, parents first."""
        return iter_nodes(self.nodes)

    def __eq__(self, other) -> bool:
        if not isinstance(other, Scene):
            return NotImplemented
        return _Comparer().statements(self.statements, other.statements)

    def __repr__(self) -> str:
        return (f"<Scene {len(self.nodes)} root nodes, {len(self.protos)} protos, "
                f"{len(self.routes)} routes>")


def iter_nodes(roots: list) -> Iterator[Node]:
    """Each node reachable from ``roots`` once, depth-first pre-order, without recursion.

    PROTO bodies are not entered (their nodes belong to the PROTO, not the scene).
    """
    seen = set()
    stack = list(reversed(roots))
    while stack:
        n = stack.pop()
        if id(n) in seen:
            continue
        seen.add(id(n))
        yield n
        stack.extend(reversed(n.children_nodes()))


# -- structural equality ----------------------------------------------------------------

def values_equal(ftype: FieldType, a: Any, b: Any) -> bool:
    """Equality of two non-node field values of one type (arrays compared exactly)."""
    if ftype.kind == "node":
        return _Comparer().value(a, b)
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return (isinstance(a, np.ndarray) and isinstance(b, np.ndarray)
                and a.shape == b.shape and np.array_equal(a, b))
    return a == b


def _declarations_first(statements: list) -> list:
    """A node body's statements, its PROTO and EXTERNPROTO declarations first."""
    return sorted(statements, key=lambda s: not isinstance(s, (Proto, ExternProto)))


class _Comparer:
    """Structural comparison of graphs: same shape, same values, same sharing."""

    def __init__(self):
        self.pairs: dict = {}   # id(a) -> id(b) of nodes already matched
        self.stack: list = []

    def statements(self, xs: list, ys: list) -> bool:
        if len(xs) != len(ys):
            return False
        for x, y in zip(xs, ys):
            if type(x) is not type(y):
                return False
            if isinstance(x, Node):
                if not self.value(x, y):
                    return False
            elif isinstance(x, Route):
                if (x.from_field, x.to_field) != (y.from_field, y.to_field):
                    return False
                if not (self.value(x.from_node, y.from_node) and self.value(x.to_node, y.to_node)):
                    return False
            elif isinstance(x, Proto):
                if x.name != y.name or list(x.fields.values()) != list(y.fields.values()):
                    return False
                if not self.statements(x.body, y.body):
                    return False
            elif isinstance(x, ExternProto):
                if (x.name, x.urls) != (y.name, y.urls) or [
                        (d.kind, d.type, d.name) for d in x.fields.values()] != [
                        (d.kind, d.type, d.name) for d in y.fields.values()]:
                    return False
        return True

    def value(self, a: Any, b: Any) -> bool:
        """Compare two SFNode/MFNode values (or nodes) and everything below them."""
        self.stack.append((a, b))
        while self.stack:
            a, b = self.stack.pop()
            if isinstance(a, list) or isinstance(b, list):
                if not (isinstance(a, list) and isinstance(b, list)) or len(a) != len(b):
                    return False
                self.stack.extend(zip(a, b))
                continue
            if a is None or b is None:
                if a is not b:
                    return False
                continue
            if not (isinstance(a, Node) and isinstance(b, Node)):
                return False
            seen = self.pairs.get(id(a))
            if seen is not None:
                if seen != id(b):
                    return False
                continue
            self.pairs[id(a)] = id(b)
            if not self._node_shallow(a, b):
                return False
        return True

    def _node_shallow(self, a: Node, b: Node) -> bool:
        if (a.type, a.name, a._is_map or {}) != (b.type, b.name, b._is_map or {}):
            return False
        if list(a.fields) != list(b.fields):
            return False
        if [(d.kind, d.type, d.name) for d in a._interface or ()] != \
                [(d.kind, d.type, d.name) for d in b._interface or ()]:
            return False
        for d1, d2 in zip(a._interface or (), b._interface or ()):
            if d1.type.kind == "node":
                self.stack.append((d1.default, d2.default))
            elif not values_equal(d1.type, d1.default, d2.default):
                return False
        for k, va in a.fields.items():
            vb = b.fields[k]
            if isinstance(va, RawValue) or isinstance(vb, RawValue):
                if not (isinstance(va, RawValue) and isinstance(vb, RawValue)) or \
                        va.bracketed != vb.bracketed or len(va.items) != len(vb.items):
                    return False
                for x, y in zip(va.items, vb.items):
                    if isinstance(x, Node):
                        self.stack.append((x, y))
                    elif x != y:
                        return False
                continue
            d = a.field_decl(k)
            if d is None:
                if va != vb:
                    return False
            elif d.type.kind == "node":
                self.stack.append((va, vb))
            elif not values_equal(d.type, va, vb):
                return False
        if len(a._statements or ()) != len(b._statements or ()):
            return False
        # a body's PROTOs and its ROUTEs keep their order within each kind; which kind
        # came first does not matter (the writer puts the PROTOs before the fields)
        sub = list(zip(_declarations_first(a._statements or ()),
                       _declarations_first(b._statements or ())))
        for x, y in sub:
            if type(x) is not type(y):
                return False
            if isinstance(x, Route):
                if (x.from_field, x.to_field) != (y.from_field, y.to_field):
                    return False
                self.stack.append((x.from_node, y.from_node))
                self.stack.append((x.to_node, y.to_node))
            elif not _Comparer().statements([x], [y]):
                return False
        return True
