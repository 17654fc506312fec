"""Xface ``.fdp`` files: the XML model description of the Xface toolkit.

Not the BIFS FDP node: an ``.fdp`` names the model's mesh files (``<source>``), its
FAPU0 distances (``<head><fapu ...>``), the face's global placement, and for each
feature point (``<fdp name="2.1" index=".." affects="..">``) the vertex that carries it,
the vertices of its region of influence (``<indices>``) and how each FAP moves that
region (``<influence fap=".." type=".." weight="..">``).

**FAP numbers.** Xface writes the ``fap`` attribute of ``<influence>`` counting from 0
(FAP number - 1): ``fap="2"`` is FAP 3, open_jaw.  This module converts on reading and
back on writing; every :class:`Influence` holds the real (1-based) FAP number.

**FAPU.** The ``<fapu>`` attributes are the FAPU0 distances (Xface divides them by 1024
when it loads them); they are stored as they are in a :class:`~mpeg4fba.fba.FAPU`.

**Safety.** The file is parsed with expat; a DOCTYPE (and so any entity declaration)
is refused, so no entity expansion ("billion laughs") can happen.

Example
-------
>>> fdp = loads_xface_fdp('''<xfdp><head><fapu ES0="69" IRISD0="16" ENS0="51" MNS0="30" MW0="50"/>
...   </head><fdp name="2.1" index="2395" affects="skin"><indices>2395 7 8</indices>
...   <influence fap="2" type="RaisedCosInfluenceSph" weight="0.3"/></fdp></xfdp>''')
>>> fdp.fapu.MNS0, fdp.points.vertex("2.1")
(30.0, ('skin', 2395))
>>> fdp.influences["2.1"]          # fap="2" in the file is FAP 3
[Influence(fap=3, type='RaisedCosInfluenceSph', weight=0.3)]
>>> loads_xface_fdp(dumps_xface_fdp(fdp)) == fdp
True
"""
from __future__ import annotations

import math
import os
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from typing import NamedTuple, Optional, Union
from xml.parsers import expat

import numpy as np

from ..fba.fapu import FAPU
from ..fba.featurepoints import FeaturePointError, FeaturePointSet, normalise_id
from ..fba.tables import FAP, N_FAPS
from .._atomic import atomic_write
from .errors import FormatError

__all__ = ["XfaceFdp", "XfaceFdpItem", "XfaceEntity", "XfaceMesh", "XfaceBind", "Influence",
           "INFLUENCE_TYPES", "read_xface_fdp", "loads_xface_fdp", "write_xface_fdp",
           "dumps_xface_fdp"]

#: The influence types Xface knows (``InfluenceCalculatorMaker``); it ignores others.
INFLUENCE_TYPES = ("RaisedCosInfluenceSph", "RaisedCosInfluenceWaveX",
                   "RaisedCosInfluenceWaveY", "RaisedCosInfluenceWaveZ")

_FAPU_ATTRS = ("ES0", "IRISD0", "ENS0", "MNS0", "MW0")   # Xface's order

PathLike = Union[str, "os.PathLike[str]"]


class Influence(NamedTuple):
    """How FAP number ``fap`` (1-based, unlike the file) moves a feature point's region."""

    fap: int
    type: str
    weight: float


class XfaceMesh(NamedTuple):
    """A ``<mesh file=.. format=.. [path=..]>`` of an entity."""

    file: str
    format: Optional[str] = None
    path: Optional[str] = None


class XfaceBind(NamedTuple):
    """A ``<bind submesh=.. item=..>``: a sub-mesh that is hair, an eye, teeth or tongue.

    ``pivot`` is the eye's centre of rotation (``pivotX/Y/Z``), or None.
    """

    submesh: str
    item: str
    pivot: Optional[tuple] = None


@dataclass(frozen=True)
class XfaceEntity:
    """An ``<entity alias=.. category=..>`` of ``<source>``: one face shape.

    The entity aliased ``Rest`` is the neutral face; Expression and Viseme entities
    are morph targets.  Xface allows several meshes per entity; ``mesh_file`` is the
    first one's file.
    """

    alias: str
    category: str
    meshes: tuple = ()
    binds: tuple = ()

    @property
    def mesh_file(self) -> Optional[str]:
        return self.meshes[0].file if self.meshes else None


