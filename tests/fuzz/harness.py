"""Mutation fuzzing of every file reader: what each is given, how it is mutated, and
how an outcome is judged.

A reader may return a result or raise its own located error (a subclass of
``mpeg4fba.vrml.errors.LocatedError``, which names the file and where in it); any
other exception is a defect, reported by type and the frame that raised it.

Inputs are made from seeds, our own fixtures first (``spec_fixtures/`` and files
generated here), then the shared data where it is present, by 1-3 mutations each:
byte flips, inserts and deletes; token deletion, duplication and replacement;
splices between two seeds of the same reader; numbers replaced by huge, tiny,
non-finite or negative-zero ones; long strings; invalid UTF-8; deep nesting.  The
same ``(reader, seed number, mutation seed)`` always gives the same input, so a
failure found by the long run (``benchmarks/fuzz_readers.py``) is reproduced from
three numbers.

>>> data = make_input(READERS["fap"], seeds(READERS["fap"]), 7)
>>> isinstance(data, bytes)
True
"""
from __future__ import annotations

import base64
import json
import os
import re
import struct
import traceback
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

REPO = Path(__file__).resolve().parents[2]
FIXTURES = REPO / "spec_fixtures"


def shared_dir() -> Path:
    env = os.environ.get("MPEG4FBA_SHARED")
    return Path(env) if env else REPO.parent / "shared"


# -- seeds we write ourselves ----------------------------------------------------------------

def _obj_seed() -> bytes:
    """A small grouped OBJ head stand-in: a box with texture and normal indices."""
    v = [(x, y, z) for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]
    lines = ["# fuzz seed", "mtllib none.mtl", "o Head"]
    lines += [f"v {x} {y} {z}" for x, y, z in v]
    lines += ["vt 0 0", "vt 1 0", "vt 1 1", "vn 0 0 1"]
    lines += ["g skin", "usemtl skin", "f 1/1/1 2/2/1 4/3/1 3/1/1", "f 5//1 7//1 8//1",
              "f -1 -2 -3", "f 2 6 8 4", "g eyeball_l", "s off", "f 1 3 7 5"]
    return ("\n".join(lines) + "\n").encode()


def _gltf_doc(with_glb_chunk: bool) -> tuple:
    """(glTF JSON, binary blob): four vertices, two triangles, two morph targets."""
    pos = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], "<f4")
    t1 = np.array([[0, 0, 0], [0, -0.1, 0], [0, 0, 0], [0, 0, 0]], "<f4")
    t2 = np.array([[0, 0, 0.1], [0, 0, 0], [0, 0, 0], [0, 0, 0]], "<f4")
    idx = np.array([0, 1, 2, 0, 2, 3, 0, 0], "<u2")      # padded to 4 bytes
    blob = pos.tobytes() + t1.tobytes() + t2.tobytes() + idx.tobytes()
    buffer = {"byteLength": len(blob)}
    if not with_glb_chunk:
        buffer["uri"] = "data:application/octet-stream;base64," + base64.b64encode(blob).decode()
    views = [{"buffer": 0, "byteOffset": 48 * k, "byteLength": 48} for k in range(3)]
    views.append({"buffer": 0, "byteOffset": 144, "byteLength": 12, "target": 34963})
    acc = [{"bufferView": k, "componentType": 5126, "count": 4, "type": "VEC3",
            **({"min": [0, 0, 0], "max": [1, 1, 0]} if k == 0 else {})} for k in range(3)]
    acc.append({"bufferView": 3, "componentType": 5123, "count": 6, "type": "SCALAR"})
    doc = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}],
           "nodes": [{"name": "Head", "mesh": 0, "translation": [0, 1.6, 0]}],
           "meshes": [{"name": "Skin", "extras": {"targetNames": ["open_jaw@512", "viseme_PP"]},
                       "primitives": [{"attributes": {"POSITION": 0}, "indices": 3,
                                       "targets": [{"POSITION": 1}, {"POSITION": 2}]}]}],
           "accessors": acc, "bufferViews": views, "buffers": [buffer]}
    return doc, blob


