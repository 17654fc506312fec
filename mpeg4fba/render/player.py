"""An HTML player for animated faces: one self-contained file, no server, no network.

:func:`player_html` turns a binary glTF (``.glb``: meshes with morph targets and an
animation, as :func:`mpeg4fba.formats.gltf.dumps_glb` writes, or any other) into one
HTML page that plays it in a browser, opened straight from disk (``file://``):
three.js draws the face in a grey studio, the mouse orbits the camera, a bar below has
play/pause (or the space bar), a time scrubber and the time, and a panel lists the morph
targets (FAT intervals, visemes, expressions: the glTF's ``mesh.extras.targetNames``)
weighted at the current time.  :func:`write_player` writes the page to a file.

Everything is inlined: the ``.glb`` as base64, and three.js r160 (vendored, unmodified,
MIT, in ``web/``) as ES modules whose sources are ``data:`` URLs in the page's import
map.  A module loaded from a ``data:`` URL cannot resolve a relative import such as
``../utils/BufferGeometryUtils.js`` (a ``data:`` URL has no path to be relative to), so
the embedded copies get their relative import specifiers rewritten to the bare names
the map defines (``three/addons/utils/BufferGeometryUtils.js``, three's own naming);
nothing else in them changes.

For tests the page exposes ``window.__player`` (``ready``, ``duration``, ``error``,
``setTime(t)``, ``play()``, ``pause()``, ``currentTime()``, ``audioTime()``, ``playing()``,
``active()``) and sets
``document.body.dataset.ready = "1"`` once the face is drawn; a failure (no WebGL, a
bad file) shows a message in the page and sets ``document.body.dataset.error``.

Example
-------
>>> import struct
>>> glb = struct.pack("<4sII", b"glTF", 2, 12)          # a (trivially empty) .glb header
>>> page = player_html(glb, title="Jaw & lips", faps=["open_jaw", 6])
>>> page.startswith("<!DOCTYPE html>"), "Jaw &amp; lips" in page, "<script src=" in page
(True, True, False)
>>> embedded_glb(page) == glb
True
>>> sorted(import_map(page)["imports"])[:2]
['three', 'three/addons/controls/OrbitControls.js']
"""
from __future__ import annotations

from .._atomic import atomic_write

import base64
import html
import json
import os
import posixpath
import re
from functools import lru_cache
from importlib import resources
from numbers import Real
from pathlib import Path
from typing import Mapping, Optional, Union

__all__ = ["player_html", "write_player", "embedded_glb", "import_map", "module_specifiers",
           "vendored_modules", "THREE_VERSION", "MODULES"]

#: Version of the three.js files in ``web/`` (npm package ``three``).
THREE_VERSION = "0.160.0"
#: The vendored ES modules: the bare import specifier the page maps, and the file in ``web/``.
MODULES = {
    "three": "three.module.min.js",
    "three/addons/loaders/GLTFLoader.js": "GLTFLoader.js",
    "three/addons/controls/OrbitControls.js": "OrbitControls.js",
    "three/addons/utils/BufferGeometryUtils.js": "BufferGeometryUtils.js",
}

# The module specifier of a static import or re-export (`import x from "s"`, `import "s"`,
# `export * from "s"`, each at the start of a statement) and of a dynamic `import("s")`.
_SPECIFIERS = (
    re.compile(r"""(?:^|(?<=[;}]))[ \t]*(?:(?:import|export)\b[\w$*{},\s]*?\bfrom|import)\s*(["'])([^"'\n]+)\1""",
               re.M),
    re.compile(r"""\bimport\s*\(\s*(["'])([^"'\n]+)\1"""),
)
_GLB = re.compile(r'<script id="glb" type="application/octet-stream">([A-Za-z0-9+/=\s]*)</script>')
_IMPORTMAP = re.compile(r'<script type="importmap">(.*?)</script>', re.S)


def _web(name: str) -> bytes:
    return resources.files(__package__).joinpath("web", name).read_bytes()


def module_specifiers(source: str) -> list:
    """The import specifiers of an ES module's source, in order of appearance.

    >>> module_specifiers("import { a } from 'three';\\nexport * from './b.js'; import('c')")
    ['three', './b.js', 'c']
    """
    return [source[a:b] for a, b in _specifier_spans(source)]