@dataclass(eq=False)
class XfaceFdpItem:
    """One ``<fdp>`` element: a feature point on one mesh.

    ``name`` is the feature point id, ``mesh`` the mesh (``affects``; None when not
    given), ``vertex`` its vertex index there, ``indices`` the vertices of its region
    of influence (int64 array) and ``influences`` the FAPs that move the region.
    """

    name: str
    mesh: Optional[str]
    vertex: int
    indices: np.ndarray = field(default_factory=lambda: np.empty(0, np.int64))
    influences: tuple = ()

    def __eq__(self, other) -> bool:
        if not isinstance(other, XfaceFdpItem):
            return NotImplemented
        return ((self.name, self.mesh, self.vertex, tuple(self.influences))
                == (other.name, other.mesh, other.vertex, tuple(other.influences))
                and np.array_equal(self.indices, other.indices))


@dataclass(eq=False)
class XfaceFdp:
    """The contents of an Xface ``.fdp`` file.

    ``items`` holds every ``<fdp>`` element in file order.  A feature point may appear
    more than once, on different meshes (Xface's alice has 2.1 on the skin and on the
    lower teeth, 3.1 on the skin and on the left eye); :attr:`points` and
    :attr:`influences` take the **first** item of each name, :meth:`items_of` gives
    all of them.  ``translation`` (x, y, z) and ``rotation`` (axis x, y, z, angle in
    radians) are the face's global placement, None when the file has none.
    """

    fapu: FAPU
    items: list = field(default_factory=list)
    entities: list = field(default_factory=list)
    translation: Optional[tuple] = None
    rotation: Optional[tuple] = None
    version: Optional[str] = "0.2"

    @property
    def points(self) -> FeaturePointSet:
        """Feature point -> (mesh, vertex) of the first item of each name; no positions."""
        vertices = {}
        for item in self.items:
            vertices.setdefault(item.name, (item.mesh, item.vertex))
        return FeaturePointSet({}, vertices)

    @property
    def influences(self) -> dict:
        """Feature point -> list of :class:`Influence` (of the first item of each name)."""
        out: dict = {}
        for item in self.items:
            if item.name not in out:
                out[item.name] = list(item.influences)
        return out

    def items_of(self, fp) -> list:
        """Every item of feature point ``fp``, in file order."""
        key = normalise_id(fp)
        return [item for item in self.items if item.name == key]

    @property
    def rest(self) -> Optional[XfaceEntity]:
        """The entity aliased ``Rest`` (the neutral face), or None."""
        return next((e for e in self.entities if e.alias == "Rest"), None)

    def problems(self) -> list:
        """What looks wrong, as sentences (empty when nothing does).

        Influences of a FAP that does not move the item's feature point (by the
        standard's FAP table) and influence types Xface does not know.

        >>> item = XfaceFdpItem("8.8", "skin", 7, influences=(Influence(59, "RaisedCosInfluenceSph", 0.1),))
        >>> XfaceFdp(FAPU(16, 69, 51, 30, 50), [item]).problems()
        ['fdp 8.8 on skin: FAP 59 (raise_l_cornerlip_o) moves 8.3, not 8.8']
        """
        out = []
        for item in self.items:
            where = f"fdp {item.name}" + (f" on {item.mesh}" if item.mesh else "")
            for inf in item.influences:
                record = FAP[inf.fap]
                if record.feature_points and item.name not in record.feature_points:
                    out.append(f"{where}: FAP {inf.fap} ({record.name}) moves "
                               f"{', '.join(record.feature_points)}, not {item.name}")
                if inf.type not in INFLUENCE_TYPES:
                    out.append(f"{where}: influence type {inf.type!r} is unknown to Xface, "
                               f"which ignores it (known: {', '.join(INFLUENCE_TYPES)})")
        return out

    def __eq__(self, other) -> bool:
        if not isinstance(other, XfaceFdp):
            return NotImplemented
        return ((self.fapu, self.entities, self.translation, self.rotation, self.version)
                == (other.fapu, other.entities, other.translation, other.rotation, other.version)
                and self.items == other.items)

    def __repr__(self) -> str:
        return (f"<XfaceFdp {len(self.items)} fdp items ({len(self.points.ids)} feature points), "
                f"{len(self.entities)} entities>")


