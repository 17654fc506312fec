"""Scene -> VRML97 text: ``dumps(scene)`` and ``dump(scene, path)``.

Canonical output: two-space indentation, one field per line, explicit fields only,
DEF at a shared node's first place and USE after, floats in the shortest form that
reads back to the same float64.  The writer is a loop over a work stack, not a
recursion, so any depth of nesting writes; indentation stops growing at 40 levels
so that deep files stay linear in size.

Example
-------
>>> from mpeg4fba.vrml import Node, Scene, dumps
>>> print(dumps(Scene([Node("Transform", translation=(0, 1.5, 0))])), end="")
#VRML V2.0 utf8
<BLANKLINE>
Transform {
  translation 0 1.5 0
}
"""
from __future__ import annotations

from .._atomic import atomic_open

import gzip
import os
from typing import Optional, Union

from .errors import VRMLError
from .fields import WRITE_NAN, FieldType, quote_string
from .scene import ExternProto, Node, Proto, RawValue, Route, Scene

__all__ = ["dump", "dumps"]

HEADER = "#VRML V2.0 utf8\n"
_MAX_INDENT = 40


def _valid_name(name: str) -> bool:
    """Whether ``name`` reads back as the same DEF name (the grammar decides)."""
    from .reader import is_name
    return is_name(name)


def _indent(level: int) -> str:
    return "  " * min(level, _MAX_INDENT)


class _Sink(list):
    """The writer's output for :func:`dump`: pieces of text gathered and written to a
    binary file about a MiB at a time, so a big scene is never one string and its bytes
    at once."""

    FLUSH = 1 << 20

    def __init__(self, file) -> None:
        super().__init__()
        self.file = file
        self.size = 0

    def append(self, piece: str) -> None:
        super().append(piece)
        self.size += len(piece)
        if self.size >= self.FLUSH:
            self.flush()

    def flush(self) -> None:
        # invalid bytes read in go back as they were
        self.file.write("".join(self).encode("utf-8", "surrogateescape"))
        self.clear()
        self.size = 0


