import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';

const $ = id => document.getElementById(id);
const E = window.__editor;
const D = JSON.parse($('editor-data').textContent);
const view = $('view'), labelBox = $('labels'), statusBar = $('status');

// ---- the sidecar JSON, written as Python's json.dumps writes it (fpjson's writer)
function pyFloat(x) {              // repr(float(x))
  if (!Number.isFinite(x)) throw new Error('not a finite number: ' + x);
  if (x === 0) return Object.is(x, -0) ? '-0.0' : '0.0';
  const [mant, expText] = x.toExponential().split('e');
  const e = Number(expText), sign = mant[0] === '-' ? '-' : '';
  const digits = mant.replace('-', '').replace('.', '');
  if (e >= -4 && e < 16) {
    if (e < 0) return sign + '0.' + '0'.repeat(-e - 1) + digits;
    const whole = digits.slice(0, e + 1).padEnd(e + 1, '0');
    return sign + whole + '.' + (digits.slice(e + 1) || '0');
  }
  return sign + digits[0] + (digits.length > 1 ? '.' + digits.slice(1) : '') +
    'e' + (e < 0 ? '-' : '+') + String(Math.abs(e)).padStart(2, '0');
}
const SHORT = { '"': '\\"', '\\': '\\\\', '\n': '\\n', '\r': '\\r', '\t': '\\t', '\b': '\\b', '\f': '\\f' };
function pyStr(s) {                // json.dumps(s) (ensure_ascii)
  let out = '"';
  for (const ch of String(s).split('')) {
    const c = ch.charCodeAt(0);
    if (SHORT[ch]) out += SHORT[ch];
    else if (c >= 0x20 && c <= 0x7e) out += ch;
    else out += '\\u' + c.toString(16).padStart(4, '0');
  }
  return out + '"';
}
function entryJson(p) {
  const parts = [];
  if (p.position) parts.push('"position": [' + p.position.map(pyFloat).join(', ') + ']');
  if (p.vertex !== null) {
    if (p.mesh !== null) parts.push('"mesh": ' + pyStr(p.mesh));
    parts.push('"vertex": ' + String(p.vertex));
  }
  if (p.confidence !== null) parts.push('"confidence": ' + pyFloat(p.confidence));
  return '{' + parts.join(', ') + '}';
}
function documentJson() {
  const lines = [];
  for (const id of D.order) {
    const p = state.get(id);
    if (p && (p.position || p.vertex !== null)) lines.push('    ' + pyStr(id) + ': ' + entryJson(p));
  }
  const out = ['{', '  "format": ' + pyStr(D.format) + ',', '  "version": ' + D.version + ','];
  if (D.units !== null) out.push('  "units": ' + pyStr(D.units) + ',');
  out.push('  "points": {' + (lines.length ? '\n' + lines.join(',\n') + '\n  ' : '') + '}' + (D.fapu ? ',' : ''));
  if (D.fapu) out.push('  "fapu": {' + Object.entries(D.fapu).map(([k, v]) => pyStr(k) + ': ' + pyFloat(v)).join(', ') + '}');
  out.push('}');
  return out.join('\n') + '\n';
}

// ---- colours: confidence 0 red -> 0.5 yellow -> 1 green; none given: blue
const NO_CONFIDENCE = '#3d8bfd', SELECTED = '#ffe14d';
const confColor = c => c === null ? NO_CONFIDENCE : 'hsl(' + (120 * c).toFixed(1) + ',80%,45%)';

function bytes(base64) {
  const text = atob(base64);
  const out = new Uint8Array(text.length);
  for (let i = 0; i < text.length; i++) out[i] = text.charCodeAt(i);
  return out.buffer;
}

// ---- the points: id -> {position|null, mesh|null, vertex|null, confidence|null, shown|null, ...}
const state = new Map();
for (const p of D.points) state.set(p.id, { ...p, moved: false, missing: false });
for (const m of D.missing) state.set(m.id, { id: m.id, name: m.name, position: null, mesh: null, vertex: null,
                                             confidence: null, shown: null, reason: m.reason, moved: false, missing: true });
const history = [];
let selected = null;

