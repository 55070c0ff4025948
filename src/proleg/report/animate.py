"""3D animation of a result in a self-contained HTML page (three.js, vendored; opens offline).

Viewer choice: three.js r147 (MIT, ``report/vendor/``, from the npm package ``three``) inlined
in the page, rather than meshcat's static export: meshcat writes its static HTML only through a
running meshcat-server (ZeroMQ + a browser-side bundle), which a report writer should not need,
and its animation player has no speed control; three.js is what meshcat itself draws with, is
~600 kB minified, and lets the page carry its own player (play/pause, time slider, speed,
orbit camera under the mouse). r147 is the last release with a non-module build and the
classic ``examples/js`` OrbitControls, so both inline as plain scripts into one file.

What is drawn: every part at its pose (COM position and Euler parameters) — its URDF visual
meshes (STL/DAE/OBJ read with trimesh) and boxes/cylinders/spheres where the model came from
URDF, otherwise a box with the part's principal inertia (the uniform box of equal mass and
inertia); each joint as two blue segments, from part I's COM to marker I and from part J's COM
to marker J (the mechanism's stick figure); springs, actuators and bushings as lines between their
markers; contacts as spheres at the contact point with a force arrow; the ground grid at z = 0
(z up). A Parquet file of :meth:`Result.to_frame` carries the joints', springs' and contacts'
markers in its metadata (``attrs["proleg.viewer"]``), so ``proleg view`` draws the same lines
without ``--model``.

Use :func:`animate` for a page, :func:`animation_iframe` to embed one in a
:class:`proleg.report.Report` (``report.add_html(animation_iframe(result))``), and
``proleg view result.parquet`` from the command line.
"""

from __future__ import annotations

import base64
import html as _html
import json
from importlib import resources
from pathlib import Path

import numpy as np

LINE_KINDS = ("spring_damper", "hydraulic_actuator", "translational_actuator", "bushing")


def _b64(a, dtype=np.float32) -> str:
    return base64.b64encode(np.ascontiguousarray(np.asarray(a, dtype=dtype)).tobytes()).decode("ascii")


def _vendor(name: str) -> str:
    return resources.files("proleg.report").joinpath("vendor", name).read_text(encoding="utf-8")


def _frames(t, max_frames):
    n = len(t)
    return np.unique(np.linspace(0, n - 1, min(n, max_frames)).round().astype(int))


def _inertia_box(part):
    """Shapes for a part without visuals: the uniform box of equal mass and principal inertia."""
    try:
        m = float(part.mass)
        J = np.asarray(part.inertia, float)
        w, V = np.linalg.eigh(J)
        d2 = 6.0 / m * np.array([w[1] + w[2] - w[0], w[0] + w[2] - w[1], w[0] + w[1] - w[2]])
        d = np.sqrt(np.clip(d2, 0, None))
        d = np.maximum(d, 0.08 * d.max() if d.max() > 0 else 0.02)
        if np.linalg.det(V) < 0:
            V[:, 0] *= -1
        X = np.eye(4)
        X[:3, :3] = V
        return [{"kind": "box", "size": d.tolist(), "X": X.reshape(-1).tolist(), "color": None}]
    except (AttributeError, TypeError, ValueError, np.linalg.LinAlgError):
        return [{"kind": "sphere", "size": [0.03], "X": np.eye(4).reshape(-1).tolist(), "color": None}]


def _shapes(model, part_names):
    """Per-part shape lists and the mesh table."""
    meshes, shapes = {}, {n: [] for n in part_names}
    info = getattr(model, "urdf", None) if model is not None else None
    if info is not None:
        for vis in info.visuals:
            if vis.part not in shapes:
                continue
            s = {"kind": vis.kind, "X": np.asarray(vis.X_PV).reshape(-1).tolist(), "size": list(vis.size), "color": vis.color}
            if vis.kind == "mesh":
                key = f"{vis.filename}|{tuple(np.round(vis.scale, 9))}"
                if key not in meshes:
                    import trimesh

                    mesh = trimesh.load(vis.filename, force="mesh")
                    meshes[key] = {
                        "v": _b64(np.asarray(mesh.vertices) * vis.scale),
                        "f": _b64(np.asarray(mesh.faces), np.uint32),
                    }
                s["mesh"] = key
            shapes[vis.part].append(s)
    if model is not None:
        by_name = {p.name: p for p in model.parts}
        for n in part_names:
            if not shapes[n] and n in by_name:
                shapes[n] = _inertia_box(by_name[n])
    for n in part_names:
        if not shapes[n]:
            shapes[n] = [{"kind": "sphere", "size": [0.03], "X": np.eye(4).reshape(-1).tolist(), "color": None}]
    return shapes, meshes