def _gltf_seed() -> bytes:
    return json.dumps(_gltf_doc(False)[0], indent=1).encode()


def _glb_seed() -> bytes:
    doc, blob = _gltf_doc(True)
    text = json.dumps(doc).encode()
    text += b" " * (-len(text) % 4)
    blob += b"\0" * (-len(blob) % 4)
    body = struct.pack("<II", len(text), 0x4E4F534A) + text + \
        struct.pack("<II", len(blob), 0x004E4942) + blob
    return struct.pack("<III", 0x46546C67, 2, 12 + len(body)) + body


def _fdp_seed() -> bytes:
    """A small Xface .fdp written from the format's structure (our own text)."""
    items = "\n".join(
        f'  <fdp name="{n}" index="{i}" affects="head.wrl_0">\n'
        f'    <indices>{i} {i + 1} {i + 2}</indices>\n'
        f'    <influence fap="{f}" type="RaisedCosInfluenceSph" weight="0.5"/>\n  </fdp>'
        for n, i, f in (("2.1", 10, 2), ("8.1", 20, 4), ("3.5", 30, 20)))
    return ('<?xml version="1.0" encoding="UTF-8"?>\n<xfdp>\n <head>\n'
            '  <file version="0.2"/>\n'
            '  <fapu ENS0="51" ES0="69" IRISD0="16" MNS0="30" MW0="50"/>\n'
            '  <translation x="0" y="-1" z="-600"/>\n'
            '  <rotation axis_angle="0.4" axis_x="-1" axis_y="0" axis_z="0"/>\n </head>\n'
            ' <source>\n  <entity alias="Rest" category="Expression">\n'
            '   <mesh file="head.wrl" format="wrl"/>\n'
            '   <bind item="LeftEye" submesh="head.wrl_1" pivotX="-3" pivotY="3" pivotZ="2"/>\n'
            '  </entity>\n </source>\n' + items + '\n</xfdp>\n').encode()


def _fap_seed() -> bytes:
    from mpeg4fba.fba.stream import FapStream
    from mpeg4fba.formats.fap import dumps_fap
    s = FapStream.from_values({"open_jaw": [0, 200, 400, 100], "raise_b_midlip": [0, -50, 20, 0],
                               "close_t_l_eyelid": [0, 0, 800, 0]}, fps=25, name="seed")
    return dumps_fap(s).encode()


def _face_seed() -> bytes:
    from mpeg4fba import vrml
    from mpeg4fba.vrml.examples import example_scene
    return vrml.dumps(example_scene()).encode()


def _files(folder: Path, pattern: str, limit: int = 40, max_size: int = 40_000) -> list:
    if not folder.is_dir():
        return []
    out = []
    for p in sorted(folder.rglob(pattern)):
        if p.is_file() and p.stat().st_size <= max_size:
            out.append((str(p.relative_to(folder.parent)), p.read_bytes()))
    return out[:limit]