async function main() {
  let renderer;
  try {
    renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
  } catch (e) {
    throw new Error('WebGL is not available in this browser (' + (e.message || e) + ')');
  }
  renderer.setPixelRatio(Math.min(window.devicePixelRatio || 1, 2));
  view.appendChild(renderer.domElement);
  const canvas = renderer.domElement;

  const scene = new THREE.Scene();
  scene.background = new THREE.Color(0x8e9196);
  scene.add(new THREE.HemisphereLight(0xf4f6ff, 0x4a4540, 1.5));
  const camera = new THREE.PerspectiveCamera(30, 1, 0.01, 100);
  // the head's own up and forward (a +Z-up head opens on its face too); before the
  // orbit controls, which take the camera's up when made
  const UP = new THREE.Vector3(...D.view.up), FWD = new THREE.Vector3(...D.view.forward);
  const SIDE = new THREE.Vector3().crossVectors(UP, FWD);
  camera.up.copy(UP);
  const key = new THREE.DirectionalLight(0xffffff, 2.0);
  key.position.set(-0.5, 0.7, 0.6);
  key.target.position.set(0, 0, -1);
  camera.add(key, key.target);
  scene.add(camera);

  // The meshes, in world coordinates (float64 kept for the saved positions).
  const meshes = new Map(), pickable = [];
  const box = new THREE.Box3();
  for (const m of D.meshes) {
    const world = new Float64Array(bytes(m.positions));
    const geometry = new THREE.BufferGeometry();
    geometry.setAttribute('position', new THREE.BufferAttribute(new Float32Array(world), 3));
    geometry.setIndex(new THREE.BufferAttribute(new Uint32Array(bytes(m.triangles)), 1));
    if (m.colors) {
      const rgb = new Uint8Array(bytes(m.colors));
      const linear = new Float32Array(rgb.length), c = new THREE.Color();
      for (let i = 0; i < rgb.length; i += 3) {
        c.setRGB(rgb[i] / 255, rgb[i + 1] / 255, rgb[i + 2] / 255, THREE.SRGBColorSpace);
        linear[i] = c.r; linear[i + 1] = c.g; linear[i + 2] = c.b;
      }
      geometry.setAttribute('color', new THREE.BufferAttribute(linear, 3));
    }
    geometry.computeVertexNormals();
    geometry.computeBoundingBox();
    box.union(geometry.boundingBox);
    const material = new THREE.MeshStandardMaterial({
      color: m.colors ? 0xffffff : new THREE.Color().setRGB(...m.color, THREE.SRGBColorSpace),
      vertexColors: !!m.colors, roughness: 0.7, metalness: 0,
      side: m.closed ? THREE.FrontSide : THREE.DoubleSide });
    const mesh = new THREE.Mesh(geometry, material);
    mesh.name = m.name;
    mesh.userData.world = world;
    scene.add(mesh);
    meshes.set(m.name, mesh);
    pickable.push(mesh);
  }
  if (box.isEmpty()) throw new Error('the face has no geometry to show');
  const center = box.getCenter(new THREE.Vector3());
  const size = box.getSize(new THREE.Vector3()).length();
  const radius = Math.max(size / 2, 1e-9);

  // Markers: an opaque sphere where the point shows, and a faint one seen through the face.
  const sphere = new THREE.SphereGeometry(0.0045 * size, 14, 10);
  const markers = [];
  function makeMarker(p) {
    const front = new THREE.Mesh(sphere, new THREE.MeshBasicMaterial({ color: 0xffffff }));
    const ghost = new THREE.Mesh(sphere, new THREE.MeshBasicMaterial({ color: 0xffffff, transparent: true,
                                                                      opacity: 0.35, depthTest: false }));
    ghost.renderOrder = 10;
    front.userData.id = ghost.userData.id = p.id;
    scene.add(front, ghost);
    markers.push(front);
    const label = labelBox.appendChild(document.createElement('div'));
    label.className = 'lab';
    label.textContent = p.id;
    label.title = p.name || '';
    label.addEventListener('click', () => select(p.id));
    p.ui = { front, ghost, label };
  }
  for (const p of state.values()) makeMarker(p);

  const controls = new OrbitControls(camera, canvas);
  controls.enableDamping = false;
  controls.target.copy(center);
  function resize() {
    const w = Math.max(view.clientWidth, 1), h = Math.max(view.clientHeight, 1);
    renderer.setSize(w, h);
    camera.aspect = w / h;
    camera.updateProjectionMatrix();
    dirty = true;
  }
  let dirty = true;
  resize();
  const vfov = THREE.MathUtils.degToRad(camera.fov);
  const hfov = 2 * Math.atan(Math.tan(vfov / 2) * camera.aspect);
  const boxSize = box.getSize(new THREE.Vector3());         // the front of the box fills the view
  const along = d => Math.abs(boxSize.x * d.x) + Math.abs(boxSize.y * d.y) + Math.abs(boxSize.z * d.z);
  const extent = new THREE.Vector3(along(SIDE), along(UP), along(FWD));
  const distance = 1.12 * Math.max(extent.y / 2 / Math.tan(vfov / 2), extent.x / 2 / Math.tan(hfov / 2)) + extent.z / 2;
  camera.position.copy(center).addScaledVector(FWD, distance);
  camera.near = distance / 100;
  camera.far = distance * 100;
  camera.updateProjectionMatrix();
  controls.update();
  addEventListener('resize', resize);
  controls.addEventListener('change', () => { dirty = true; });
  controls.addEventListener('end', () => { occlusionDue = true; });

  // ---- the panel
  const rowOf = new Map();
  function buildTable() {
    const body = $('rows');
    for (const id of D.order) {
      const p = state.get(id);
      if (!p) continue;
      const tr = body.appendChild(document.createElement('tr'));
      tr.dataset.id = id;
      tr.title = p.name || '';
      for (let i = 0; i < 4; i++) tr.appendChild(document.createElement('td'));
      tr.children[2].className = 'num';
      tr.children[3].className = 'note';
      tr.addEventListener('click', () => select(id));
      rowOf.set(id, tr);
    }
    for (const n of D.notes || []) $('notes').appendChild(document.createElement('div')).textContent = n;
    const box = $('missing');
    if (!D.missing.length) { box.className = 'none'; box.textContent = 'none'; }
    for (const m of D.missing) {
      const div = box.appendChild(document.createElement('div'));
      div.dataset.id = m.id;
      div.title = 'Click, then click the surface to place it';
      div.appendChild(document.createElement('b')).textContent = m.id;
      div.appendChild(document.createTextNode(m.name ? ' ' + m.name : ''));
      if (m.reason) {
        div.appendChild(document.createElement('br'));
        div.appendChild(document.createElement('span')).textContent = m.reason;
        div.lastChild.className = 'why';
      }
      div.addEventListener('click', () => select(m.id));
    }
    $('missinghead').textContent = 'Missing required points (' + D.missing.length + ')';
  }
  function refreshPoint(p) {
    const colour = p.id === selected ? SELECTED : confColor(p.confidence);
    const shown = !!p.shown;
    for (const m of [p.ui.front, p.ui.ghost]) {
      m.visible = shown;
      m.material.color.set(colour);
      if (shown) m.position.set(...p.shown);
      m.scale.setScalar(p.id === selected ? 1.7 : 1);
    }
    p.ui.label.classList.toggle('sel', p.id === selected);
    const tr = rowOf.get(p.id);
    if (tr) {
      tr.classList.toggle('sel', p.id === selected);
      tr.classList.toggle('moved', p.moved);
      tr.children[0].innerHTML = '';
      const dot = tr.children[0].appendChild(document.createElement('span'));
      dot.className = 'sw';
      dot.style.background = confColor(p.confidence);
      tr.children[0].appendChild(document.createTextNode(p.id));
      tr.children[1].textContent = p.vertex !== null ? (p.mesh === null ? '' : p.mesh + ' ') + '#' + p.vertex
                                                     : (p.position ? 'position' : 'missing');
      tr.children[2].textContent = p.confidence === null ? '' : p.confidence.toFixed(2);
      tr.children[3].textContent = p.missing && !p.moved ? 'missing' : (p.reason || '');
      tr.children[3].title = p.reason || '';
    }
    const div = document.querySelector('#missing div[data-id="' + p.id + '"]');
    if (div) {
      div.classList.toggle('sel', p.id === selected);
      div.firstChild.classList.toggle('placed', p.moved);
    }
    dirty = true;
  }
  function say(text) { statusBar.textContent = text; }
  function idle() {
    say('Click a point (or its row), then click the surface to move it there. Drag to turn the head, wheel to zoom.');
  }

  // ---- editing
  function select(id) {
    if (id !== null && !state.has(id)) throw new Error('no point ' + id + ' in this editor');
    const before = selected;
    selected = id;
    if (before && state.has(before)) refreshPoint(state.get(before));
    if (id === null) { idle(); return; }
    const p = state.get(id);
    refreshPoint(p);
    const tr = rowOf.get(id);
    if (tr) tr.scrollIntoView({ block: 'nearest' });
    say('Selected ' + id + (p.name ? ' (' + p.name + ')' : '') + ': click the surface to ' +
        (p.shown ? 'move' : 'place') + ' it, Esc to cancel.');
  }
  function nearestVertex(mesh, xyz) {
    const w = mesh.userData.world;
    let best = -1, bestD = Infinity;
    for (let i = 0; i < w.length; i += 3) {
      const d = (w[i] - xyz[0]) ** 2 + (w[i + 1] - xyz[1]) ** 2 + (w[i + 2] - xyz[2]) ** 2;
      if (d < bestD) { bestD = d; best = i / 3; }
    }
    return best;
  }
  function moveTo(meshName, where) {
    if (selected === null) throw new Error('select a point first');
    let mesh = meshName === null || meshName === undefined ? null : meshes.get(meshName);
    if (meshName != null && !mesh) throw new Error('no mesh ' + meshName + ' in this face');
    let index;
    if (Array.isArray(where)) {
      if (!mesh) {           // the nearest vertex of any mesh
        let bestD = Infinity;
        for (const m of meshes.values()) {
          const i = nearestVertex(m, where), w = m.userData.world;
          const d = (w[3 * i] - where[0]) ** 2 + (w[3 * i + 1] - where[1]) ** 2 + (w[3 * i + 2] - where[2]) ** 2;
          if (d < bestD) { bestD = d; mesh = m; index = i; }
        }
      } else index = nearestVertex(mesh, where);
    } else {
      index = Number(where);
      if (!mesh || !Number.isInteger(index) || index < 0 || 3 * index >= mesh.userData.world.length)
        throw new Error('vertex ' + where + ' is not a vertex of ' + meshName);
    }
    const p = state.get(selected), w = mesh.userData.world;
    const keep = ['position', 'mesh', 'vertex', 'confidence', 'shown', 'moved'];
    history.push({ id: p.id, before: Object.fromEntries(keep.map(k => [k, p[k]])) });
    const at = [w[3 * index], w[3 * index + 1], w[3 * index + 2]];
    Object.assign(p, { position: at, mesh: mesh.name, vertex: index, confidence: 1.0, shown: at, moved: true });
    const id = p.id;
    select(null);
    refreshPoint(p);
    occlusionDue = true;
    $('undo').disabled = false;
    say('Moved ' + id + ' to vertex ' + index + ' of ' + mesh.name + '.');
    return { id, mesh: mesh.name, vertex: index, position: at };
  }
  function undo() {
    const last = history.pop();
    if (!last) return null;
    const p = state.get(last.id);
    Object.assign(p, last.before);
    refreshPoint(p);
    occlusionDue = true;
    $('undo').disabled = history.length === 0;
    say('Undone: the move of ' + last.id + '.');
    return last.id;
  }
  function save() {
    const blob = new Blob([documentJson()], { type: 'application/json' });
    const a = document.createElement('a');
    a.href = URL.createObjectURL(blob);
    a.download = D.filename;
    document.body.appendChild(a);
    a.click();
    a.remove();
    setTimeout(() => URL.revokeObjectURL(a.href), 60000);
    say('Saved ' + D.filename + (history.length ? ' (' + history.length + ' move' + (history.length > 1 ? 's' : '') + ')' : '') + '.');
  }

  // ---- the mouse: a click (not a drag) picks a marker, else the surface
  const raycaster = new THREE.Raycaster();
  function pick(clientX, clientY) {
    const r = canvas.getBoundingClientRect();
    const ndc = new THREE.Vector2((clientX - r.left) / r.width * 2 - 1, -(clientY - r.top) / r.height * 2 + 1);
    raycaster.setFromCamera(ndc, camera);
    const hitMarker = raycaster.intersectObjects(markers.filter(m => m.visible), false)[0];
    const hitSurface = raycaster.intersectObjects(pickable, false)[0];
    if (hitMarker && (!hitSurface || hitMarker.distance <= hitSurface.distance + 0.01 * size))
      return { marker: hitMarker.object.userData.id };
    return hitSurface ? { surface: hitSurface } : {};
  }
  let down = null;
  canvas.addEventListener('pointerdown', e => { if (e.button === 0) down = [e.clientX, e.clientY]; });
  canvas.addEventListener('pointerup', e => {
    if (!down || e.button !== 0) return;
    const moved = Math.hypot(e.clientX - down[0], e.clientY - down[1]);
    down = null;
    if (moved > 4) return;
    const hit = pick(e.clientX, e.clientY);
    if (hit.marker && hit.marker !== selected) { select(hit.marker); return; }
    if (!hit.surface) { if (selected === null) idle(); return; }
    if (selected === null) { say('Select a point first: click its marker, its label or its row.'); return; }
    // the vertex of the clicked triangle nearest the click
    const s = hit.surface, mesh = s.object, w = mesh.userData.world;
    let best = s.face.a, bestD = Infinity;
    for (const v of [s.face.a, s.face.b, s.face.c]) {
      const d = (w[3 * v] - s.point.x) ** 2 + (w[3 * v + 1] - s.point.y) ** 2 + (w[3 * v + 2] - s.point.z) ** 2;
      if (d < bestD) { bestD = d; best = v; }
    }
    moveTo(mesh.name, best);
  });
  addEventListener('keydown', e => {
    if (e.key === 'Escape') select(null);
    if ((e.ctrlKey || e.metaKey) && e.key.toLowerCase() === 'z') { e.preventDefault(); undo(); }
  });
  $('undo').addEventListener('click', () => undo());
  $('save').addEventListener('click', () => save());
  $('showlabels').addEventListener('change', e => { labelBox.classList.toggle('off', !e.target.checked); });

  // ---- labels follow the markers; ones hidden behind the face are dimmed
  let occlusionDue = true;
  const v = new THREE.Vector3(), occluder = new THREE.Raycaster();
  function updateOcclusion() {
    occlusionDue = false;
    for (const p of state.values()) {
      if (!p.shown) continue;
      v.set(...p.shown);
      const toward = camera.position.clone().sub(v);
      const far = toward.length();
      occluder.set(v.clone().addScaledVector(toward.normalize(), 0.004 * size), toward);
      occluder.far = far;
      p.behind = occluder.intersectObjects(pickable, false).length > 0;
      p.ui.label.classList.toggle('behind', p.behind);
    }
  }
  function placeLabels() {
    const w = canvas.clientWidth, h = canvas.clientHeight;
    for (const p of state.values()) {
      const lab = p.ui.label;
      if (!p.shown) { lab.style.display = 'none'; continue; }
      v.set(...p.shown).project(camera);
      lab.style.display = v.z > 1 ? 'none' : '';
      lab.style.left = ((v.x + 1) / 2 * w).toFixed(1) + 'px';
      lab.style.top = ((1 - v.y) / 2 * h).toFixed(1) + 'px';
    }
  }
  function screenOf(meshName, index) {    // page coordinates of a vertex (or of a point by id)
    let xyz;
    if (index === undefined) xyz = state.get(meshName).shown;
    else { const w = meshes.get(meshName).userData.world; xyz = [w[3 * index], w[3 * index + 1], w[3 * index + 2]]; }
    const r = canvas.getBoundingClientRect();
    v.set(...xyz).project(camera);
    return { x: r.left + (v.x + 1) / 2 * r.width, y: r.top + (1 - v.y) / 2 * r.height };
  }

  buildTable();
  for (const p of state.values()) refreshPoint(p);
  idle();
  renderer.setAnimationLoop(() => {
    controls.update();
    if (occlusionDue) updateOcclusion();
    if (!dirty) return;
    dirty = false;
    placeLabels();
    renderer.render(scene, camera);
  });
  Object.assign(E, {
    select: id => { select(id); return selected; }, selected: () => selected, moveTo, undo, save,
    json: documentJson, screenOf, pyFloat, pyStr,
    points: () => [...state.values()].map(({ id, position, mesh, vertex, confidence, moved }) =>
      ({ id, position, mesh, vertex, confidence, moved })),
  });
  E.ready = true;
  $('msg').hidden = true;
  document.body.dataset.ready = '1';
}

main().catch(e => window.__fail(e && e.message || e));