def scene_from_result(result, *, model=None, max_frames: int = 600) -> dict:
    """The JSON scene the page plays: frames, part shapes and poses, lines, contacts."""
    topo = result.system.topo
    model = model if model is not None else topo.model
    idx = _frames(result.t, max_frames)
    names = list(topo.body_names)
    q = np.asarray(result.q)[idx]
    pose = np.stack([q[:, 7 * b : 7 * b + 7] for b in range(len(names))], 1)  # (n, nb, 7)
    shapes, meshes = _shapes(model, names)
    lines, pts = [], []
    for g in topo.groups + topo.extensions:
        if g.kind in LINE_KINDS and len(g):
            elems = [e for e in (model.forces + model.actuators if model is not None else []) if e.name in g.names]
            for e in elems:
                i, j = getattr(e, "i", None), getattr(e, "j", None)
                if i is None or j is None:
                    continue
                lines.append({"name": e.name, "kind": g.kind})
                pts.append(np.concatenate([result.marker(i.name).position[idx], result.marker(j.name).position[idx]], 1))
    from ..analyses.result import viewer_topology

    links, link_pts = _links({"joints": viewer_topology(result.system).get("joints", [])}, names, pose)  # springs drawn above
    lines, pts = links + lines, link_pts + pts
    contacts, cdata = [], []
    for g in topo.extensions:
        if g.kind == "contact" and len(g):
            for n in g.names:
                c = result.contact(n)
                radius = next((float(x.radius) for x in (model.contacts if model is not None else []) if x.name == n), 0.0)
                contacts.append({"name": n, "radius": radius})
                cdata.append(np.concatenate([np.asarray(c["point"])[idx], np.asarray(c["force"])[idx]], 1))
    return _scene(np.asarray(result.t)[idx], names, shapes, meshes, pose, lines, pts, contacts, cdata, getattr(model, "name", topo.name))


def scene_from_frame(df, *, model=None, max_frames: int = 600) -> dict:
    """A scene from :meth:`Result.to_frame` columns (a Parquet file): parts from ``NAME.x [m]`` and
    ``NAME.e0..e3``, contact forces from ``NAME.force_x [N]`` and ``NAME.point_x [m]`` if present."""
    t = df["time [s]"].to_numpy()
    idx = _frames(t, max_frames)
    names = [c[: -len(".x [m]")] for c in df.columns if c.endswith(".x [m]") and f"{c[:-6]}.e0" in df.columns]
    pose = np.stack(
        [np.stack([df[f"{n}.{k}"].to_numpy()[idx] for k in ("x [m]", "y [m]", "z [m]", "e0", "e1", "e2", "e3")], 1) for n in names], 1
    )
    shapes, meshes = _shapes(model, names)
    topo = df.attrs.get("proleg.viewer") or {}
    lines, pts = _links(topo, names, pose)
    radius = topo.get("contact_radius", {})
    contacts, cdata = [], []
    for c in df.columns:
        if c.endswith(".normal_force [N]"):
            n = c[: -len(".normal_force [N]")]
            cols = [f"{n}.point_{a} [m]" for a in "xyz"] + [f"{n}.force_{a} [N]" for a in "xyz"]
            if all(k in df.columns for k in cols):
                contacts.append({"name": n, "radius": float(radius.get(n, 0.0))})
                cdata.append(np.stack([df[k].to_numpy()[idx] for k in cols], 1))
    return _scene(t[idx], names, shapes, meshes, pose, lines, pts, contacts, cdata, getattr(model, "name", "result"))


