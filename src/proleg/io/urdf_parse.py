"""Reading a URDF file for :func:`proleg.io.load_urdf`: the XML checks that name what a malformed
file is missing (element, attribute, line), yourdfpy's parse, and ``package://`` mesh paths."""

from __future__ import annotations

from pathlib import Path

from ..errors import ModelError

SUPPORTED = ("revolute", "continuous", "prismatic", "fixed", "floating", "planar")
# (element path from <robot>, attribute, how to fix) for the attributes URDF requires
REQUIRED = (
    (".", "name", 'Give the robot a name: <robot name="my_robot">.'),
    ("link", "name", 'Give every link a unique name: <link name="...">.'),
    ("joint", "name", 'Give every joint a unique name: <joint name="..." type="...">.'),
    ("joint", "type", "Give the joint a type: revolute, continuous, prismatic, fixed, floating or planar."),
    ("link/inertial/mass", "value", 'Give the mass in kg: <mass value="1.0"/>.'),
    (".//geometry/box", "size", 'Give the box size in m: <box size="x y z"/>.'),
    (".//geometry/cylinder", "radius", 'Give the cylinder radius and length in m: <cylinder radius="r" length="l"/>.'),
    (".//geometry/cylinder", "length", 'Give the cylinder radius and length in m: <cylinder radius="r" length="l"/>.'),
    (".//geometry/sphere", "radius", 'Give the sphere radius in m: <sphere radius="r"/>.'),
    (".//geometry/mesh", "filename", 'Give the mesh file: <mesh filename="package://pkg/meshes/part.stl"/>.'),
)


def _parse(path: Path):
    try:
        import yourdfpy
    except ImportError as exc:  # pragma: no cover
        raise ModelError("load_urdf needs yourdfpy: pip install 'proleg[urdf]'.") from exc
    if not path.is_file():
        raise ModelError(f"URDF file {path} not found. Give the path of an existing .urdf file.")
    try:
        from lxml import etree

        root = etree.parse(str(path)).getroot()
    except Exception as exc:  # lxml.etree.XMLSyntaxError and OSError
        raise ModelError(f"URDF file {path}: not well-formed XML ({exc}). Fix the XML syntax.") from exc
    if root.tag != "robot":
        raise ModelError(f"URDF file {path}: the root element is <{root.tag}>, expected <robot>.")
    for xpath, attr, fix in REQUIRED:
        for e in root.iterfind(xpath):
            if e.get(attr) is None:
                owner = next((a for a in e.iterancestors() if a.tag in ("link", "joint")), None)
                within = f" of {owner.tag} '{owner.get('name')}'" if owner is not None and owner is not e else ""
                raise ModelError(
                    f"URDF file {path}, line {e.sourceline}: <{e.tag}>{within} has no '{attr}' attribute, which URDF requires. {fix}"
                )
    for j in root.findall("joint"):
        jt = j.get("type")
        if jt not in SUPPORTED:
            raise ModelError(
                f"URDF file {path}: joint '{j.get('name')}' has type '{jt}', which proleg cannot import; "
                f"supported URDF joint types: {', '.join(SUPPORTED)}."
            )
        for tag in ("parent", "child"):
            e = j.find(tag)
            if e is None or not e.get("link"):
                raise ModelError(f"URDF file {path}: joint '{j.get('name')}' has no <{tag} link=...>; every joint needs both.")
    try:
        urdf = yourdfpy.URDF.load(
            str(path), build_scene_graph=False, load_meshes=False, build_collision_scene_graph=False, load_collision_meshes=False
        )
    except Exception as exc:
        raise ModelError(f"URDF file {path} could not be read: {type(exc).__name__}: {exc}.") from exc
    return urdf.robot


def _resolve_mesh(filename: str, urdf_path: Path, package_dirs) -> Path:
    """Resolve ``package://pkg/rest``, ``file://`` or a relative path against the URDF's folder."""
    if filename.startswith("file://"):
        return Path(filename[7:])
    if filename.startswith("package://"):
        rest = filename[len("package://") :]
        pkg, _, sub = rest.partition("/")
        cands = [Path(d) / pkg / sub for d in (package_dirs or [])] + [Path(d) / sub for d in (package_dirs or [])]
        for parent in urdf_path.resolve().parents:
            if parent.name == pkg:
                cands.append(parent / sub)
            cands.append(parent / pkg / sub)
        for c in cands:
            if c.is_file():
                return c
        return cands[0] if cands else Path(sub)
    p = Path(filename)
    return p if p.is_absolute() else urdf_path.parent / p
