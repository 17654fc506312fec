"""The HTML player: one self-contained page (three.js and the .glb inlined, nothing
fetched), and, in Debian's Chromium when it and Playwright are installed, a page that
draws the face and animates it."""
from __future__ import annotations

import base64
import hashlib
import io
import json
import os
import re
import struct
from pathlib import Path

import numpy as np
import pytest

from mpeg4fba.render import player
from mpeg4fba.render.player import (MODULES, THREE_VERSION, embedded_glb, import_map,
                                    module_specifiers, player_html, vendored_modules,
                                    write_player)

from _browser import CHROMIUM, CHROMIUM_ARGS, browser, close_pages  # noqa: F401  (fixtures)

WEB = Path(player.__file__).parent / "web"
BACKGROUND = (0x8E, 0x91, 0x96)          # the page's scene background
VIEWPORT = {"width": 800, "height": 600}
TARGETS = ["open_jaw[0,1024]", "viseme:PP[0,63]"]

# The only URLs in the embedded three.js code outside comments: an XML namespace and a
# link in a console warning, neither of them fetched.
THREE_URLS_IN_CODE = {"http://www.w3.org/1999/xhtml",
                      "https://discourse.threejs.org/t/updates-to-lighting-in-three-js-r155/53733"}


def sphere_glb(material: bool = True) -> bytes:
    """A "head" (a UV sphere of radius 0.1 m at y = 1.6, away from the origin so that the
    framing is tested) with two morph targets (the jaw drops, the lips push forward) and
    an animation "fap_stream" of 2 s: their weights, and a turn of the node about y."""
    import pygltflib as g

    lat, lon = np.meshgrid(np.linspace(0, np.pi, 25), np.linspace(0, 2 * np.pi, 33), indexing="ij")
    unit = np.stack([np.sin(lat) * np.sin(lon), np.cos(lat), np.sin(lat) * np.cos(lon)], -1).reshape(-1, 3)
    pos = (unit * 0.1 + [0, 1.6, 0]).astype(np.float32)
    normal = unit.astype(np.float32)
    rows, cols = lat.shape
    quads = [(r * cols + c, (r + 1) * cols + c, (r + 1) * cols + c + 1, r * cols + c + 1)
             for r in range(rows - 1) for c in range(cols - 1)]
    tri = np.array([(a, b, c) for a, b, c, d in quads] + [(a, c, d) for a, b, c, d in quads], np.uint32)
    jaw = np.zeros_like(pos)
    jaw[:, 1] = np.where(unit[:, 1] < -0.1, -0.08 * (-unit[:, 1]), 0)
    lips = np.zeros_like(pos)
    lips[:, 2] = np.where((unit[:, 2] > 0.6) & (np.abs(unit[:, 1]) < 0.5), 0.05, 0)
    times = np.array([0, 1, 2], np.float32)
    weights = np.array([0, 0, 1, 0.7, 0, 1], np.float32)
    half = np.radians(40) / 2
    turn = np.array([[0, 0, 0, 1], [0, np.sin(half), 0, np.cos(half)], [0, 0, 0, 1]], np.float32)

    blob, views, accessors = bytearray(), [], []

    def add(arr, kind, target=None, bounds=False):
        while len(blob) % 4:
            blob.append(0)
        views.append(g.BufferView(buffer=0, byteOffset=len(blob), byteLength=arr.nbytes, target=target))
        blob.extend(arr.tobytes())
        ctype = g.UNSIGNED_INT if arr.dtype == np.uint32 else g.FLOAT
        acc = g.Accessor(bufferView=len(views) - 1, componentType=ctype, type=kind,
                         count=arr.size if kind == g.SCALAR else len(arr))
        if bounds:
            acc.min = np.atleast_1d(arr.min(axis=0)).tolist()
            acc.max = np.atleast_1d(arr.max(axis=0)).tolist()
        accessors.append(acc)
        return len(accessors) - 1

    prim = g.Primitive(attributes=g.Attributes(POSITION=add(pos, g.VEC3, g.ARRAY_BUFFER, True),
                                               NORMAL=add(normal, g.VEC3, g.ARRAY_BUFFER)),
                       indices=add(tri.ravel(), g.SCALAR, g.ELEMENT_ARRAY_BUFFER),
                       targets=[g.Attributes(POSITION=add(jaw, g.VEC3, g.ARRAY_BUFFER, True)),
                                g.Attributes(POSITION=add(lips, g.VEC3, g.ARRAY_BUFFER, True))],
                       material=0 if material else None)
    t_in = add(times, g.SCALAR, bounds=True)
    doc = g.GLTF2(
        scene=0, scenes=[g.Scene(nodes=[0])], nodes=[g.Node(name="Head", mesh=0)],
        meshes=[g.Mesh(name="Skin", primitives=[prim], weights=[0.0, 0.0], extras={"targetNames": TARGETS})],
        materials=[g.Material(name="skin", pbrMetallicRoughness=g.PbrMetallicRoughness(
            baseColorFactor=[0.8, 0.5, 0.4, 1.0], metallicFactor=0.0, roughnessFactor=0.7))] if material else [],
        animations=[g.Animation(name="fap_stream", samplers=[
            g.AnimationSampler(input=t_in, output=add(weights, g.SCALAR), interpolation="LINEAR"),
            g.AnimationSampler(input=t_in, output=add(turn, g.VEC4), interpolation="LINEAR")],
            channels=[g.AnimationChannel(sampler=0, target=g.AnimationChannelTarget(node=0, path="weights")),
                      g.AnimationChannel(sampler=1, target=g.AnimationChannelTarget(node=0, path="rotation"))])],
        accessors=accessors, bufferViews=views, buffers=[g.Buffer(byteLength=len(blob))])
    doc.set_binary_blob(bytes(blob))
    return b"".join(doc.save_to_bytes())