def _marker_path(end, names, pose):
    """(n, 3) ground positions of a marker given as [part, local position (3,)] over the frames
    of ``pose`` ((n, nb, 7): COM position, Euler parameters); None for an unknown part."""
    from ..spatial.rotation import A_of_p

    part, s = end
    s = np.asarray(s, float)
    if part == "ground":
        return np.broadcast_to(s, (pose.shape[0], 3))
    if part not in names:
        return None
    b = names.index(part)
    p = np.asarray(pose[:, b, 3:], float)
    A = np.asarray(A_of_p(p / np.linalg.norm(p, axis=1, keepdims=True)))
    return np.asarray(pose[:, b, :3], float) + A @ s


def _links(topo: dict, names, pose):
    """Lines from the viewer topology (analyses/result.py ``viewer_topology``): each joint as two
    segments, part I's COM to marker I and part J's COM to marker J (the stick figure of the
    mechanism, kind ``"link"``), and each spring, actuator and bushing between its markers."""
    lines, pts = [], []
    for j in topo.get("joints", []):
        for side in ("i", "j"):
            part = j[side][0]
            end = _marker_path(j[side], names, pose)
            if part == "ground" or end is None:
                continue
            com = np.asarray(pose[:, names.index(part), :3], float)
            lines.append({"name": f"{j['name']} ({part})", "kind": "link"})
            pts.append(np.concatenate([com, end], 1))
    for e in topo.get("lines", []):
        a, b = _marker_path(e["i"], names, pose), _marker_path(e["j"], names, pose)
        if a is not None and b is not None:
            lines.append({"name": e["name"], "kind": e["kind"]})
            pts.append(np.concatenate([a, b], 1))
    return lines, pts


def _scene(t, names, shapes, meshes, pose, lines, pts, contacts, cdata, title):
    n = len(t)
    r = pose[:, :, :3].reshape(-1, 3)
    for p in pts:
        r = np.concatenate([r, p.reshape(-1, 3)])
    lo, hi = r.min(0), r.max(0)
    fmax = max([float(np.linalg.norm(c[:, 3:], axis=1).max()) for c in cdata] + [0.0])
    return {
        "title": title,
        "t": np.asarray(t, float).tolist(),
        "parts": [{"name": nm, "shapes": shapes[nm]} for nm in names],
        "meshes": meshes,
        "pose": _b64(pose),
        "lines": lines,
        "line_pts": _b64(np.stack(pts, 1) if pts else np.zeros((n, 0, 6))),
        "contacts": contacts,
        "contact_data": _b64(np.stack(cdata, 1) if cdata else np.zeros((n, 0, 6))),
        "bounds": [lo.tolist(), hi.tolist()],
        "force_max": fmax,
    }


def _unb64(b: str, shape_tail: tuple, dtype=np.float32) -> np.ndarray:
    return np.frombuffer(base64.b64decode(b), dtype=dtype).reshape(-1, *shape_tail)