# -- reading ------------------------------------------------------------------------------

class _Doc:
    """A parsed document: the root Element and the line each element starts on."""

    def __init__(self, root: ET.Element, lines: dict, path: Optional[str]):
        self.root = root
        self.lines = lines
        self.path = path

    def error(self, message: str, elem: Optional[ET.Element] = None) -> FormatError:
        return FormatError(message, self.path, self.lines.get(elem) if elem is not None else None)

    def attr(self, elem: ET.Element, name: str, required: bool = True) -> Optional[str]:
        value = elem.get(name)
        if value is None and required:
            raise self.error(f"<{elem.tag}> has no {name} attribute", elem)
        return value

    def number(self, elem: ET.Element, name: str, default: Optional[float] = None) -> float:
        text = self.attr(elem, name, required=default is None)
        if text is None:
            return default
        try:
            value = float(text)
        except ValueError:
            value = math.nan
        if not math.isfinite(value):
            raise self.error(f"<{elem.tag}> attribute {name}: {_cut(text)!r} is not a number", elem)
        return value

    def integer(self, elem: ET.Element, name: str) -> int:
        """A whole-number attribute: a vertex index or a FAP number, so within 32 bits."""
        text = self.attr(elem, name)
        try:
            value = int(text.strip())
        except ValueError:
            raise self.error(f"<{elem.tag}> attribute {name}: {_cut(text)!r} is not an "
                             "integer", elem) from None
        if not -2 ** 31 <= value < 2 ** 31:
            raise self.error(f"<{elem.tag}> attribute {name}: {_cut(text)} is beyond 32 bits; "
                             "no vertex index or FAP number is", elem)
        return value


def _cut(text: str, limit: int = 40) -> str:
    return text if len(text) <= limit else text[:limit] + "..."


def _parse_xml(data: Union[bytes, str], path: Optional[str]) -> _Doc:
    builder = ET.TreeBuilder()
    lines: dict = {}
    parser = expat.ParserCreate()
    parser.buffer_text = True
    parser.SetParamEntityParsing(expat.XML_PARAM_ENTITY_PARSING_NEVER)

    def start(tag, attrs):
        lines[builder.start(tag, attrs)] = parser.CurrentLineNumber

    def refuse(*_):
        raise FormatError("DOCTYPE and ENTITY declarations are not allowed in an Xface .fdp "
                          "(refused so that no entity expansion can happen)", path,
                          parser.CurrentLineNumber)

    parser.StartElementHandler = start
    parser.EndElementHandler = builder.end
    parser.CharacterDataHandler = builder.data
    parser.StartDoctypeDeclHandler = refuse
    parser.EntityDeclHandler = refuse
    try:
        parser.Parse(data, True)
    except expat.ExpatError as e:
        raise FormatError(f"not well-formed XML: {expat.errors.messages[e.code]}", path,
                          e.lineno, e.offset + 1) from None
    except (LookupError, ValueError) as e:
        if isinstance(e, FormatError):
            raise
        # the XML declaration names an encoding Python does not know, or one expat
        # can't take (multi-byte, or not a text encoding at all)
        raise FormatError(f"the XML declaration's encoding can't be read ({e}); an Xface "
                          ".fdp is UTF-8", path, 1) from None
    return _Doc(builder.close(), lines, path)