@pytest.fixture(scope="module")
def glb() -> bytes:
    return sphere_glb()


@pytest.fixture(scope="module")
def page(glb) -> str:
    return player_html(glb, title="Sphere <test>", faps=[{"open_jaw": 0}, {"open_jaw": 1024}, {}])


# --------------------------------------------------------------------------- the files


def test_vendored_three_is_the_unmodified_release_the_readme_names():
    readme = (WEB / "README.md").read_text("utf-8")
    assert f"three@{THREE_VERSION}" in readme and "MIT" in readme
    listed = dict(re.findall(r"`([\w.]+)`\s*\|\s*\d+\s*\|\s*`([0-9a-f]{64})`", readme))
    assert set(listed) == set(MODULES.values()) | {"LICENSE"}
    for name, digest in listed.items():
        assert hashlib.sha256((WEB / name).read_bytes()).hexdigest() == digest, f"{name} was modified"
    assert sorted(p.name for p in WEB.iterdir()) == sorted(set(listed) | {"README.md"})
    assert not (WEB / "__init__.py").exists()       # package data, not a package


def test_page_fetches_nothing_and_names_no_url(page):
    assert page.startswith("<!DOCTYPE html>") and page.count("<html") == 1
    assert not re.search(r"<script[^>]*\bsrc\s*=|<link\b|<iframe\b|<img\b|@import|url\(", page, re.I)
    assert not re.search(r"https?://", page)       # the page itself (the licence has no URL)
    assert "Sphere &lt;test&gt;" in page and "<test>" not in page
    # Everything the page imports is a data: URL, and the embedded code names no URL
    # outside its comments but the two known strings that are never fetched.
    for spec, url in import_map(page)["imports"].items():
        assert url.startswith("data:text/javascript;base64,"), spec
        source = base64.b64decode(url.split(",", 1)[1]).decode("utf-8")
        for line in source.splitlines():
            code = line.strip()
            if code.startswith(("//", "*", "/*")):
                continue
            for found in re.findall(r"https?://[^\s'\"`]*[^\s'\"`.,;)]", code):
                assert found in THREE_URLS_IN_CODE, f"{spec}: {found}"


def test_glb_is_embedded_byte_for_byte(glb, page):
    assert embedded_glb(page) == glb
    assert page.count('<script id="glb"') == 1


def _module_sources(page: str) -> dict:
    """{specifier or "page": source} of every module the page runs."""
    out = {spec: base64.b64decode(url.split(",", 1)[1]).decode("utf-8")
           for spec, url in import_map(page)["imports"].items()}
    inline = re.findall(r'<script type="module">(.*?)</script>', page, re.S)
    assert len(inline) == 1
    out["page"] = inline[0]
    return out


def test_import_map_covers_every_specifier(page):
    imports = import_map(page)["imports"]
    assert set(imports) == set(MODULES)
    sources = _module_sources(page)
    used = set()
    for name, source in sources.items():
        specs = module_specifiers(source)
        # A cruder count, to check the parser misses none: `from "x";` and `import "x";`.
        crude = re.findall(r"""\b(?:from|import)\s*["']([^"'\s]+)["']\s*;""", source)
        assert sorted(specs) == sorted(crude), name
        for spec in specs:
            assert spec in imports, f"{name} imports {spec!r}, which the import map lacks"
        used.update(specs)
    assert used == set(MODULES)                      # and maps nothing unused
    assert module_specifiers(sources["three/addons/loaders/GLTFLoader.js"]) == \
        ["three", "three/addons/utils/BufferGeometryUtils.js"]