def _specifier_spans(source: str) -> list:
    return sorted(m.span(2) for pattern in _SPECIFIERS for m in pattern.finditer(source))


def _rewrite(source: str, specifier: str) -> str:
    """``source`` (the module mapped as ``specifier``) with each relative import made bare."""
    out, done = [], 0
    for a, b in _specifier_spans(source):
        spec = source[a:b]
        if spec.startswith(("./", "../")):
            target = posixpath.normpath(posixpath.join(posixpath.dirname(specifier), spec))
            if target not in MODULES:
                raise ValueError(f"{MODULES[specifier]} imports {spec!r} ({target}), which is not vendored")
            out += [source[done:a], target]
            done = b
    return "".join(out) + source[done:]


@lru_cache(maxsize=1)
def vendored_modules() -> dict:
    """{bare specifier: module source as embedded in the page} (relative imports made bare).

    >>> mods = vendored_modules()
    >>> module_specifiers(mods["three/addons/loaders/GLTFLoader.js"])
    ['three', 'three/addons/utils/BufferGeometryUtils.js']
    """
    return {spec: _rewrite(_web(name).decode("utf-8"), spec) for spec, name in MODULES.items()}


@lru_cache(maxsize=1)
def _import_map_json() -> str:
    imports = {spec: "data:text/javascript;base64," + base64.b64encode(src.encode("utf-8")).decode("ascii")
               for spec, src in vendored_modules().items()}
    return json.dumps({"imports": imports}, indent=0)


def import_map(page: str) -> dict:
    """The import map of a player page, as a dict.

    >>> import_map('<script type="importmap">{"imports": {}}</script>')
    {'imports': {}}
    """
    m = _IMPORTMAP.search(page)
    if m is None:
        raise ValueError("the page has no import map")
    return json.loads(m.group(1))


def embedded_glb(page: str) -> bytes:
    """The ``.glb`` a player page carries.

    >>> embedded_glb('<script id="glb" type="application/octet-stream">Z2xURg==</script>')
    b'glTF'
    """
    m = _GLB.search(page)
    if m is None:
        raise ValueError("the page carries no .glb")
    return base64.b64decode("".join(m.group(1).split()), validate=True)


def _check_glb(glb: bytes) -> None:
    if not isinstance(glb, (bytes, bytearray, memoryview)):
        raise TypeError(f"glb is the bytes of a .glb file, not {type(glb).__name__}")
    glb = bytes(glb)
    if len(glb) < 12 or glb[:4] != b"glTF":
        raise ValueError("not a binary glTF (.glb): it does not start with the magic 'glTF'"
                         + ("; this looks like a JSON .gltf" if glb.lstrip()[:1] == b"{" else ""))
    version, length = int.from_bytes(glb[4:8], "little"), int.from_bytes(glb[8:12], "little")
    if version != 2:
        raise ValueError(f"a glTF {version} binary: the player reads glTF 2.0")
    if length != len(glb):
        raise ValueError(f"the .glb header gives {length} bytes, but there are {len(glb)}")


def _fap_label(fap) -> str:
    from ..fba.tables import FAP
    if isinstance(fap, str):
        return fap
    record = FAP.get(int(fap))
    return record.name if record is not None else str(fap)


def _fap_value(value):
    if isinstance(value, Mapping):   # viseme / expression fields of FAPs 1 and 2
        return " ".join(f"{k}={v:g}" if isinstance(v, Real) else f"{k}={v}" for k, v in value.items())
    return float(value)


def _fap_payload(faps: Optional[list]) -> Optional[dict]:
    """The JSON the page reads for its FAP panel: per-frame values, or a list of names."""
    if faps is None:
        return None
    items = list(faps)
    if items and all(isinstance(f, Mapping) or hasattr(f, "faps") for f in items):
        frames = []
        for f in items:
            if not isinstance(f, Mapping):   # a FapFrame: its transmitted FAPs
                f = {n: f[n] for n in f.faps}
            frames.append({_fap_label(k): _fap_value(v) for k, v in f.items() if v is not None})
        return {"frames": frames}
    if any(isinstance(f, Mapping) for f in items):
        raise TypeError("faps is a list of frames ({fap: value} each) or a list of FAPs, not a mix")
    return {"names": [_fap_label(f) for f in items]}


def _script_json(value) -> str:
    """JSON safe inside a <script> element (no "</script", no "<!--")."""
    return json.dumps(value, separators=(",", ":"), allow_nan=False).replace("<", "\\u003c")