def _corpus_seeds(limit: int = 30) -> list:
    """Small positive files of the shared VRML corpus, spread over their sizes."""
    folder = shared_dir() / "data" / "vrml-corpus"
    manifest = folder / "MANIFEST.tsv"
    if not manifest.is_file():
        return []
    rows = [r.split("\t") for r in manifest.read_text("utf-8").splitlines()]
    head = rows[0]
    files = []
    for r in rows[1:]:
        d = dict(zip(head, r))
        path = folder / d.get("local_path", "")
        if d.get("role") == "positive" and path.is_file() and path.stat().st_size <= 8_000:
            files.append(path)
    files.sort(key=lambda p: p.stat().st_size)
    step = max(1, len(files) // limit)
    return [(str(p.relative_to(folder)), p.read_bytes()) for p in files[::step][:limit]]


# -- the readers -------------------------------------------------------------------------------

@dataclass(frozen=True)
class Reader:
    name: str
    suffix: str
    read: Callable                 # path -> result
    own_seeds: Callable            # () -> [(label, bytes)]
    shared_seeds: Callable = lambda: []
    nesting: tuple = (b"[", b"]")  # how this format nests, for the deep-nesting mutation
    compressed: bool = False       # gzip: memory is judged against what it inflates to


def _read_vrml(path):
    from mpeg4fba import vrml
    return vrml.load(path)


def _read_vrml_lenient(path):
    from mpeg4fba import vrml
    return vrml.load(path, strict=False)


def _read_face(path):
    from mpeg4fba.formats.wrl_face import load_face
    return load_face(path)


def _read_fap(path):
    from mpeg4fba.formats.fap import read_fap
    return read_fap(path)


def _read_fpjson(path):
    from mpeg4fba.formats.fpjson import read_feature_points_json
    return read_feature_points_json(path)


def _read_fdp(path):
    from mpeg4fba.formats.xface_fdp import read_xface_fdp
    return read_xface_fdp(path)


def _read_mesh_face(path):
    from mpeg4fba.formats.face_files import read_face
    return read_face(path)


def _vrml_seeds() -> list:
    own = _files(FIXTURES / "validate", "*.wrl") + _files(FIXTURES / "fat", "*.wrl")
    return own + [("example_scene", _face_seed())]


def _gzip_seeds() -> list:
    import gzip
    return [(label + ".gz", gzip.compress(data, mtime=0)) for label, data in _vrml_seeds()]


def payload(reader: Reader, data: bytes, cap: int = 1 << 28) -> int:
    """The bytes a reader works on: the input, or for gzip what it inflates to (up to
    ``cap``; the reader's own inflation limits stop it sooner)."""
    if not reader.compressed:
        return len(data)
    import zlib
    d = zlib.decompressobj(16 + zlib.MAX_WBITS)
    try:
        return max(len(data), len(d.decompress(data, cap)))
    except zlib.error:
        return len(data)


READERS: dict = {r.name: r for r in (
    Reader("vrml", ".wrl", _read_vrml, _vrml_seeds, _corpus_seeds,
           (b"Group { children [ ", b" ] }")),
    Reader("vrml-lenient", ".wrl", _read_vrml_lenient, _vrml_seeds, _corpus_seeds,
           (b"Transform { children ", b" }")),
    Reader("vrml-gz", ".wrl.gz", _read_vrml, _gzip_seeds, compressed=True),
    Reader("face", ".wrl", _read_face,
           lambda: _files(FIXTURES / "fat", "*.wrl") + [("example_scene", _face_seed())],
           lambda: [], (b"Group { children [ ", b" ] }")),
    Reader("fap", ".fap", _read_fap,
           lambda: _files(FIXTURES / "fap", "*.fap") + [("generated", _fap_seed())],
           lambda: _files(shared_dir() / "data" / "xface", "*.fap", limit=4)),
    Reader("fpjson", ".json", _read_fpjson,
           lambda: _files(FIXTURES / "feature_points", "*.json") +
           _files(FIXTURES / "ict", "*.json"), lambda: [], (b'{"a": [', b"]}")),
    Reader("fdp", ".fdp", _read_fdp, lambda: [("generated", _fdp_seed())],
           lambda: _files(shared_dir() / "data" / "xface", "*.fdp", limit=2),
           (b"<g>", b"</g>")),
    Reader("obj", ".obj", _read_mesh_face, lambda: [("generated", _obj_seed())]),
    Reader("gltf", ".gltf", _read_mesh_face, lambda: [("generated", _gltf_seed())],
           lambda: [], (b'{"a": [', b"]}")),
    Reader("glb", ".glb", _read_mesh_face, lambda: [("generated", _glb_seed())],
           lambda: [], (b'{"a": [', b"]}")),
)}


def seeds(reader: Reader, shared: bool = True) -> list:
    """The reader's seeds: ours, then (``shared``) the shared data's."""
    out = list(reader.own_seeds())
    if shared:
        out += reader.shared_seeds()
    return out


# -- mutations ----------------------------------------------------------------------------------

_TOKEN_RE = re.compile(rb"[A-Za-z_][\w.]*|[-+]?\d[\d.eExX+-]*|\"[^\"\n]*\"|\S")
# (atomic groups: on a long run of digits followed by a letter a plain one backtracks
# quadratically)
_NUMBER_RE = re.compile(rb"(?<![\w.])[-+]?(?>\d+(?:\.\d*)?|\.\d+)(?>[eE][-+]?\d+)?(?![\w.])")
NASTY_NUMBERS = [b"9" * 30, b"9" * 400, b"-" + b"9" * 25, b"0x" + b"f" * 20, b"0xFFFFFFFFFFFFFFFF",
                 b"18446744073709551616", b"2147483648", b"-2147483649", b"1e309", b"-1e309",
                 b"1e-400", b"nan", b"NaN", b"inf", b"-inf", b"-0", b"+0", b"00", b"-0.0",
                 b"1e10", b"10000000000", b"0.000001", b"-1", b"65536", b"4294967296"]
NASTY_BYTES = [b"\xff", b"\xfe\xff", b"\xc3(", b"\xed\xa0\x80", b"\x00", b"\x0b", b"\x1b[0m",
               b"\r", b"\t", b"\xef\xbb\xbf", b"\x85", b"\xe2\x80\xa8"]


def _pick(rng, items):
    return items[int(rng.integers(len(items)))]


def mutate_once(rng: np.random.Generator, data: bytes, pool: list, nesting: tuple) -> bytes:
    """One mutation of ``data``; ``pool`` holds the reader's other seeds (for splices)."""
    op = int(rng.integers(12))
    n = len(data)
    at = int(rng.integers(n + 1))
    if op == 0 and n:                                          # flip bytes
        b = bytearray(data)
        for _ in range(int(rng.integers(1, 5))):
            b[int(rng.integers(n))] = int(rng.integers(256))
        return bytes(b)
    if op == 1:                                                # insert / delete a run
        if rng.random() < 0.5 and n:
            return data[:at] + data[at + int(rng.integers(1, 64)):]
        return data[:at] + bytes(rng.integers(0, 256, int(rng.integers(1, 16)), np.uint8)) + data[at:]
    tokens = list(_TOKEN_RE.finditer(data))
    if op in (2, 3, 4) and tokens:                             # token delete / duplicate / swap
        m = _pick(rng, tokens)
        if op == 2:
            return data[:m.start()] + data[m.end():]
        if op == 3:
            return data[:m.start()] + m.group() + b" " + data[m.start():]
        other = _pick(rng, tokens).group()
        return data[:m.start()] + other + data[m.end():]
    if op in (5, 6):                                           # a nasty number
        numbers = list(_NUMBER_RE.finditer(data))
        if numbers:
            m = _pick(rng, numbers)
            return data[:m.start()] + _pick(rng, NASTY_NUMBERS) + data[m.end():]
        return data[:at] + _pick(rng, NASTY_NUMBERS) + data[at:]
    if op == 7 and pool:                                       # splice with another seed
        other = _pick(rng, pool)[1]
        a = int(rng.integers(len(other) + 1))
        b = a + int(rng.integers(0, 2000))
        if rng.random() < 0.5:
            return data[:at] + other[a:b] + data[at:]
        return data[:at] + other[a:b] + data[at + int(rng.integers(0, 2000)):]
    if op == 8:                                                # a long run
        unit = _pick(rng, [b"A", b"9", b" ", b"\"x", b"#", b"\n", b"[", b"{"])
        return data[:at] + unit * int(rng.integers(1_000, 200_000)) + data[at:]
    if op == 9:                                                # invalid / odd bytes
        return data[:at] + _pick(rng, NASTY_BYTES) + data[at:]
    if op == 10:                                               # deep nesting
        depth = int(rng.integers(100, 20_000))
        opening, closing = nesting
        return data[:at] + opening * depth + closing * depth + data[at:]
    return data[:at]                                           # truncate


def make_input(reader: Reader, pool: list, seed: int) -> bytes:
    """The input number ``seed`` for ``reader``: a seed from ``pool`` mutated 1-3 times."""
    rng = np.random.default_rng([seed, 0x5EED])
    data = pool[int(rng.integers(len(pool)))][1]
    if reader.compressed and rng.random() < 0.75:
        # mostly the text mutated under an intact gzip layer (a flipped byte of the
        # stream itself only ever reaches the CRC check), sometimes a bomb of blanks
        import gzip
        text = gzip.decompress(data)
        plain = [(label, gzip.decompress(d)) for label, d in pool]
        for _ in range(int(rng.integers(1, 4))):
            text = mutate_once(rng, text, plain, (b"Group { children [ ", b" ] }"))
        if rng.random() < 0.05:          # past 16 MiB, where the ratio cap applies
            text += b" " * int(rng.integers(17 << 20, 24 << 20))
        return gzip.compress(text, compresslevel=6, mtime=0)
    for _ in range(int(rng.integers(1, 4))):
        data = mutate_once(rng, data, pool, reader.nesting)
    return data


# -- judging an outcome --------------------------------------------------------------------------

def own_error(exc: BaseException) -> bool:
    from mpeg4fba.vrml.errors import LocatedError
    return isinstance(exc, LocatedError)


def top_frame(exc: BaseException) -> str:
    """``file:line function`` of the innermost frame of the project that raised."""
    frames = traceback.extract_tb(exc.__traceback__)
    ours = [f for f in frames if "mpeg4fba" in f.filename] or frames
    f = ours[-1] if ours else None
    if f is None:
        return "?"
    return f"{Path(f.filename).name}:{f.lineno} {f.name}"


def run_input(reader: Reader, data: bytes, folder: Path) -> tuple:
    """("accepted" | "error" | "other", detail) of reading ``data`` as a file."""
    path = Path(folder) / f"input{reader.suffix}"
    path.write_bytes(data)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            reader.read(str(path))
    except Exception as e:  # noqa: BLE001 - sorting exceptions is the point
        if own_error(e):
            return "error", str(e)[:200]
        return "other", f"{type(e).__name__} at {top_frame(e)}: {str(e)[:160]}"
    return "accepted", ""


def locate(reader_name: str, seed: int, shared: bool = True) -> bytes:
    """The input the long run numbered ``seed`` for ``reader_name``."""
    r = READERS[reader_name]
    return make_input(r, seeds(r, shared), seed)


def minimise(reader: Reader, data: bytes, folder: Path, same: Callable,
             budget: int = 400) -> bytes:
    """A smaller input that still fails the same way (``same(outcome)``): chunks of
    halving size removed while the failure stays."""
    chunk = max(1, len(data) // 2)
    tries = 0
    while chunk >= 1 and tries < budget:
        i, changed = 0, False
        while i < len(data) and tries < budget:
            candidate = data[:i] + data[i + chunk:]
            tries += 1
            if candidate and same(run_input(reader, candidate, folder)):
                data, changed = candidate, True
            else:
                i += chunk
        if not changed:
            chunk //= 2
    return data


def describe_seeds() -> dict:
    return {name: len(seeds(r)) for name, r in READERS.items()}


if __name__ == "__main__":  # pragma: no cover - a quick look at the seeds
    print(json.dumps(describe_seeds(), indent=1))


__all__ = ["READERS", "Reader", "seeds", "make_input", "run_input", "own_error", "locate",
           "minimise", "mutate_once", "shared_dir", "payload", "NASTY_NUMBERS"]