def test_embedded_modules_differ_from_the_files_only_in_their_import_specifiers(page):
    sources = _module_sources(page)
    for spec, name in MODULES.items():
        original = (WEB / name).read_text("utf-8")
        embedded = sources[spec].replace("'three/addons/utils/BufferGeometryUtils.js'",
                                         "'../utils/BufferGeometryUtils.js'")
        assert embedded == original, name
    assert vendored_modules()["three"] == (WEB / "three.module.min.js").read_text("utf-8")


def test_fap_panel_data_and_escaping(glb):
    frames = json.loads(re.search(r'<script id="fapdata" type="application/json">(.*?)</script>',
                                  player_html(glb, title="t", faps=[{3: 10, "</script>": 1.5}]), re.S).group(1))
    assert frames == {"frames": [{"open_jaw": 10.0, "</script>": 1.5}]}
    page = player_html(glb, title="t", faps=[3, "viseme"])
    assert '{"names":["open_jaw","viseme"]}' in page
    assert 'application/json">null</script>' in player_html(glb, title="t")
    with pytest.raises(TypeError):
        player_html(glb, title="t", faps=[{3: 1}, 3])


def test_frames_of_a_fap_stream_are_accepted(glb):
    from mpeg4fba.fba.stream import FapStream
    stream = FapStream.from_values({"open_jaw": [0, 100]}, fps=25)
    assert '{"frames":[{"open_jaw":0.0},{"open_jaw":100.0}]}' in player_html(glb, title="t", faps=list(stream))


def test_what_is_not_a_glb_is_refused(glb):
    with pytest.raises(ValueError, match="magic"):
        player_html(b"PK\x03\x04" + bytes(20), title="t")
    with pytest.raises(ValueError, match="JSON .gltf"):
        player_html(b'{"asset": {"version": "2.0"}}', title="t")
    with pytest.raises(ValueError, match="header gives"):
        player_html(glb[:-4], title="t")
    with pytest.raises(ValueError, match="glTF 1"):
        player_html(struct.pack("<4sII", b"glTF", 1, 12), title="t")
    with pytest.raises(TypeError):
        player_html("face.glb", title="t")


def test_write_player_is_atomic(glb, tmp_path, monkeypatch):
    src = tmp_path / "face.glb"
    src.write_bytes(glb)
    out = write_player(src, tmp_path / "out" / "face.html")
    assert out == tmp_path / "out" / "face.html"
    text = out.read_text("utf-8")
    assert embedded_glb(text) == glb and "<title>face</title>" in text
    assert write_player(glb, out, title="Again").read_text("utf-8") != text
    before = out.read_bytes()

    def broken(*a, **k):
        raise OSError("disk full")
    monkeypatch.setattr(player.os, "replace", broken)
    with pytest.raises(OSError, match="disk full"):
        write_player(glb, out, title="Never written")
    assert out.read_bytes() == before                      # the old page is intact
    assert sorted(p.name for p in out.parent.iterdir()) == ["face.html"]   # no temporary left
    with pytest.raises(ValueError):                        # nothing written for a bad input
        write_player(b"not a glb", tmp_path / "bad.html")
    assert not (tmp_path / "bad.html").exists()


# --------------------------------------------------------------------------- in Chromium


class Page:
    """A player page open in Chromium, with its errors and the URLs it requested."""

    def __init__(self, browser, path: Path):
        self.errors, self.requests = [], []
        self.page = browser.new_page(viewport=VIEWPORT)
        self.page.on("pageerror", lambda e: self.errors.append(str(e)))
        self.page.on("console", lambda m: m.type == "error" and self.errors.append(m.text))
        self.page.on("request", lambda r: self.requests.append(r.url))
        self.page.goto(path.as_uri())

    def wait(self, what: str = 'document.body.dataset.ready === "1" || !!document.body.dataset.error'):
        self.page.wait_for_function(what, timeout=60_000)

    def shot(self) -> np.ndarray:
        from matplotlib import image as mimage
        self.page.evaluate("() => new Promise(r => requestAnimationFrame(() => requestAnimationFrame(r)))")
        png = self.page.screenshot()
        return (mimage.imread(io.BytesIO(png), format="png")[..., :3] * 255).round().astype(int)


def _scene_pixels(image: np.ndarray) -> np.ndarray:
    """The 3D view only: above the control bar, left of the panel, below the title."""
    return image[40:VIEWPORT["height"] - 44, :VIEWPORT["width"] - 250]


