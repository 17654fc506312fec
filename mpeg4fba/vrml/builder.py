"""The VRML97 reader's transformer: one method per grammar rule, called as lark's LALR
parser reduces it (:mod:`mpeg4fba.vrml.reader`), so no parse tree is ever built.  Each
callback types and checks what it reduces, knowing (through the ``*_head`` rules) which
node or PROTO it is in, and builds the scene graph (:mod:`mpeg4fba.vrml.scene`).

>>> from mpeg4fba.vrml.reader import loads
>>> loads('#VRML V2.0 utf8\\nDEF T Transform { translation 0 1 0 }').find("T")["translation"]
(0.0, 1.0, 0.0)
"""
from __future__ import annotations

import difflib
import warnings
from typing import Optional

from .errors import Source, VRMLError, VRMLWarning
from .fields import FIELD_TYPES, unquote_string
from .lexer import Tok
from .values import MF, NAN_WORD_RE, ValueReader, kind_text

__all__ = ["Builder", "MF", "kind_text", "NAN_WORD_RE", "X3D_WORDS"]

#: X3D's words, named as such when a VRML97 reader meets them.
X3D_WORDS = {"IMPORT", "EXPORT", "COMPONENT", "PROFILE", "META", "UNIT", "AS",
             "inputOnly", "outputOnly", "initializeOnly", "inputOutput"}

class _Scope:
    """File or PROTO-body scope: its PROTO types and DEF names."""

    __slots__ = ("parent", "proto", "protos", "defs", "defaults")

    def __init__(self, parent: Optional["_Scope"], proto, defaults: bool = False):
        self.parent = parent
        self.proto = proto
        self.protos: dict = {}
        self.defs: dict = {}
        #: a PROTO interface: each field's default value is a DEF/USE scope of its own
        self.defaults = defaults

    def lookup_type(self, name: str):
        s = self
        while s is not None:
            t = s.protos.get(name)
            if t is not None:
                return t
            s = s.parent
        return None


_IS_RULES = {  # node side kind -> PROTO interface kinds it may be bound to (VRML97 4.8.3)
    "inout": ("exposedField", "field", "eventIn", "eventOut"),
    "field": ("field",),
    "in": ("eventIn",),
    "out": ("eventOut",),
}


def _lenient_is(node_kind: str, proto_kind: str) -> bool:
    """Whether the lenient reader keeps an IS that VRML97's table (4.8.3) forbids: a
    field or an event bound to an exposedField, which X3D allows (its table is VRML97's
    with these added; an exposedField carries a value and both events); any other
    mismatch means nothing and stays an error."""
    return proto_kind == "exposedField" and node_kind != "exposedField"


def _implicit_clash(d, declared: dict) -> Optional[str]:
    """Why ``d`` may not join the interface ``declared`` (name -> declaration), or None:
    ``exposedField foo`` declares ``eventIn set_foo`` and ``eventOut foo_changed`` as well
    (VRML97 4.7), and a node type's interface names are unique.

    >>> from types import SimpleNamespace as D
    >>> _implicit_clash(D(kind="eventIn", name="set_size"), {"size": D(kind="exposedField")})
    'its exposedField size already declares eventIn set_size'
    """
    if d.kind == "exposedField":
        for kind, name in (("eventIn", f"set_{d.name}"), ("eventOut", f"{d.name}_changed")):
            if name in declared:
                return f"that declares {kind} {name}, which is already declared"
        return None
    for base in ((d.name[4:],) if d.name.startswith("set_") else ()) + \
            ((d.name[:-8],) if d.name.endswith("_changed") else ()):
        other = declared.get(base)
        if other is not None and other.kind == "exposedField":
            return f"its exposedField {base} already declares {d.kind} {d.name}"
    return None


