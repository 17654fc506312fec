"""``mpeg4fba info``: what a file holds.

For a VRML file: node counts, PROTOs, ROUTEs, DEFs, meshes.  For a ``.fap`` animation
(chosen by the extension, case-insensitive): frames, fps, duration, version, name, the
animated FAPs and the min/max of each.  For a face in a mesh file (``.glb``, ``.gltf``,
``.obj``, as ``play`` and ``demo`` write them): its meshes, Transforms, feature points,
FAT and bounding box, as :func:`mpeg4fba.formats.face_files.read_face` reads it.

Example
-------
>>> from click.testing import CliRunner
>>> from mpeg4fba.cli import main
>>> result = CliRunner().invoke(main, ["info", "--example", "--json"])
>>> import json; json.loads(result.output)["routes"]
2
"""
from __future__ import annotations

import json
from collections import Counter
from typing import Any, Optional

import click

from ..fba.stream import FapStream
from ..formats.face_files import MESH_SUFFIXES
from ..vrml import ExternProto, Node, Proto, Scene
from ..vrml.walk import Mesh, iter_meshes
from . import main, read_scene, warnings_to_stderr
from .common import number_spans

__all__ = ["info", "scene_info", "fap_info", "face_info"]


def _label(node: Node) -> str:
    return node.name or node.type


def _path_text(nodes: tuple, keep: int = 8) -> str:
    """``Head/LeftEye/Shape``; long paths keep their two first and last few steps."""
    labels = [_label(n) for n in nodes[:2]]
    if len(nodes) > keep:
        labels += [f"...{len(nodes) - keep + 2} more..."] + [_label(n) for n in nodes[-(keep - 2):]]
    else:
        labels = [_label(n) for n in nodes]
    return "/".join(labels)


def _mesh_info(mesh: Mesh) -> dict:
    owner = mesh.path + ((mesh.shape,) if mesh.shape is not None else ())
    bounds = mesh.bounds
    return {
        "name": mesh.geometry.name or (mesh.shape.name if mesh.shape is not None else None),
        "path": _path_text(owner + (mesh.geometry,)),
        "vertices": int(len(mesh.vertices)),
        "triangles": int(len(mesh.triangles)),
        "bounds": None if bounds is None else [b.tolist() for b in bounds],
    }


def scene_info(scene: Scene) -> dict:
    """The facts ``info`` reports about ``scene``, as plain JSON-ready values.

    >>> from mpeg4fba.vrml.examples import example_scene
    >>> facts = scene_info(example_scene(1))
    >>> facts["protos"], facts["defs"], [m["name"] for m in facts["meshes"]]
    (['LoopingClock'], 11, ['HeadMesh', 'EyeMesh', 'EyeMesh', 'NoseMesh'])
    """
    nodes = list(scene)
    counts = Counter(n.type for n in nodes)
    meshes = [_mesh_info(m) for m in iter_meshes(scene)]
    lows = [m["bounds"][0] for m in meshes if m["bounds"] is not None]
    highs = [m["bounds"][1] for m in meshes if m["bounds"] is not None]
    bounds: Optional[dict] = None
    if lows:
        bounds = {"min": [min(v) for v in zip(*lows)], "max": [max(v) for v in zip(*highs)]}
    return {
        "file": scene.path,
        "node_count": len(nodes),
        "nodes": dict(sorted(counts.items(), key=lambda kv: (-kv[1], kv[0]))),
        "protos": [p.name for p in scene.protos if isinstance(p, Proto)],
        "externprotos": [p.name for p in scene.protos if isinstance(p, ExternProto)],
        "routes": len(scene.routes),
        "defs": sum(1 for n in nodes if n.name is not None),
        "meshes": meshes,
        "bounds": bounds,
    }


def _xyz(values: list) -> str:
    return "(" + ", ".join(f"{v:.6g}" for v in values) + ")"


def _text(facts: dict) -> str:
    lines = [f"file: {facts['file'] or '<built-in example>'}",
             f"nodes: {facts['node_count']} ({len(facts['nodes'])} types)"]
    width = max((len(t) for t in facts["nodes"]), default=0)
    lines += [f"  {t:<{width}}  {c}" for t, c in facts["nodes"].items()]
    lines.append("PROTOs: " + (", ".join(facts["protos"]) or "none"))
    lines.append("EXTERNPROTOs: " + (", ".join(facts["externprotos"]) or "none"))
    lines.append(f"ROUTEs: {facts['routes']}")
    lines.append(f"DEFs: {facts['defs']}")
    lines.append(f"meshes: {len(facts['meshes'])}")
    for m in facts["meshes"]:
        name = m["name"] or m["path"]
        where = f"  at {m['path']}" if m["name"] else ""
        lines.append(f"  {name}: {m['vertices']} vertices, {m['triangles']} triangles{where}")
    b = facts["bounds"]
    lines.append("bounds: " + ("none" if b is None else f"{_xyz(b['min'])} to {_xyz(b['max'])}"))
    return "\n".join(lines)




def fap_info(stream: FapStream, path: Optional[str] = None) -> dict:
    """The facts ``info`` reports about a FAP stream, as plain JSON-ready values.

    >>> s = FapStream.from_values({"open_jaw": [0, 100, 250]}, fps=25, name="demo")
    >>> facts = fap_info(s)
    >>> facts["frames"], facts["duration"], facts["animated"], facts["faps"]["3"]["max"]
    (3, 0.12, [3], 250.0)
    """
    summary = stream.summary()
    return {"file": path, "name": summary["name"], "version": summary["version"],
            "frames": summary["frames"], "fps": summary["fps"], "duration": summary["duration"],
            "animated": stream.animated,
            "faps": {str(k): v for k, v in summary["faps"].items()}}