def _open(browser, tmp_path, glb: bytes, **kw) -> Page:
    path = write_player(glb, tmp_path / "face.html", **kw)
    p = Page(browser, path)
    p.wait()
    return p


@pytest.mark.parametrize("material", [True, False], ids=["material", "no-material"])
def test_the_face_is_drawn_and_moves(browser, tmp_path, material):
    p = _open(browser, tmp_path, sphere_glb(material), title="Sphere")
    assert p.page.evaluate("document.body.dataset.error || ''") == ""
    state = p.page.evaluate("({ready: __player.ready, duration: __player.duration})")
    assert state == {"ready": True, "duration": pytest.approx(2.0)}
    p.page.evaluate("__player.pause(); __player.setTime(0)")
    assert p.page.evaluate("__player.active()") == []
    first = p.shot()
    p.page.evaluate("__player.setTime(__player.duration / 2)")
    assert [a["name"] for a in p.page.evaluate("__player.active()")] == TARGETS
    panel = p.page.inner_text("#targets")
    assert all(name in panel for name in TARGETS) and "1.00" in panel and "0.70" in panel
    assert "1.00 / 2.00 s" in p.page.inner_text("#time")
    middle = p.shot()

    bg = np.array(BACKGROUND)
    face = (np.abs(_scene_pixels(first) - bg).sum(-1) > 40).mean()
    changed = (np.abs(_scene_pixels(middle) - _scene_pixels(first)).sum(-1) > 40).mean()
    print(f"face covers {face:.1%} of the view; {changed:.1%} of it changed at t = 1 s")
    assert np.abs(first[5, 5] - bg).sum() <= 6                # the studio background
    assert 0.08 < face < 0.8                                   # the face fills a good part
    assert changed > 0.02                                      # and the two frames differ
    # Nothing but the page itself (and its data: URLs) was requested; no error was logged.
    assert all(u.startswith(("file:", "data:", "blob:")) for u in p.requests), p.requests
    assert p.errors == []


def test_play_pause_space_and_scrubber(browser, tmp_path, glb):
    p = _open(browser, tmp_path, glb, title="Sphere", faps=[{"open_jaw": 0}, {"open_jaw": 1024}, {}])
    t0 = p.page.evaluate("__player.currentTime()")
    p.page.wait_for_timeout(300)
    assert p.page.evaluate("__player.currentTime()") != t0          # it plays on load
    assert p.page.inner_text("#play") == "Pause"
    p.page.keyboard.press("Space")
    assert p.page.inner_text("#play") == "Play"
    t1 = p.page.evaluate("__player.currentTime()")
    p.page.wait_for_timeout(200)
    assert p.page.evaluate("__player.currentTime()") == t1          # paused
    p.page.keyboard.press("Space")
    assert p.page.inner_text("#play") == "Pause"
    p.page.click("#play")
    assert p.page.inner_text("#play") == "Play"
    p.page.fill("#scrub", "1.5")                                    # the scrubber sets the time
    assert p.page.evaluate("__player.currentTime()") == pytest.approx(1.5, abs=1e-3)
    p.page.evaluate("__player.setTime(1)")
    assert "open_jaw" in p.page.inner_text("#faps") and "1024" in p.page.inner_text("#faps")
    p.page.evaluate("__player.setTime(5)")                          # clamped to the end
    assert p.page.evaluate("__player.currentTime()") == pytest.approx(2.0, abs=1e-3)
    assert p.errors == []


def test_a_broken_file_shows_a_message(browser, tmp_path):
    broken = struct.pack("<4sII", b"glTF", 2, 24) + struct.pack("<I4s", 4, b"JSON") + b"{{{ "
    p = _open(browser, tmp_path, broken, title="Broken")
    error = p.page.evaluate("document.body.dataset.error || ''")
    assert "cannot be read" in error and p.page.evaluate("__player.ready") is False
    assert p.page.is_visible("#msg") and "cannot be shown" in p.page.inner_text("#msg")