def combine_scenes(scenes: dict, spacing: float | None = None) -> dict:
    """One scene holding several (``{label: scene}``, e.g. the same test with three joint
    models), side by side along y, ``spacing`` [m] apart (default: 1.2 × the widest scene's
    extent + 0.4 m). Part, line and contact names get a ``"label: "`` prefix. Every scene must have
    the same frame times (the same output times and ``max_frames``)."""
    items = list(scenes.items())
    if not items:
        raise ValueError("combine_scenes: no scenes given.")
    t0 = np.asarray(items[0][1]["t"])
    for label, sc in items[1:]:
        if len(sc["t"]) != len(t0) or not np.allclose(sc["t"], t0, rtol=0, atol=1e-9):
            raise ValueError(
                f"combine_scenes: scene '{label}' has other frame times than '{items[0][0]}'; "
                "animate results with the same output times and max_frames."
            )
    n = len(t0)
    if spacing is None:
        # the bounds hold the parts' origins, not their shapes: 0.4 m more for the bodies drawn around them
        spacing = 1.2 * max(max(sc["bounds"][1][k] - sc["bounds"][0][k] for k in range(2)) for _, sc in items) + 0.4
    parts, meshes, lines, contacts, poses, lps, cds, lo, hi = [], {}, [], [], [], [], [], [], []
    for i, (label, sc) in enumerate(items):
        dy = np.array([0.0, (i - 0.5 * (len(items) - 1)) * spacing, 0.0], np.float32)
        parts += [{**p, "name": f"{label}: {p['name']}"} for p in sc["parts"]]
        meshes.update(sc["meshes"])
        lines += [{**x, "name": f"{label}: {x['name']}"} for x in sc["lines"]]
        contacts += [{**x, "name": f"{label}: {x['name']}"} for x in sc["contacts"]]
        pose = _unb64(sc["pose"], (len(sc["parts"]), 7)).copy()
        pose[..., :3] += dy
        lp = _unb64(sc["line_pts"], (len(sc["lines"]), 6)).copy() if sc["lines"] else np.zeros((n, 0, 6), np.float32)
        lp[..., :3] += dy
        lp[..., 3:] += dy
        cd = _unb64(sc["contact_data"], (len(sc["contacts"]), 6)).copy() if sc["contacts"] else np.zeros((n, 0, 6), np.float32)
        cd[..., :3] += dy
        poses.append(pose), lps.append(lp), cds.append(cd)
        lo.append(np.asarray(sc["bounds"][0]) + dy), hi.append(np.asarray(sc["bounds"][1]) + dy)
    return {
        "title": " | ".join(label for label, _ in items),
        "t": t0.tolist(),
        "parts": parts,
        "meshes": meshes,
        "pose": _b64(np.concatenate(poses, 1)),
        "lines": lines,
        "line_pts": _b64(np.concatenate(lps, 1)),
        "contacts": contacts,
        "contact_data": _b64(np.concatenate(cds, 1)),
        "bounds": [np.min(lo, 0).tolist(), np.max(hi, 0).tolist()],
        "force_max": max(float(sc["force_max"]) for _, sc in items),
    }


def page(scene: dict, title: str | None = None) -> str:
    """The self-contained HTML page for a scene."""
    title = _html.escape(title or f"proleg: {scene['title']}")
    data = json.dumps(scene, separators=(",", ":")).replace("</", "<\\/")
    return _TEMPLATE.format(title=title, three=_vendor("three.min.js"), orbit=_vendor("OrbitControls.js"), data=data, player=_PLAYER)


def animate(result, path=None, *, model=None, title: str | None = None, max_frames: int = 600) -> str:
    """Write (``path``) and return a self-contained HTML animation of ``result``.

    Parameters
    ----------
    result : proleg.Result
    path : str or Path, optional; the .html file to write
    model : proleg.Model, optional; default the model the result's system was assembled from
    max_frames : int; frames kept (evenly spaced output samples)

    The page opens offline. ``#t=0.25`` in the URL shows t = 0.25 s paused (used by the browser test).
    """
    text = page(scene_from_result(result, model=model, max_frames=max_frames), title)
    if path is not None:
        Path(path).parent.mkdir(parents=True, exist_ok=True)
        Path(path).write_text(text, encoding="utf-8")
    return text


def scene_iframe(scene: dict, *, height: int = 480, title: str | None = None) -> str:
    """An ``<iframe srcdoc>`` holding the page of a scene (:func:`scene_from_result`,
    :func:`combine_scenes`), for ``Report.add_html``; a scene is plain JSON data, so a worker
    process can build it and send it back instead of the Result."""
    text = page(scene, title)
    return f'<iframe style="width:100%;height:{int(height)}px;border:1px solid #ccc" srcdoc="{_html.escape(text, quote=True)}"></iframe>'


def animation_iframe(result, *, height: int = 480, model=None, title: str | None = None, max_frames: int = 600) -> str:
    """An ``<iframe srcdoc>`` holding the animation page, for ``Report.add_html`` (several may share a report)."""
    return scene_iframe(scene_from_result(result, model=model, max_frames=max_frames), height=height, title=title)