def player_html(glb: bytes, *, title: str, faps: Optional[list] = None,
                audio: Optional[bytes] = None) -> str:
    """One self-contained HTML page that plays ``glb`` (the bytes of a ``.glb``).

    ``title`` heads the page.  ``faps``, optional, adds a "FAPs" section to the panel:
    either one ``{fap: value}`` mapping (or :class:`~mpeg4fba.fba.stream.FapFrame`) per
    frame of the animation, frames spread evenly over its duration, whose non-zero values
    are listed at the current time; or a list of FAPs (numbers or names) the animation
    drives, listed as they are.  ``audio``, optional, is a WAV file's bytes played with
    the animation: the audio's clock then drives the animation (so the two can't drift),
    and scrubbing moves both.

    >>> import struct
    >>> page = player_html(struct.pack("<4sII", b"glTF", 2, 12), title="t",
    ...                    faps=[{"open_jaw": 0}, {3: 512.0}])
    >>> '{"frames":[{"open_jaw":0.0},{"open_jaw":512.0}]}' in page
    True
    """
    _check_glb(glb)
    payload = _fap_payload(faps)
    encoded = base64.b64encode(bytes(glb)).decode("ascii")
    glb_text = "\n".join(encoded[i:i + 76] for i in range(0, len(encoded), 76))
    licence = _web("LICENSE").decode("utf-8").replace("--", "- -").strip()
    sound = ""
    if audio is not None:
        if bytes(audio[:4]) != b"RIFF" or bytes(audio[8:12]) != b"WAVE":
            raise ValueError("audio must be the bytes of a WAV file")
        sound = ('<audio id="audio" preload="auto" src="data:audio/wav;base64,'
                 + base64.b64encode(bytes(audio)).decode("ascii") + '"></audio>')
    fill = {"LICENSE": licence, "VERSION": THREE_VERSION, "IMPORTMAP": _import_map_json(),
            "GLB": glb_text, "FAPS": _script_json(payload), "JS": _PLAYER_JS, "AUDIO": sound,
            "FAIL": failure_script("__player", "player", "duration: 0, setTime() {}, play() {}, "
                                   "pause() {}, currentTime() { return 0; }, audioTime() { return null; }, "
                                   "active() { return []; }"),
            "TITLE": html.escape(str(title))}
    return re.sub(r"@([A-Z]+)@", lambda m: fill[m.group(1)], _TEMPLATE)


def failure_script(name: str, what: str, members: str = "") -> str:
    """The classic script a page of ours starts with: ``window.<name>`` (``ready``,
    ``error`` and ``members``) for tests, and ``window.__fail`` that shows any error in
    the page (never a blank page) and in ``document.body.dataset.error``; a page that is
    not ready within 30 s fails too.

    >>> "window.__editor = {ready: false, error: null};" in failure_script("__editor", "editor")
    True
    """
    extra = f", {members}" if members else ""
    return _FAIL_JS.replace("@NAME@", name).replace("@WHAT@", what).replace("@MEMBERS@", extra)


_FAIL_JS = r"""// A classic script: it runs even where modules cannot, so a failure is never a blank page.
window.@NAME@ = {ready: false, error: null@MEMBERS@};
window.__fail = function (text) {
  text = String(text || 'unknown error');
  if (/ResizeObserver/.test(text)) return;
  console.error('@WHAT@:', text);
  if (window.@NAME@.error) return;
  window.@NAME@.error = text;
  document.body.dataset.error = text;
  const msg = document.getElementById('msg');
  msg.textContent = 'The face cannot be shown:\n' + text;
  msg.hidden = false;
};
addEventListener('error', e => __fail(e.message || (e.error && e.error.message)));
addEventListener('unhandledrejection', e => __fail(e.reason && e.reason.message || e.reason));
if (!(window.HTMLScriptElement && HTMLScriptElement.supports && HTMLScriptElement.supports('importmap')))
  __fail('this browser has no import maps: open the page in a current Chrome, Edge, Firefox or Safari');
setTimeout(() => { if (!@NAME@.ready) __fail('the @WHAT@ did not start within 30 s'); }, 30000);"""