def loads_xface_fdp(data: Union[bytes, str], path: Optional[str] = None) -> XfaceFdp:
    """Read an Xface ``.fdp`` from bytes or text; ``path`` only names it in errors.

    Raises :class:`~mpeg4fba.formats.errors.FormatError` (with the line) for text
    that is not XML, a DOCTYPE, a root other than ``<xfdp>``, a missing ``<fapu>``,
    a missing or non-numeric attribute, an out-of-range FAP, and ``<fdp>`` names that
    are not feature points of the standard.

    >>> loads_xface_fdp("<xfdp>\\n<head/></xfdp>", "x.fdp")
    Traceback (most recent call last):
    ...
    mpeg4fba.formats.errors.FormatError: x.fdp:2: no <fapu> in <head>: an Xface .fdp gives the five FAPU0 distances there
    """
    doc = _parse_xml(data, path)
    root = doc.root
    if root.tag != "xfdp":
        raise doc.error(f"the root element is <{root.tag}>; an Xface .fdp has <xfdp>", root)
    head = root.find("head")
    if head is None:
        raise doc.error("no <head> element: an Xface .fdp gives its FAPU (<fapu>) there", root)
    fapu_elem = next(head.iter("fapu"), None)
    if fapu_elem is None:
        raise doc.error("no <fapu> in <head>: an Xface .fdp gives the five FAPU0 distances "
                        "there", head)
    fapu = FAPU(**{name: doc.number(fapu_elem, name) for name in _FAPU_ATTRS})
    version_elem = next(head.iter("file"), None)
    version = version_elem.get("version") if version_elem is not None else None
    translation = rotation = None
    elem = next(head.iter("translation"), None)
    if elem is not None:
        translation = tuple(doc.number(elem, a, 0.0) for a in ("x", "y", "z"))
    elem = next(head.iter("rotation"), None)
    if elem is not None:
        rotation = tuple(doc.number(elem, a, 0.0)
                         for a in ("axis_x", "axis_y", "axis_z", "axis_angle"))

    entities = []
    for source in root.iter("source"):
        for ent in source.iter("entity"):
            entities.append(_read_entity(doc, ent))

    items, unknown = [], []
    for elem in root.iter("fdp"):
        name = doc.attr(elem, "name")
        try:
            key = normalise_id(name)
        except FeaturePointError:
            unknown.append((name, doc.lines.get(elem)))
            continue
        items.append(_read_item(doc, elem, key))
    if unknown:
        names = ", ".join(f"{n!r} (line {line})" for n, line in unknown)
        raise FormatError(f"<fdp> name{'s' if len(unknown) > 1 else ''} {names}: not "
                          "feature points of the standard (groups 2-11, e.g. \"3.5\")",
                          path, unknown[0][1])
    return XfaceFdp(fapu, items, entities, translation, rotation, version)


def _read_entity(doc: _Doc, ent: ET.Element) -> XfaceEntity:
    meshes, binds = [], []
    for elem in ent.iter():
        if elem.tag == "mesh":
            meshes.append(XfaceMesh(doc.attr(elem, "file"), elem.get("format"), elem.get("path")))
        elif elem.tag == "bind":
            pivot = None
            if any(elem.get(a) is not None for a in ("pivotX", "pivotY", "pivotZ")):
                pivot = tuple(doc.number(elem, a, 0.0) for a in ("pivotX", "pivotY", "pivotZ"))
            binds.append(XfaceBind(doc.attr(elem, "submesh"), doc.attr(elem, "item"), pivot))
    return XfaceEntity(doc.attr(ent, "alias"), ent.get("category", ""), tuple(meshes),
                       tuple(binds))


def _read_item(doc: _Doc, elem: ET.Element, key: str) -> XfaceFdpItem:
    vertex = doc.integer(elem, "index")
    if vertex < 0:
        raise doc.error(f"<fdp name=\"{key}\"> index {vertex} is negative", elem)
    chunks = []
    influences = []
    for sub in elem.iter():
        if sub.tag == "indices":
            values = []
            for token in (sub.text or "").split():
                try:
                    value = int(token)
                except ValueError:
                    value = None
                if value is None or not -2 ** 31 <= value < 2 ** 31:
                    raise doc.error(f"<indices> of fdp {key}: {_cut(token)!r} is not a vertex "
                                    "index", sub)
                values.append(value)
            values = np.array(values, dtype=np.int64)
            if (values < 0).any():
                raise doc.error(f"<indices> of fdp {key}: {int(values[values < 0][0])} is "
                                "negative", sub)
            chunks.append(values)
        elif sub.tag == "influence":
            zero_based = doc.integer(sub, "fap")
            if not 0 <= zero_based < N_FAPS:
                raise doc.error(f"<influence> fap=\"{zero_based}\" of fdp {key}: Xface counts "
                                f"FAPs from 0, so it must be 0-{N_FAPS - 1} "
                                f"(FAP 1-{N_FAPS})", sub)
            influences.append(Influence(zero_based + 1, doc.attr(sub, "type"),
                                        doc.number(sub, "weight")))
    indices = np.concatenate(chunks) if chunks else np.empty(0, np.int64)
    return XfaceFdpItem(key, elem.get("affects"), vertex, indices, tuple(influences))