class _Writer:
    def __init__(self, out: Optional[list] = None):
        self.out: list = [] if out is None else out
        self.names: dict = {}     # id(node) -> name used for DEF/USE
        self.written: set = set()  # ids of nodes already written (in this scope)
        self.bound: dict = {}      # DEF name -> id(node) it refers to now

    # -- naming ---------------------------------------------------------------------------
    def plan_names(self, statements: list) -> None:
        """Give a DEF name to every node used twice or named by a ROUTE and unnamed."""
        count: dict = {}
        routed: set = set()
        nodes: dict = {}
        taken: set = set()
        stack = [s for s in reversed(statements)]
        while stack:
            s = stack.pop()
            if isinstance(s, Route):
                routed.add(id(s.from_node))
                routed.add(id(s.to_node))
                nodes[id(s.from_node)] = s.from_node
                nodes[id(s.to_node)] = s.to_node
                continue
            if not isinstance(s, Node):
                continue  # PROTO bodies are planned when written, in their own scope
            k = id(s)
            count[k] = count.get(k, 0) + 1
            if count[k] > 1:
                continue
            nodes[k] = s
            if s.name:
                taken.add(s.name)
            stack.extend(reversed(s._statements or ()))
            stack.extend(reversed(s.children_nodes()))
        serial = 0
        for k, n in nodes.items():
            if not n.name and (count.get(k, 0) > 1 or k in routed):
                serial += 1
                while f"_{serial}" in taken:
                    serial += 1
                # VRML needs a DEF name to share a node; the name is kept on the node, so
                # the scene written and the scene read back are equal, names included.
                n.name = f"_{serial}"
            if n.name:
                self.names[k] = n.name

    # -- output ---------------------------------------------------------------------------
    def run(self, ops: list) -> None:
        out = self.out
        stack = list(reversed(ops))
        while stack:
            op = stack.pop()
            if type(op) is str:
                out.append(op)
                continue
            kind = op[0]
            if kind == "node":
                more = self.node(op[1], op[2])
            elif kind == "stmt":
                more = self.statement(op[1], op[2])
            else:  # "call": run a bookkeeping function in document order
                op[1]()
                continue
            stack.extend(reversed(more))

    def statement(self, s, level: int) -> list:
        ind = _indent(level)
        if isinstance(s, Node):
            return [ind, ("node", s, level), "\n"]
        if isinstance(s, Route):
            return [ind + f"ROUTE {self.name_of(s.from_node)}.{s.from_field} TO "
                    f"{self.name_of(s.to_node)}.{s.to_field}\n"]
        if isinstance(s, Proto):
            return self.proto(s, level)
        if isinstance(s, ExternProto):
            ops = [ind + f"EXTERNPROTO {s.name} [\n"]
            for d in s.fields.values():
                ops.append(_indent(level + 1) + f"{d.kind} {d.type.name} {d.name}\n")
            urls = s.urls
            ops.append(ind + "] " + (quote_string(urls[0]) if len(urls) == 1 else
                                     "[ " + " ".join(map(quote_string, urls)) + " ]") + "\n")
            return ops
        raise VRMLError(f"can't write a {type(s).__name__} as a VRML statement")

    def name_of(self, node: Node) -> str:
        name = self.names.get(id(node))
        if name is None:
            raise VRMLError(f"a ROUTE names a {node.type} node that is not in the scene")
        return name

    def scoped(self, statements: list, ops: list) -> list:
        """``ops`` written in a DEF/USE scope of their own, whose names are planned over
        ``statements`` (a PROTO body; a PROTO field's default value)."""
        saved = []

        def enter():
            saved.append((self.names, self.written, self.bound))
            self.names, self.written, self.bound = {}, set(), {}
            self.plan_names(statements)

        def leave():
            self.names, self.written, self.bound = saved.pop()

        return [("call", enter)] + ops + [("call", leave)]

    def proto(self, p: Proto, level: int) -> list:
        ind = _indent(level)
        ops = [ind + f"PROTO {p.name} [\n"]
        for d in p.fields.values():
            decl = self.declaration(d, None, level + 1)
            if d.type.kind == "node" and d.has_value:
                # each field's default value is a DEF/USE scope of its own
                nodes = d.default if d.type.mf else [d.default]
                decl = self.scoped([n for n in nodes if n is not None], decl)
            ops.extend(decl)
        ops.append(ind + "]\n" + ind + "{\n")
        ops.extend(self.scoped(p.body, [("stmt", s, level + 1) for s in p.body]))
        ops.append(ind + "}\n")
        return ops

    def declaration(self, d, bound_to, level: int) -> list:
        """``kind type name`` plus its value, or ``IS bound_to`` when it is bound."""
        line = _indent(level) + f"{d.kind} {d.type.name} {d.name}"
        if bound_to is not None:
            return [line + f" IS {bound_to}\n"]
        if d.has_value:
            return [line + " "] + self.value(d.type, d.default, level) + ["\n"]
        return [line + "\n"]

    def node(self, node: Node, level: int) -> list:
        k = id(node)
        name = self.names.get(k)
        if k in self.written:
            if self.bound.get(name) != k:
                raise VRMLError(f"can't write USE {name}: a later node took the DEF name {name!r}; "
                                f"rename one of them")
            return [f"USE {name}"]
        self.written.add(k)
        if name and not _valid_name(name):
            raise VRMLError(f"can't write DEF {name!r}: not a VRML97 name (no spaces, no leading "
                            "digit or sign, none of \" # ' , . [ \\ ] { })")
        head = (f"DEF {name} " if name else "") + node.type + " {"
        if name:
            self.bound[name] = k
        # (the private lists: reading the public ones would make them for every node)
        interface, is_map, statements = node._interface or (), node._is_map or {}, \
            node._statements or ()
        if not (node.fields or interface or is_map or statements):
            return [head + " }"]
        ind = _indent(level + 1)
        ops = [head + "\n"]
        # PROTOs declared in the body go first, so every use in the fields follows its
        # declaration; ROUTEs last, after the DEFs they name
        declared = [s for s in statements if isinstance(s, (Proto, ExternProto))]
        for s in declared:
            ops.append(("stmt", s, level + 1))
        interface_names = set()
        for d in interface:
            interface_names.add(d.name)
            ops.extend(self.declaration(d, is_map.get(d.name), level + 1))
        for fname, value in node.fields.items():
            ops.append(ind + fname + " ")
            if isinstance(value, RawValue):
                ops.extend(self.raw(value, level + 1))
            else:
                d = node.field_decl(fname)
                ops.extend(self.value(d.type, value, level + 1))
            ops.append("\n")
        for fname, pname in is_map.items():
            if fname not in interface_names:
                ops.append(ind + f"{fname} IS {pname}\n")
        for s in statements:
            if not isinstance(s, (Proto, ExternProto)):
                ops.append(("stmt", s, level + 1))
        ops.append(_indent(level) + "}")
        return ops

    def value(self, ftype: FieldType, value, level: int) -> list:
        if ftype.kind != "node":
            try:
                return ftype.format_parts(value, _indent(level))
            except ValueError as e:
                raise VRMLError(f"can't write a {ftype.name} value: {e}") from None
        if not ftype.mf:
            return ["NULL"] if value is None else [("node", value, level)]
        if not value:
            return ["[]"]
        if len(value) == 1:
            return [("node", value[0], level)]
        ind = _indent(level + 1)
        ops = ["[\n"]
        for n in value:
            ops.extend([ind, ("node", n, level + 1), "\n"])
        ops.append(_indent(level) + "]")
        return ops

    def raw(self, value: RawValue, level: int) -> list:
        ops: list = []
        for i, item in enumerate(value.items):
            if i:
                ops.append(" ")
            ops.append(("node", item, level + 1) if isinstance(item, Node) else item)
        if value.bracketed:
            return ["[ "] + ops + [" ]"]
        return ops