def write_player(glb: Union[bytes, str, os.PathLike], out_path: Union[str, os.PathLike], **kw) -> Path:
    """Write :func:`player_html` of ``glb`` (bytes, or the path of a ``.glb``) to
    ``out_path``, atomically (a temporary file beside it, then a rename); return the path.
    ``title`` defaults to the name of the output file.

    >>> import struct, tempfile, os
    >>> with tempfile.TemporaryDirectory() as d:
    ...     p = write_player(struct.pack("<4sII", b"glTF", 2, 12), os.path.join(d, "face.html"))
    ...     p.name, "<title>face</title>" in p.read_text("utf-8"), os.listdir(d)
    ('face.html', True, ['face.html'])
    """

    if not isinstance(glb, (bytes, bytearray, memoryview)):
        glb = Path(glb).read_bytes()
    path = Path(out_path)
    kw.setdefault("title", path.stem)
    text = player_html(glb, **kw)
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write(path, text)
    return path


_TEMPLATE = """<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<meta name="generator" content="mpeg4fba player (three.js @VERSION@)">
<title>@TITLE@</title>
<!--
This page embeds three.js @VERSION@ (build/three.module.min.js and, from examples/jsm,
loaders/GLTFLoader.js, controls/OrbitControls.js and utils/BufferGeometryUtils.js) as
base64 data: URLs in the import map below, unmodified except that relative import
specifiers are rewritten to bare ones. Its licence:

@LICENSE@
-->
<style>
html,body{margin:0;height:100%;overflow:hidden;background:#8e9196;color:#e8e8e8;font:13px/1.4 system-ui,sans-serif}
#view{position:fixed;left:0;right:0;top:0;bottom:44px}
#view canvas{display:block}
#title{position:fixed;top:8px;left:12px;font-size:15px;font-weight:600;color:#fff;text-shadow:0 1px 2px #0009;pointer-events:none}
#panel{position:fixed;top:8px;right:8px;width:230px;max-height:calc(100% - 70px);overflow:auto;padding:6px 10px;border-radius:6px;background:#1e2024c0}
#panel h2{margin:4px 0;font-size:11px;font-weight:600;letter-spacing:.06em;text-transform:uppercase;color:#aab}
.row{display:flex;justify-content:space-between;gap:8px;white-space:nowrap}
.row span:first-child{overflow:hidden;text-overflow:ellipsis}
.row span:last-child{font-variant-numeric:tabular-nums}
.w{height:3px;margin:0 0 3px;background:#7fb2e5}
.none{color:#889}
#bar{position:fixed;left:0;right:0;bottom:0;height:44px;display:flex;align-items:center;gap:12px;padding:0 12px;box-sizing:border-box;background:#26282c}
#play{width:70px;height:28px;border:0;border-radius:4px;background:#44484f;color:#fff;font:inherit;cursor:pointer}
#scrub{flex:1}
#time{min-width:120px;text-align:right;font-variant-numeric:tabular-nums}
#msg{position:fixed;inset:0;display:flex;align-items:center;justify-content:center;padding:2em;box-sizing:border-box;text-align:center;white-space:pre-wrap;font-size:16px;background:#3b3d42;color:#fff}
#msg[hidden]{display:none}
</style>
<script type="importmap">@IMPORTMAP@</script>
</head>
<body>
<div id="view"></div>
<div id="title">@TITLE@</div>
<div id="panel"><h2>Active morph targets</h2><div id="targets" class="none">none</div><div id="fapbox" hidden><h2 id="faphead">FAPs</h2><div id="faps"></div></div></div>
<div id="bar"><button id="play" type="button" title="Play / pause (space)">Pause</button><input id="scrub" type="range" min="0" max="0" step="any" value="0" aria-label="Time"><span id="time">0.00 / 0.00 s</span></div>
<div id="msg">Loading the face...
(this page needs JavaScript, ES modules and import maps)</div>
@AUDIO@
<script id="glb" type="application/octet-stream">@GLB@</script>
<script id="fapdata" type="application/json">@FAPS@</script>
<script>
@FAIL@
</script>
<script type="module">
@JS@
</script>
</body>
</html>
"""