def test_the_exported_reference_head_plays(browser, tmp_path):
    gltf = pytest.importorskip("mpeg4fba.formats.gltf")
    if not hasattr(gltf, "dumps_glb"):
        pytest.skip("mpeg4fba.formats.gltf has no dumps_glb yet")
    from mpeg4fba.fba.stream import FapStream
    from mpeg4fba.models import reference_head
    stream = FapStream.from_values({"open_jaw": [0, 400, 800, 0], "raise_l_i_eyebrow": [0, 200, 0, 0]}, fps=2)
    p = _open(browser, tmp_path, gltf.dumps_glb(reference_head(resolution=0.5), stream),
              title="Reference head", faps=list(stream))
    assert p.page.evaluate("document.body.dataset.error || ''") == ""
    assert p.page.evaluate("__player.duration") == pytest.approx(1.5)
    p.page.evaluate("__player.pause(); __player.setTime(0)")
    first = p.shot()
    p.page.evaluate("__player.setTime(1)")
    names = [a["name"] for a in p.page.evaluate("__player.active()")]
    assert any(n.startswith("open_jaw[") for n in names), names
    middle = p.shot()
    face = (np.abs(_scene_pixels(first) - np.array(BACKGROUND)).sum(-1) > 40).mean()
    changed = (np.abs(_scene_pixels(middle) - _scene_pixels(first)).sum(-1) > 40).mean()
    print(f"reference head covers {face:.1%} of the view; {changed:.1%} of it changed at t = 1 s")
    assert face > 0.08 and changed > 0.005
    assert p.errors == []


def test_without_webgl_the_page_says_so(browser, tmp_path, glb):
    no_webgl = browser.browser_type.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS + ["--disable-webgl"])
    try:
        p = Page(no_webgl, write_player(glb, tmp_path / "face.html"))
        p.wait()
        assert "WebGL is not available" in p.page.evaluate("document.body.dataset.error || ''")
        assert p.page.is_visible("#msg") and "WebGL" in p.page.inner_text("#msg")
    finally:
        no_webgl.close()


def _mouth_stream():
    """Two frames, 1 s apart: the mouth closed, then wide open (viseme "aa" at full blend)."""
    from mpeg4fba.fba.stream import FapStream
    return FapStream.from_values({}, fps=1, n_frames=2, visemes=[(10, 0, 0, 0), (10, 0, 63, 0)])


def test_the_open_mouth_shows_the_teeth(browser, tmp_path):
    """The mouth cavity is wound inward: drawn two-sided, its near wall would cover the
    teeth.  Teeth painted green must show in the open mouth, and only there."""
    from mpeg4fba.formats.gltf import dumps_glb
    from mpeg4fba.models import reference_head
    face = reference_head(resolution=0.5)
    for name in ("UpperTeeth", "LowerTeeth"):
        face.colors[name] = np.tile([0.0, 1.0, 0.0], (len(face.meshes[name].vertices), 1))
    p = _open(browser, tmp_path, dumps_glb(face, _mouth_stream()), title="Teeth")
    p.page.evaluate("__player.pause(); __player.setTime(0)")
    closed = _scene_pixels(p.shot())[:, :-20]        # [:, :-20]: clear of the panel's edge
    p.page.evaluate("__player.setTime(1)")
    wide = _scene_pixels(p.shot())[:, :-20]

    def green(img):
        g = img[..., 1]
        return (g > 80) & (g > 2 * img[..., 0] + 20) & (g > 2 * img[..., 2] + 20)
    rows, cols = np.nonzero(np.abs(wide - np.array(BACKGROUND)).sum(-1) > 40)
    r, c = np.nonzero(green(wide))
    print(f"{len(r)} green pixels in the open mouth")
    assert not green(closed).any()                 # behind the closed lips
    assert len(r) > 100
    top, bottom, left, right = rows.min(), rows.max(), cols.min(), cols.max()
    assert ((r > (top + bottom) / 2) & (r < bottom)).all()          # the lower half of the face
    assert ((c > left + (right - left) / 3) & (c < right - (right - left) / 3)).all()
    assert p.errors == []


def test_a_face_saved_as_vrml_and_read_back_plays_as_before(browser, tmp_path):
    """Colours go through the VRML file (Material, Color nodes): the page of the face
    read back looks like the page of the face itself."""
    from mpeg4fba.formats.gltf import dumps_glb
    from mpeg4fba.formats.wrl_face import load_face, save_face
    from mpeg4fba.models import reference_head
    face = reference_head(resolution=0.5)
    save_face(face, tmp_path / "head.wrl")
    shots = []
    for k, f in enumerate((face, load_face(tmp_path / "head.wrl"))):
        (tmp_path / str(k)).mkdir()
        p = _open(browser, tmp_path / str(k), dumps_glb(f, _mouth_stream()), title="Head")
        p.page.evaluate("__player.pause(); __player.setTime(1)")
        shots.append(_scene_pixels(p.shot()))
        assert p.errors == []
    differ = (np.abs(shots[0] - shots[1]).sum(-1) > 12).mean()
    print(f"{differ:.3%} of the view differs")
    assert differ < 0.002