def _number(x: float) -> str:
    return f"{x:.6g}"


def _fap_text(facts: dict) -> str:
    lines = [f"file: {facts['file'] or '<stream>'}",
             f"frames: {facts['frames']}",
             f"fps: {_number(facts['fps'])}",
             f"duration: {_number(facts['duration'])} s",
             f"version: {facts['version']}",
             f"name: {facts['name'] or '(none)'}",
             f"animated FAPs: {len(facts['animated'])}"
             + (f" ({number_spans(facts['animated'])})" if facts["animated"] else "")]
    if facts["faps"]:
        width = max(len(v["name"]) for v in facts["faps"].values())
        lines.append(f"  {'FAP':>3}  {'name':<{width}}  {'frames':>6}  {'min':>9}  {'max':>9}")
        for number, v in facts["faps"].items():
            low = _number(v["min"]) if "min" in v else "-"
            high = _number(v["max"]) if "max" in v else "-"
            lines.append(f"  {number:>3}  {v['name']:<{width}}  {v['frames']:>6}  {low:>9}  "
                         f"{high:>9}")
    return "\n".join(lines)


def _is_fap(path: str) -> bool:
    return path.lower().endswith(".fap")


def face_info(face: Any, path: Optional[str] = None) -> dict:
    """The facts ``info`` reports about a face model (read from a mesh file), as plain
    JSON-ready values; positions are in the face frame (Transforms applied).

    >>> from mpeg4fba.fba.face import FaceMesh, FaceModel
    >>> facts = face_info(FaceModel([FaceMesh("Tri", [[0, 0, 0], [1, 0, 0], [0, 2, 0]], [[0, 1, 2]])]))
    >>> facts["meshes"][0]["triangles"], facts["bounds"]["max"], facts["fat"]["faps"]
    (1, [1.0, 2.0, 0.0], 0)
    """
    meshes = []
    lows, highs = [], []
    for name, m in face.meshes.items():
        world = face.world_vertices(name)
        bounds = None
        if len(world):
            bounds = [world.min(axis=0).tolist(), world.max(axis=0).tolist()]
            lows.append(bounds[0])
            highs.append(bounds[1])
        meshes.append({"name": name, "parent": m.parent, "vertices": int(len(m.vertices)),
                       "triangles": int(len(m.triangles)), "bounds": bounds})
    bounds = None
    if lows:
        bounds = {"min": [min(v) for v in zip(*lows)], "max": [max(v) for v in zip(*highs)]}
    fat = face.fat
    return {"file": path, "kind": "face", "name": face.name, "meshes": meshes,
            "transforms": list(face.transforms), "feature_points": len(face.points),
            "fat": {"tables": len(fat), "faps": len(fat.faps), "visemes": len(fat.visemes),
                    "expressions": len(fat.expressions)},
            "bounds": bounds}


def _face_text(facts: dict) -> str:
    fat = facts["fat"]
    lines = [f"file: {facts['file'] or '<face>'}",
             f"face: {facts['name']}",
             f"meshes: {len(facts['meshes'])}"]
    for m in facts["meshes"]:
        under = f"  under {m['parent']}" if m["parent"] else ""
        lines.append(f"  {m['name']}: {m['vertices']} vertices, {m['triangles']} triangles{under}")
    lines.append("Transforms: " + (", ".join(facts["transforms"]) or "none"))
    lines.append(f"feature points: {facts['feature_points']}"
                 + ("" if facts["feature_points"] else " (the file holds none)"))
    lines.append(f"FAT: {fat['tables']} tables: {fat['faps']} FAPs, {fat['visemes']} visemes, "
                 f"{fat['expressions']} expressions")
    b = facts["bounds"]
    lines.append("bounds: " + ("none" if b is None else f"{_xyz(b['min'])} to {_xyz(b['max'])}"))
    return "\n".join(lines)


@main.command(epilog="\b\nExamples:\n  mpeg4fba info face.wrl\n  mpeg4fba info --json face.wrl.gz"
                     "\n  mpeg4fba info joy.fap\n  mpeg4fba info talk.glb\n  mpeg4fba info --example")
@click.argument("file", required=False, metavar="[FILE.wrl|FILE.fap|FILE.glb]")
@click.option("--json", "as_json", is_flag=True, help="Print the facts as JSON.")
@click.option("--lenient", is_flag=True, help="Keep nodes and fields that are not VRML97, IS bound to exposedFields, a missing header, nan values (warns).")
@click.option("--example", is_flag=True, help="Describe the built-in example scene instead of FILE.")
def info(file: Optional[str], as_json: bool, lenient: bool, example: bool) -> None:
    """Node counts, PROTOs, ROUTEs, DEFs, meshes and bounding box of a VRML97 file;
    frames, fps, duration and per-FAP min/max of a .fap animation; meshes, FAT and
    bounding box of a face in a .glb, .gltf or .obj file."""
    if example == (file is not None):
        raise click.UsageError("give either FILE or --example")
    if file is not None and _is_fap(file):
        from ..formats.fap import read_fap
        with warnings_to_stderr():
            facts = fap_info(read_fap(file), file)
        click.echo(json.dumps(facts, indent=2) if as_json else _fap_text(facts))
        return
    if file is not None and file.lower().endswith(MESH_SUFFIXES):
        from ..formats.face_files import read_face
        with warnings_to_stderr():
            facts = face_info(read_face(file, lenient=lenient), file)
        click.echo(json.dumps(facts, indent=2) if as_json else _face_text(facts))
        return
    if example:
        from ..vrml.examples import example_scene
        scene = example_scene()
    else:
        scene = read_scene(file, lenient)
    with warnings_to_stderr():
        facts: Any = scene_info(scene)
    click.echo(json.dumps(facts, indent=2) if as_json else _text(facts))