_PLAYER_JS = r"""import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';

const $ = id => document.getElementById(id);
const P = window.__player;
const view = $('view'), button = $('play'), scrub = $('scrub'), clock = $('time');

function bytes(base64) {
  const text = atob(base64.replace(/\s+/g, ''));
  const out = new Uint8Array(text.length);
  for (let i = 0; i < text.length; i++) out[i] = text.charCodeAt(i);
  return out.buffer;
}

function rows(box, entries, fraction) {   // [name, value] pairs as rows (and bars) of the panel
  box.replaceChildren();
  box.className = entries.length ? '' : 'none';
  if (!entries.length) { box.textContent = 'none'; return; }
  for (const [name, value] of entries) {
    const row = box.appendChild(document.createElement('div'));
    row.className = 'row';
    row.appendChild(document.createElement('span')).textContent = name;
    row.appendChild(document.createElement('span')).textContent =
      typeof value === 'number' ? (fraction ? value.toFixed(2) : +value.toFixed(3)) : (value ?? '');
    if (fraction) {
      const bar = box.appendChild(document.createElement('div'));
      bar.className = 'w';
      bar.style.width = Math.min(100, 100 * Math.abs(value)) + '%';
    }
  }
}

async function main() {
  let renderer;
  try {
    renderer = new THREE.WebGLRenderer({ antialias: true });
  } catch (e) {
    throw new Error('WebGL is not available in this browser (' + (e.message || e) + ')');
  }
  renderer.setPixelRatio(Math.min(window.devicePixelRatio || 1, 2));
  view.appendChild(renderer.domElement);

  const scene = new THREE.Scene();
  scene.background = new THREE.Color(0x8e9196);
  scene.add(new THREE.HemisphereLight(0xf4f6ff, 0x4a4540, 1.5));
  const camera = new THREE.PerspectiveCamera(30, 1, 0.01, 100);
  const key = new THREE.DirectionalLight(0xffffff, 2.2);   // follows the camera: from upper left
  key.position.set(-0.5, 0.7, 0.6);
  key.target.position.set(0, 0, -1);
  camera.add(key, key.target);
  scene.add(camera);

  const gltf = await new Promise((resolve, reject) => {
    const fail = e => reject(new Error('the embedded glTF cannot be read: ' + (e && e.message || e)));
    try { new GLTFLoader().parse(bytes($('glb').textContent), '', resolve, fail); } catch (e) { fail(e); }
  });
  const root = gltf.scene || gltf.scenes[0];
  if (!root) throw new Error('the glTF has no scene');
  scene.add(root);

  // Morph targets by name (mesh.extras.targetNames), and clay for meshes without a material
  // (glTF's default material is a white metal, which is black without an environment map).
  const clay = new THREE.MeshStandardMaterial({ color: 0xc9c3bc, roughness: 0.65, metalness: 0 });
  const morphs = [];
  root.traverse(o => {
    if (!o.isMesh) return;
    if (!o.geometry.attributes.normal) o.geometry.computeVertexNormals();
    const m = o.material;
    if (m && !Array.isArray(m) && !(gltf.parser.associations.get(m) || {}).hasOwnProperty('materials')) {
      o.material = clay.clone();
      o.material.vertexColors = m.vertexColors;
    }
    if (o.morphTargetInfluences && o.morphTargetInfluences.length) {
      const names = o.morphTargetInfluences.map((_, i) => 'target ' + i);
      for (const [name, i] of Object.entries(o.morphTargetDictionary || {})) names[i] = name;
      morphs.push({ mesh: o, names });
    }
  });

  // Frame the face: the camera looks down -z at the bounding sphere of the model.
  root.updateMatrixWorld(true);
  const box = new THREE.Box3().setFromObject(root, true);
  if (box.isEmpty()) throw new Error('the glTF has no geometry to show');
  const center = box.getCenter(new THREE.Vector3());
  const radius = Math.max(box.getSize(new THREE.Vector3()).length() / 2, 1e-6);
  const controls = new OrbitControls(camera, renderer.domElement);
  controls.enableDamping = true;
  controls.target.copy(center);
  function resize() {
    const w = Math.max(view.clientWidth, 1), h = Math.max(view.clientHeight, 1);
    renderer.setSize(w, h);
    camera.aspect = w / h;
    camera.updateProjectionMatrix();
  }
  resize();
  const vfov = THREE.MathUtils.degToRad(camera.fov);
  const hfov = 2 * Math.atan(Math.tan(vfov / 2) * camera.aspect);
  const distance = 1.1 * radius / Math.sin(Math.min(vfov, hfov) / 2);
  camera.position.copy(center).add(new THREE.Vector3(0, 0, distance));
  camera.near = distance / 100;
  camera.far = distance * 100;
  camera.updateProjectionMatrix();
  controls.update();
  addEventListener('resize', resize);

  // The animation: the clip "fap_stream" if there is one, else the first; it loops.
  const clip = gltf.animations.find(a => a.name === 'fap_stream') || gltf.animations[0];
  const mixer = new THREE.AnimationMixer(root);
  const action = clip ? mixer.clipAction(clip) : null;
  const duration = clip ? clip.duration : 0;
  if (action) action.play();
  let playing = duration > 0;
  scrub.max = String(duration);
  button.disabled = scrub.disabled = !(duration > 0);

  const fapData = JSON.parse($('fapdata').textContent);
  if (fapData) {
    $('fapbox').hidden = false;
    if (fapData.names) { $('faphead').textContent = 'FAPs animated'; rows($('faps'), fapData.names.map(n => [n, ''])); }
  }

  // With sound, the audio's clock is the animation's: the mixer is set to the audio's
  // time on every frame, so the two can't drift; scrubbing moves both.
  const audio = $('audio');
  const time = () => action && duration > 0 ? action.time : 0;
  function active() {
    const weight = new Map();
    for (const { mesh, names } of morphs)
      mesh.morphTargetInfluences.forEach((w, i) => {
        if (Math.abs(w) > 1e-3 && !(Math.abs(weight.get(names[i]) || 0) >= Math.abs(w))) weight.set(names[i], w);
      });
    return [...weight].sort((a, b) => Math.abs(b[1]) - Math.abs(a[1]));
  }
  let shown = '';
  function refresh() {
    const t = time();
    scrub.value = String(t);
    clock.textContent = t.toFixed(2) + ' / ' + duration.toFixed(2) + ' s';
    button.textContent = playing ? 'Pause' : 'Play';
    const targets = active();
    let frame = null;
    if (fapData && fapData.frames && fapData.frames.length) {
      const n = fapData.frames.length;
      frame = Object.entries(fapData.frames[Math.min(n - 1, Math.max(0, Math.round(duration > 0 ? t / duration * (n - 1) : 0)))])
        .filter(([, v]) => v !== 0);
    }
    const key = JSON.stringify([targets.map(([n, w]) => [n, w.toFixed(2)]), frame]);
    if (key === shown) return;
    shown = key;
    rows($('targets'), targets, true);
    if (frame) rows($('faps'), frame);
  }
  function draw() { refresh(); renderer.render(scene, camera); }
  function setTime(t) {
    t = Math.min(Math.max(Number(t) || 0, 0), duration);
    if (action) mixer.setTime(duration > 0 ? Math.min(t, duration * (1 - 1e-6)) : 0);
    if (audio && Math.abs(audio.currentTime - t) > 1e-3) audio.currentTime = t;
    draw();
  }
  function play() {
    playing = duration > 0;
    // a browser may refuse sound before the user has clicked: then the button starts it
    if (audio && playing) audio.play().catch(() => { playing = false; draw(); });
    draw();
  }
  const pause = () => { playing = false; if (audio) audio.pause(); draw(); };
  if (audio) audio.addEventListener('ended', () => { if (playing) { audio.currentTime = 0; audio.play().catch(() => {}); } });
  const toggle = () => (playing ? pause() : play());

  button.addEventListener('click', () => { toggle(); button.blur(); });
  scrub.addEventListener('input', () => setTime(Number(scrub.value)));
  addEventListener('keydown', e => {
    if (e.code === 'Space' || e.key === ' ') { e.preventDefault(); toggle(); }
  });

  const ticker = new THREE.Clock();
  renderer.setAnimationLoop(() => {
    const dt = Math.min(ticker.getDelta(), 0.1);
    if (playing && audio) mixer.setTime(Math.min(audio.currentTime, duration * (1 - 1e-6)));
    else if (playing) mixer.update(dt);
    controls.update();
    draw();
  });

  setTime(0);
  if (audio) play();
  Object.assign(P, { duration, setTime, play, pause, currentTime: time,
                     audioTime: () => audio ? audio.currentTime : null, playing: () => playing,
                     active: () => active().map(([name, w]) => ({ name, weight: w })) });
  P.ready = true;
  $('msg').hidden = true;
  document.body.dataset.ready = '1';
}

main().catch(e => window.__fail(e && e.message || e));"""