_PLAYER = r"""
(function(){
const S = JSON.parse(document.getElementById('scene-data').textContent);
const status = document.getElementById('status');
function fail(msg){ status.textContent = 'error: ' + msg; status.className = 'err'; }
window.addEventListener('error', e => fail(e.message));
const cerr = console.error.bind(console); console.error = (...a) => { fail(a.join(' ')); cerr(...a); };
function f32(b){ const s = atob(b), u = new Uint8Array(s.length); for (let i=0;i<s.length;i++) u[i]=s.charCodeAt(i); return new Float32Array(u.buffer); }
function u32(b){ const s = atob(b), u = new Uint8Array(s.length); for (let i=0;i<s.length;i++) u[i]=s.charCodeAt(i); return new Uint32Array(u.buffer); }
const T = S.t, nf = T.length, np_ = S.parts.length;
const pose = f32(S.pose), lp = f32(S.line_pts), cd = f32(S.contact_data);
const nl = S.lines.length, nc = S.contacts.length;
const view = document.getElementById('view');
let renderer;
try { renderer = new THREE.WebGLRenderer({antialias:true, preserveDrawingBuffer:true}); }
catch (e) { fail('WebGL is not available: ' + e.message); return; }
renderer.setPixelRatio(window.devicePixelRatio || 1);
view.appendChild(renderer.domElement);
const scene = new THREE.Scene(); scene.background = new THREE.Color(0xf4f6f8);
const camera = new THREE.PerspectiveCamera(40, 1, 0.01, 1000); camera.up.set(0,0,1);
scene.add(new THREE.HemisphereLight(0xffffff, 0x667788, 0.8));
const sun = new THREE.DirectionalLight(0xffffff, 0.7); sun.position.set(3,-4,6); scene.add(sun);
const lo = S.bounds[0], hi = S.bounds[1];
const ctr = new THREE.Vector3((lo[0]+hi[0])/2,(lo[1]+hi[1])/2,(lo[2]+hi[2])/2);
const L = Math.max(hi[0]-lo[0], hi[1]-lo[1], hi[2]-lo[2], 0.2);
const grid = new THREE.GridHelper(Math.max(4*L, 1), 20, 0x999999, 0xcccccc); grid.rotation.x = Math.PI/2; scene.add(grid);
scene.add(new THREE.AxesHelper(0.2*L));
const meshGeo = {};
for (const k in S.meshes){ const g = new THREE.BufferGeometry();
  g.setAttribute('position', new THREE.BufferAttribute(f32(S.meshes[k].v), 3)); g.setIndex(new THREE.BufferAttribute(u32(S.meshes[k].f), 1));
  g.computeVertexNormals(); meshGeo[k] = g; }
const palette = [0x4e79a7,0xf28e2b,0x59a14f,0xe15759,0x76b7b2,0xedc948,0xb07aa1,0xff9da7,0x9c755f,0xbab0ac];
const groups = S.parts.map((p, i) => { const grp = new THREE.Group(); grp.name = p.name;
  for (const s of p.shapes){ let g;
    if (s.kind === 'mesh') g = meshGeo[s.mesh];
    else if (s.kind === 'box') g = new THREE.BoxGeometry(s.size[0], s.size[1], s.size[2]);
    else if (s.kind === 'cylinder') { g = new THREE.CylinderGeometry(s.size[0], s.size[0], s.size[1], 24); g.rotateX(Math.PI/2); }
    else g = new THREE.SphereGeometry(s.size[0], 20, 14);
    const c = s.color && (s.color[0]+s.color[1]+s.color[2] > 0.05) ? new THREE.Color(s.color[0], s.color[1], s.color[2]) : new THREE.Color(palette[i % palette.length]);
    const m = new THREE.Mesh(g, new THREE.MeshStandardMaterial({color:c, metalness:0.1, roughness:0.7}));
    const X = new THREE.Matrix4(); X.set(...s.X); m.applyMatrix4(X); grp.add(m); }
  scene.add(grp); return grp; });
const lines = S.lines.map(l => { const g = new THREE.BufferGeometry(); g.setAttribute('position', new THREE.BufferAttribute(new Float32Array(6), 3));
  const o = new THREE.Line(g, new THREE.LineBasicMaterial({color: l.kind === 'link' ? 0x1f77b4 : l.kind === 'bushing' ? 0x333333 : 0xd62728})); scene.add(o); return o; });
const fscale = S.force_max > 0 ? 0.3*L / S.force_max : 0;
const contacts = S.contacts.map(c => { const b = new THREE.Mesh(new THREE.SphereGeometry(Math.max(c.radius, 0.01*L), 16, 12), new THREE.MeshStandardMaterial({color:0x222222}));
  const a = new THREE.ArrowHelper(new THREE.Vector3(0,0,1), new THREE.Vector3(), 0.1, 0x2ca02c); scene.add(b); scene.add(a); return {b, a}; });
camera.position.set(ctr.x + 1.6*L + 0.5, ctr.y - 2.2*L - 0.5, ctr.z + 1.0*L + 0.3);
const controls = new THREE.OrbitControls(camera, renderer.domElement); controls.target.copy(ctr); controls.update();
const play = document.getElementById('play'), slider = document.getElementById('slider'), speed = document.getElementById('speed'), tlabel = document.getElementById('tlabel');
slider.max = nf - 1;
let frame = 0, playing = true, simt = T[0], last = null;
function show(k){ frame = k; slider.value = k; tlabel.textContent = 't = ' + T[k].toFixed(4) + ' s';
  for (let b=0;b<np_;b++){ const o = 7*(k*np_+b); groups[b].position.set(pose[o],pose[o+1],pose[o+2]); groups[b].quaternion.set(pose[o+4],pose[o+5],pose[o+6],pose[o+3]); }
  for (let l=0;l<nl;l++){ const o = 6*(k*nl+l), a = lines[l].geometry.attributes.position; for (let j=0;j<6;j++) a.array[j] = lp[o+j]; a.needsUpdate = true; lines[l].geometry.computeBoundingSphere(); }
  for (let c=0;c<nc;c++){ const o = 6*(k*nc+c), p = new THREE.Vector3(cd[o],cd[o+1],cd[o+2]), f = new THREE.Vector3(cd[o+3],cd[o+4],cd[o+5]);
    contacts[c].b.position.copy(p); const n = f.length();
    contacts[c].a.visible = n*fscale > 1e-4*L; if (contacts[c].a.visible){ contacts[c].a.position.copy(p); contacts[c].a.setDirection(f.clone().normalize()); contacts[c].a.setLength(n*fscale, 0.2*n*fscale, 0.1*n*fscale); } } }
function frameAt(t){ let lo_ = 0, hi_ = nf-1; while (hi_-lo_ > 1){ const m = (lo_+hi_)>>1; if (T[m] <= t) lo_ = m; else hi_ = m; } return (t - T[lo_] < T[hi_] - t) ? lo_ : hi_; }
play.onclick = () => { playing = !playing; play.textContent = playing ? 'pause' : 'play'; last = null; };
slider.oninput = () => { playing = false; play.textContent = 'play'; simt = T[+slider.value]; show(+slider.value); };
const m = /[#&]t=([0-9.eE+-]+)/.exec(location.hash);
if (m){ playing = false; play.textContent = 'play'; simt = +m[1]; }
function resize(){ const w = view.clientWidth, h = view.clientHeight; renderer.setSize(w, h); camera.aspect = w/h; camera.updateProjectionMatrix(); }
window.addEventListener('resize', resize); resize();
show(frameAt(simt));
function loop(now){ if (playing){ if (last !== null){ simt += (now-last)/1000 * (+speed.value); if (simt > T[nf-1]) simt = T[0]; } last = now; show(frameAt(simt)); }
  controls.update(); renderer.render(scene, camera); requestAnimationFrame(loop); }
renderer.render(scene, camera);
status.textContent = 'ok: ' + np_ + ' parts, ' + nf + ' frames'; status.className = 'ok';
requestAnimationFrame(loop);
})();
"""

_TEMPLATE = """<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{title}</title>
<style>
html,body{{margin:0;height:100%;font:13px system-ui,sans-serif;background:#fff}}
#view{{position:absolute;top:0;left:0;right:0;bottom:40px}}
#bar{{position:absolute;left:0;right:0;bottom:0;height:40px;display:flex;gap:10px;align-items:center;padding:0 10px;background:#eee}}
#slider{{flex:1}} #status{{color:#666;font-size:11px}} #status.err{{color:#b00}}
</style></head><body>
<div id="view"></div>
<div id="bar"><button id="play">pause</button><input id="slider" type="range" min="0" value="0" step="1">
<span id="tlabel"></span><label>speed <select id="speed"><option>0.1</option><option>0.25</option><option>0.5</option><option selected>1</option><option>2</option></select></label>
<span id="status">loading</span></div>
<script>{three}</script>
<script>{orbit}</script>
<script type="application/json" id="scene-data">{data}</script>
<script>{player}</script>
</body></html>
"""