class Builder(ValueReader):
    """The transformer: one method per grammar rule, called as lark reduces it."""

    Node = Proto = ExternProto = Route = Scene = RawValue = type("_Unbound", (), {})

    def __init__(self):
        self.bound = False
        self.reset(Source(""), True)

    def bind(self) -> None:
        """Import the scene graph and catalogue (not at import: they need parse_value)."""
        from .catalogue import NODE_TYPES
        from .scene import ExternProto, Node, Proto, RawValue, Route, Scene
        self.NODE_TYPES = NODE_TYPES
        self.SCRIPT = NODE_TYPES["Script"]
        self.Node, self.Proto, self.ExternProto = Node, Proto, ExternProto
        self.Route, self.Scene, self.RawValue = Route, Scene, RawValue
        self.bound = True

    def reset(self, source: Source, strict: bool) -> None:
        self.src = source
        self.text = source.text
        self.strict = strict
        self.scope = _Scope(None, None)
        self.frames: list = []
        self.warned: set = set()
        self.pending_def = None
        self.open_defs: set = set()   # ids of DEF'd nodes whose bodies are being read

    # -- helpers --------------------------------------------------------------------------
    def err(self, message: str, pos: Optional[int], expected=()) -> VRMLError:
        return self.src.error(message, pos, expected)

    def warn(self, key: str, message: str, pos: int) -> None:
        if key in self.warned:
            return
        self.warned.add(key)
        e = self.src.error(message, pos)
        warnings.warn(str(e), VRMLWarning, stacklevel=2)

    def pos_of(self, value) -> Optional[int]:
        if isinstance(value, Tok):
            return value.start_pos
        if isinstance(value, self.Node):
            return value._pos
        return getattr(value, "pos", None)

    def unknown_field(self, node, name: str, pos: int) -> VRMLError:
        names = list(node.decl.fields) + [d.name for d in node.interface]
        close = difflib.get_close_matches(name, names, n=3)
        return self.err(f"{node.type} has no field {name!r}", pos,
                        [repr(c) for c in close] if close else ())

    def node_event(self, node, name: str):
        for d in node._interface or ():
            if d.name == name:
                return d, {"eventIn": "in", "eventOut": "out", "field": "field",
                           "exposedField": "inout"}[d.kind]
        return node.decl.event(name)

    # -- rules ----------------------------------------------------------------------------
    def start(self, items):
        statements = [s for s in items if s is not None]
        for s in statements:
            if isinstance(s, self.Node) and s.decl is not None:
                classes = s.classes
                if classes is not None and "child" not in classes:
                    message = f"a {s.type} node can't be a root node of a file"
                    if self.strict:
                        raise self.err(message, s._pos, [
                            "a grouping, shape, sensor, light, interpolator, bindable or "
                            "Script node"])
                    self.warn("root:" + s.type, message + "; kept", s._pos)
        return self.Scene(statements)

    def node_head(self, items):
        tok = items[0]
        name = tok.value
        decl = self.scope.lookup_type(name) or self.NODE_TYPES.get(name)
        if decl is None:
            if name in X3D_WORDS:
                raise self.err(f"{name} is X3D, not VRML97", tok.start_pos)
            if self.strict:
                close = difflib.get_close_matches(
                    name, list(self.NODE_TYPES) + self.visible_protos(), n=3)
                raise self.err(f"unknown node type {name!r}", tok.start_pos,
                               [repr(c) for c in close] if close else ())
            self.warn("node:" + name, f"{name} is not a VRML97 node type; kept as a generic node",
                      tok.start_pos)
        if decl is not None and decl.name == name:
            name = decl.name            # one string for all nodes of a type, not one each
        node = self.Node._raw(name, decl, self.src, tok.start_pos)
        if self.pending_def is not None:
            node.name = self.pending_def.value
            self.scope.defs[node.name] = node
            self.open_defs.add(id(node))
            self.pending_def = None
        self.frames.append(node)
        return node

    def visible_protos(self) -> list:
        out, s = [], self.scope
        while s is not None:
            out.extend(s.protos)
            s = s.parent
        return out

    def node(self, items):
        node = items[0]
        self.frames.pop()
        for s in items[1:]:
            if s is not None:
                node.statements.append(s)
        return node

    def field(self, items):
        tok, value = items
        node = self.frames[-1]
        name = tok.value
        if node.decl is None:
            node.fields[name] = self.raw(value)
            return None
        d = node.decl.fields.get(name) if not node._interface else None
        if d is None:
            d = node.field_decl(name)          # an alias, or a Script's own field
        if d is None:
            if self.strict:
                raise self.unknown_field(node, name, tok.start_pos)
            self.warn(f"field:{node.type}.{name}",
                      f"{node.type} has no field {name!r}; kept as written", tok.start_pos)
            node.fields[name] = self.raw(value)
            return None
        if d.kind != "field" and d.kind != "exposedField":
            raise self.err(f"{node.type}.{name} is an {d.kind}: it can't be given a value",
                           tok.start_pos, ["a field or exposedField"])
        if d.origin is not None or (d.name != name and name in node.decl.alias_origin):
            self.warn(f"x3d:{node.type}.{name}", f"{node.type}.{name} is an X3D field, not "
                      "VRML97; accepted" + (f" as {d.name}" if d.name != name else ""),
                      tok.start_pos)
        node.fields[d.name] = self.convert(d, value, node.type, name)
        return None

    def is_field(self, items):
        tok, _, ptok = items
        node = self.frames[-1]
        proto = self.scope.proto
        if proto is None:
            raise self.err("IS is only allowed inside a PROTO body", tok.start_pos)
        pd = proto.fields.get(ptok.value)
        if pd is None:
            close = difflib.get_close_matches(ptok.value, list(proto.fields), n=3)
            raise self.err(f"PROTO {proto.name} has no field {ptok.value!r} to bind with IS",
                           ptok.start_pos, [repr(c) for c in close])
        if node.decl is not None:
            ev = self.node_event(node, tok.value)
            if ev is None:
                raise self.unknown_field(node, tok.value, tok.start_pos)
            self.check_is(node, tok, ev, pd, ptok)
        node.is_map[tok.value] = ptok.value
        return None

    def check_is(self, node, tok, ev, pd, ptok) -> None:
        d, direction = ev
        if d.type is not pd.type:
            raise self.err(f"{node.type}.{tok.value} is {d.type.name} but PROTO field "
                           f"{pd.name} is {pd.type.name}", ptok.start_pos, [d.type.name])
        if pd.kind not in _IS_RULES[direction]:
            message = (f"{node.type}.{tok.value} ({d.kind}) can't be bound with IS to "
                       f"{pd.kind} {pd.name}")
            if self.strict or not _lenient_is(d.kind, pd.kind):
                raise self.err(message, ptok.start_pos, [" or ".join(_IS_RULES[direction])])
            # seen in robot worlds: Box { size IS size } with an exposedField size
            self.warn(f"is:{node.type}.{tok.value}:{pd.name}", message + " in VRML97; kept",
                      ptok.start_pos)

    def decl_common(self, kind_tok, type_tok, name_tok):
        ftype = FIELD_TYPES.get(type_tok.value)
        if ftype is None:
            close = difflib.get_close_matches(type_tok.value, list(FIELD_TYPES), n=3)
            raise self.err(f"unknown field type {type_tok.value!r}", type_tok.start_pos,
                           [repr(c) for c in close] or ["a VRML97 field type"])
        from .catalogue import FieldDecl
        target = self.frames[-1]
        d = FieldDecl(kind_tok.value, ftype, name_tok.value, ftype.empty(), None,
                      kind_tok.start_pos)
        if isinstance(target, self.Node):
            if target.decl is not self.SCRIPT and target.decl is not None:
                raise self.err(f"interface declarations are only allowed in Script nodes, "
                               f"not in {target.type}", kind_tok.start_pos)
            if d.kind == "exposedField":
                raise self.err("a Script can't have an exposedField in VRML97",
                               kind_tok.start_pos, ["eventIn, eventOut or field"])
            old = target.field_decl(d.name)
            if old is not None:
                if old in target.interface and (old.kind, old.type) == (d.kind, d.type) \
                        and not d.has_value:
                    # Seen in the wild: the same event declared twice.  Harmless; keep one.
                    self.warn(f"dup:{d.name}", f"Script declares {d.kind} {d.name} twice; "
                              "the repeat is ignored", name_tok.start_pos)
                    return old, None
                raise self.err(f"Script already has a field or event named {d.name!r}",
                               name_tok.start_pos)
            target.interface.append(d)
        else:
            if d.name in target.fields:
                raise self.err(f"{target.name} already declares {d.name!r}", name_tok.start_pos)
            clash = _implicit_clash(d, target.fields)
            if clash is not None:
                raise self.err(f"{target.name} declares {d.kind} {d.name}, but {clash}",
                               name_tok.start_pos, ["an interface name of its own"])
            target.fields[d.name] = d
        return d, target

    def event_decl(self, items):
        self.decl_common(*items)
        return None

    def field_decl(self, items):
        kind_tok, type_tok, name_tok, value = items
        d, target = self.decl_common(kind_tok, type_tok, name_tok)
        owner = target.type if isinstance(target, self.Node) else target.name
        d.default = self.convert(d, value, owner, d.name, extra_ok=True)
        if self.scope.defaults:
            self.scope.defs = {}
        return None

    def is_decl(self, items):
        kind_tok, type_tok, name_tok, _, ptok = items
        d, node = self.decl_common(kind_tok, type_tok, name_tok)
        if node is None:
            raise self.err(f"Script already has a field or event named {d.name!r}",
                           name_tok.start_pos)
        proto = self.scope.proto
        if proto is None:
            raise self.err("IS is only allowed inside a PROTO body", name_tok.start_pos)
        pd = proto.fields.get(ptok.value)
        if pd is None:
            raise self.err(f"PROTO {proto.name} has no field {ptok.value!r} to bind with IS",
                           ptok.start_pos, [repr(c) for c in proto.fields])
        direction = {"eventIn": "in", "eventOut": "out", "field": "field"}[d.kind]
        self.check_is(node, name_tok, (d, direction), pd, ptok)
        node.is_map[d.name] = pd.name
        return None

    def extern_decl(self, items):
        kind_tok, type_tok, name_tok = items
        self.decl_common(kind_tok, type_tok, name_tok)
        return None

    def mfvalue(self, items):
        out = MF(items[1:])
        out.pos = items[0].start_pos
        return out

    def def_head(self, items):
        # Reduced before the node's type is read: node_head binds the name at once, so
        # that a USE inside the node's own body is recognised as a cycle.
        self.pending_def = items[0]
        return items[0]

    def def_node(self, items):
        tok, node = items
        self.open_defs.discard(id(node))
        return node

    def use_node(self, items):
        tok = items[0]
        node = self.scope.defs.get(tok.value)
        if node is None:
            close = difflib.get_close_matches(tok.value, list(self.scope.defs), n=3)
            where = " in this PROTO body" if self.scope.proto is not None else ""
            if self.scope.defaults:
                where = (" in this field's default value (each PROTO field's default is a "
                         "DEF/USE scope of its own)")
            raise self.err(f"USE {tok.value}: no node was DEF'd as {tok.value!r} before{where}",
                           tok.start_pos, [repr(c) for c in close])
        if id(node) in self.open_defs and not self.through_script(node):
            message = f"USE {tok.value} inside the node DEF'd as {tok.value} makes it its own ancestor"
            if self.strict:
                raise self.err(message, tok.start_pos)
            self.warn("cycle:" + tok.value, message + "; kept", tok.start_pos)
        return node

    def through_script(self, node) -> bool:
        """Whether a USE of the open ``node`` here reaches it through a Script's field: a
        Script's SFNode and MFNode fields are references, not the transformation
        hierarchy that may have no cycles (VRML97 4.4.2, 6.40), so the Script itself or
        a node holding it may be named there."""
        frames = self.frames
        for i in range(len(frames) - 1, -1, -1):
            f = frames[i]
            if getattr(f, "decl", None) is self.SCRIPT:
                return any(g is node for g in frames[:i + 1])
            if f is node:
                return False
        return False

    def route(self, items):
        fn, ff, _, tn, tf = items
        ends = []
        for ntok, ftok, want in ((fn, ff, "out"), (tn, tf, "in")):
            node = self.scope.defs.get(ntok.value)
            if node is None:
                raise self.err(f"ROUTE names {ntok.value!r}, which no DEF before it defines",
                               ntok.start_pos, [repr(c) for c in difflib.get_close_matches(
                                   ntok.value, list(self.scope.defs), n=3)])
            ev = None
            if node.decl is not None:
                ev = self.node_event(node, ftok.value)
                if ev is None:
                    raise self.err(f"{node.type} {ntok.value} has no event {ftok.value!r}",
                                   ftok.start_pos)
                d, direction = ev
                if direction != want and direction != "inout":
                    word = "eventOut" if want == "out" else "eventIn"
                    what = {"in": "eventIn", "out": "eventOut", "field": "field"}[direction]
                    what += "" if d.kind != "exposedField" else " of an exposedField"
                    raise self.err(f"ROUTE {'from' if want == 'out' else 'to'} "
                                   f"{ntok.value}.{ftok.value}, which is an {what}",
                                   ftok.start_pos, [f"an {word} or exposedField"])
            ends.append((node, ev))
        (a, ea), (b, eb) = ends
        if ea is not None and eb is not None and ea[0].type is not eb[0].type:
            raise self.err(f"ROUTE from {ea[0].type.name} {fn.value}.{ff.value} to "
                           f"{eb[0].type.name} {tn.value}.{tf.value}: the types differ",
                           tf.start_pos, [ea[0].type.name])
        r = self.Route(a, ff.value, b, tf.value)
        r._source, r._pos = self.src, fn.start_pos
        return r

    def proto_head(self, items):
        proto = self.open_declaration(self.Proto, items[0])
        self.scope = _Scope(self.scope, None, defaults=True)
        return proto

    def open_declaration(self, cls, tok):
        """A PROTO or EXTERNPROTO whose interface is about to be read."""
        p = cls(tok.value)
        p._source, p._pos = self.src, tok.start_pos
        self.frames.append(p)
        return p

    def proto_body_start(self, items):
        proto = self.frames.pop()
        self.scope = _Scope(self.scope.parent, proto)       # the interface's scope ends
        return None

    def proto(self, items):
        proto = items[0]
        proto.body = [s for s in items[1:] if s is not None]
        self.scope = self.scope.parent
        if not any(isinstance(s, self.Node) for s in proto.body):
            raise self.err(f"PROTO {proto.name} has no node in its body", proto._pos,
                           ["at least one node"])
        self.scope.protos[proto.name] = proto
        return proto

    def externproto_head(self, items):
        return self.open_declaration(self.ExternProto, items[0])

    def externproto(self, items):
        proto = items[0]
        urls = items[-1]
        self.frames.pop()
        if isinstance(urls, Tok):
            proto.urls = [unquote_string(urls.value)]
        else:
            bad = [u for u in urls if not (isinstance(u, Tok) and u.type == "STRING")]
            if bad:
                raise self.err("EXTERNPROTO URLs must be strings", self.pos_of(bad[0]),
                               ["a string"])
            proto.urls = [unquote_string(u.value) for u in urls]
        self.scope.protos[proto.name] = proto
        return proto