def read_xface_fdp(path: PathLike) -> XfaceFdp:
    """Read the Xface ``.fdp`` file at ``path`` (see :func:`loads_xface_fdp`)."""
    with open(path, "rb") as f:
        data = f.read()
    return loads_xface_fdp(data, os.fspath(path))


# -- writing ------------------------------------------------------------------------------

def _num(x: float) -> str:
    x = float(x)
    return str(int(x)) if x.is_integer() and abs(x) < 1e15 else repr(x)


def dumps_xface_fdp(fdp: XfaceFdp) -> str:
    """The ``.fdp`` XML text of ``fdp``, laid out as Xface's editor writes it.

    Influence FAP numbers are written 0-based, as Xface expects.
    """
    root = ET.Element("xfdp")
    root.append(ET.Comment("MPEG-4 FDP specification file in the Xface format"))
    head = ET.SubElement(root, "head")
    if fdp.version is not None:
        ET.SubElement(head, "file", version=fdp.version)
    ET.SubElement(head, "fapu", {k: _num(getattr(fdp.fapu, k)) for k in _FAPU_ATTRS})
    if fdp.translation is not None:
        ET.SubElement(head, "translation",
                      {a: _num(v) for a, v in zip(("x", "y", "z"), fdp.translation)})
    if fdp.rotation is not None:
        ET.SubElement(head, "rotation", {a: _num(v) for a, v in zip(
            ("axis_x", "axis_y", "axis_z", "axis_angle"), fdp.rotation)})
    source = ET.SubElement(root, "source")
    for ent in fdp.entities:
        e = ET.SubElement(source, "entity", alias=ent.alias, category=ent.category)
        for mesh in ent.meshes:
            attrs = {"file": mesh.file}
            if mesh.format is not None:
                attrs["format"] = mesh.format
            if mesh.path is not None:
                attrs["path"] = mesh.path
            ET.SubElement(e, "mesh", attrs)
        for bind in ent.binds:
            attrs = {"item": bind.item, "submesh": bind.submesh}
            if bind.pivot is not None:
                attrs.update(zip(("pivotX", "pivotY", "pivotZ"), map(_num, bind.pivot)))
            ET.SubElement(e, "bind", attrs)
    for item in fdp.items:
        attrs = {"name": normalise_id(item.name), "index": str(int(item.vertex))}
        if item.mesh is not None:
            attrs["affects"] = item.mesh
        e = ET.SubElement(root, "fdp", attrs)
        indices = np.asarray(item.indices, dtype=np.int64).reshape(-1)
        if indices.size:
            ET.SubElement(e, "indices").text = " ".join(map(str, indices.tolist())) + " "
        for inf in item.influences:
            fap = int(inf.fap)
            if not 1 <= fap <= N_FAPS:
                raise ValueError(f"fdp {item.name}: FAP {fap} is not a FAP number (1-{N_FAPS})")
            ET.SubElement(e, "influence", fap=str(fap - 1), type=inf.type,
                          weight=_num(inf.weight))
    ET.indent(root, "  ")
    return ('<?xml version="1.0" encoding="UTF-8" standalone="no" ?>\n'
            + ET.tostring(root, encoding="unicode") + "\n")


def write_xface_fdp(fdp: XfaceFdp, path: PathLike) -> None:
    """Write ``fdp`` to ``path`` as an Xface ``.fdp`` (atomically: all or nothing)."""
    atomic_write(os.fspath(path), dumps_xface_fdp(fdp).encode("utf-8"))