def dumps(scene: Scene, strict: bool = True) -> str:
    """The VRML97 text of ``scene``.  Raises VRMLError for values VRML97 can't hold.

    A node used in several places (or named by a ROUTE) without a DEF name is given one,
    ``_1``, ``_2``..., stored on the node: VRML97 can share a node only through a name.
    ``strict=False`` writes NaN as ``nan``, as the lenient reader reads it (infinity is
    refused either way).
    """
    w = _Writer()
    _write(w, scene, strict)
    return HEADER + "\n" + "".join(w.out)


def _write(w: _Writer, scene: Scene, strict: bool) -> None:
    w.plan_names(scene.statements)
    ops: list = []
    for s in scene.statements:
        ops.append(("stmt", s, 0))
    token = WRITE_NAN.set(not strict)
    try:
        w.run(ops)
    finally:
        WRITE_NAN.reset(token)


def dump(scene: Scene, path: Union[str, os.PathLike], strict: bool = True) -> None:
    """Write ``scene`` to ``path``, gzip-compressed when it ends in ``.gz`` or ``.wrz`` (any case).

    The file is written to a temporary name beside it and renamed, so a failure never
    leaves a half-written file; the text goes out a MiB at a time, never whole in memory.
    """
    path = os.fspath(path)
    with atomic_open(path) as raw:
        # OUT.WRZ too: never plain text under a gzip name
        packed = path.lower().endswith((".gz", ".wrz"))
        f = gzip.GzipFile(fileobj=raw, mode="wb", compresslevel=6, mtime=0) if packed else raw
        try:
            sink = _Sink(f)
            sink.append(HEADER + "\n")
            _write(_Writer(sink), scene, strict)
            sink.flush()
        finally:
            if packed:
                f.close()


