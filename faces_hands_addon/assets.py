# SPDX-License-Identifier: GPL-3.0-or-later
"""Loaders for the committed default assets (``<extension root>/assets``, written by ``make assets``).

Every function returns plain dataclasses of numpy arrays ALREADY IN THE PROJECT CONVENTION:
metres, Z up, the face looks along -Y, +X is the character's left (CONTRIBUTING.md). The source
conventions, worked out from the data (see tests/engine/test_assets.py for the checks):

* MediaPipe canonical face (npm ``@mediapipe/face_mesh`` 0.4.1633559619): centimetres, +y up,
  +z out of the face towards the viewer, +x the face's own left (landmark 263, MediaPipe's left eye
  corner, has x > 0). Ours: ``(X, Y, Z) = 0.01 * (x, -z, y)``.
* myo_sim meshes and MJCF (PyPI ``myo-sim`` 0.2.4, OpenSim/MuJoCo ground frame): metres, +x anterior
  (the jaw and the face lie at +x), +y up, +z the body's right. Ours: ``(X, Y, Z) = (-z, -x, y)``.
* WebXR generic hands (npm ``@webxr-input-profiles/assets`` 1.0.20, glTF 2.0): metres, +y up, and
  authored in WebXR user space, where the user looks along -z and +x is the user's right (the left
  hand's wrist lies at x < 0, the thumbs point to -z). Ours: ``(X, Y, Z) = (-x, z, y)``, so the left
  hand sits at +X with its thumb forward (-Y). (Blender's glTF importer, which assumes the glTF
  "front = +z" rule, would give ``(x, -z, y)`` and turn the hands round.)

All three are proper rotations (determinant +1), so triangle winding and handedness survive.
Nothing here downloads or writes anything; no ``bpy``.
"""
from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path

import numpy as np

from .core.errors import UserError
from .core.geometry import vertex_normals
from .meshio import read_glb, read_obj, read_stl

ASSETS_DIR = Path(__file__).resolve().parents[1] / "assets"
MEDIAPIPE_DIR = ASSETS_DIR / "mediapipe"
MYOSIM_DIR = ASSETS_DIR / "myo_sim" / "models"
WEBXR_DIR = ASSETS_DIR / "webxr" / "generic-hand"

# Rows give our X, Y, Z in terms of the source x, y, z.
MEDIAPIPE_TO_FH = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
OPENSIM_TO_FH = np.array([[0.0, 0.0, -1.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
WEBXR_TO_FH = np.array([[-1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 1.0, 0.0]])
MEDIAPIPE_SCALE = 0.01  # cm -> m

# The 27 hand bones of myo_sim (thumb: 1mc + thumbprox + thumbdist, no middle phalanx) + forearm.
HAND_BONES = (
    ("1mc", "thumbprox", "thumbdist")
    + tuple(f"{d}{part}" for d in (2, 3, 4, 5) for part in ("mc", "proxph", "midph", "distph"))
    + ("capitate", "hamate", "lunate", "pisiform", "scaphoid", "trapezium", "trapezoid", "triquetrum")
)
FOREARM_BONES = ("radius", "ulna")
# MyoHand = MyoArm pruned by myo_sim/build/hand.py (RIGHT_HAND_REMOVED_JOINTS): these arm joints go.
_ARM_ONLY_JOINTS = frozenset({
    "sternoclavicular_r2_r", "sternoclavicular_r3_r", "unrotscap_r3_r", "unrotscap_r2_r",
    "acromioclavicular_r2_r", "acromioclavicular_r3_r", "acromioclavicular_r1_r", "unrothum_r1_r",
    "unrothum_r3_r", "unrothum_r2_r", "elv_angle_r", "shoulder_elv_r", "shoulder1_r2_r",
    "shoulder_rot_r", "elbow_flexion_r"})
WRIST_BODY = "lunate_r"  # its origin is the wrist joint centre (deviation_r / flexion_r act there)


@dataclass
class Mesh:
    """A triangle mesh in project coordinates (metres, Z up, face along -Y)."""
    name: str
    vertices: np.ndarray                 # (N,3) float64
    faces: np.ndarray                    # (M,3) int64, counter-clockwise seen from outside
    uvs: np.ndarray | None = None        # (N,2) per vertex, Blender convention (v up)
    normals: np.ndarray | None = None    # (N,3) per vertex, unit length


@dataclass
class FaceContours:
    """MediaPipe's named contours as ordered index polylines into :func:`canonical_face` vertices.

    ``_L`` / ``_R`` = the character's left / right (+X / -X). ``refined_only`` holds the iris rings,
    whose indices (468-477) exist only in MediaPipe's 478-landmark output, not in the canonical mesh.
    """
    lines: dict[str, np.ndarray]
    closed: dict[str, bool]
    sources: dict[str, str]
    refined_only: dict[str, np.ndarray]


@dataclass
class SkinnedHand:
    """A WebXR generic hand: skinned mesh + its 25 joints, all in project coordinates.

    ``rest_local[j]`` is joint ``j``'s transform relative to its parent node (joint ``parents[j]``, or
    the armature node when -1), ``rest_world[j]`` its transform in the file's scene, ``inverse_bind[j]``
    as in glTF (skeleton/mesh space -> joint space), so ``rest_world @ inverse_bind`` is ~identity at
    rest. ``skin_joints``/``skin_weights`` give up to 4 influences per vertex (indices into the joints).
    """
    side: str
    mesh: Mesh
    joint_names: list[str]
    parents: np.ndarray
    rest_local: np.ndarray
    rest_world: np.ndarray
    inverse_bind: np.ndarray
    skin_joints: np.ndarray
    skin_weights: np.ndarray


@dataclass
class MyoBody:
    name: str
    parent: str | None
    offset: np.ndarray          # position in the parent body (project axes, metres)
    position: np.ndarray        # rest position relative to the wrist centre (project axes, metres)
    meshes: list[str] = field(default_factory=list)  # mesh file stems under assets/myo_sim/models/meshes


@dataclass
class MyoJoint:
    name: str
    body: str                   # the body the joint moves (its parent body is the joint's parent)
    parent_body: str | None
    kind: str                   # "hinge" (all MyoHand joints) / "slide" / ...
    axis: np.ndarray            # unit axis in project coordinates (bodies carry no rotation at rest)
    range: tuple[float, float]  # radians
    position: np.ndarray        # joint centre at rest, relative to the wrist centre


@dataclass
class PathPoint:
    kind: str                   # "site" or "wrap" (a wrapping geom, optional side site)
    name: str
    body: str
    position: np.ndarray        # rest position (site, or the wrap geom's centre) rel. to the wrist
    sidesite: str | None = None


@dataclass
class MyoMuscle:
    name: str
    tendon: str
    force: float                # maximal isometric force, N
    length_range: tuple[float, float]
    path: list[PathPoint]


@dataclass
class MyoHandModel:
    """The MyoHand musculoskeletal model (myo_sim 0.2.4 MyoArm MJCF, hand part), rest pose."""
    bodies: dict[str, MyoBody]
    joints: list[MyoJoint]
    muscles: list[MyoMuscle]
    wrist_origin: np.ndarray    # where the wrist centre lies in the converted MJCF root frame


def _path(*parts: str | Path) -> Path:
    path = ASSETS_DIR.joinpath(*parts)
    if not path.is_file():
        raise UserError(f"default asset {path.relative_to(ASSETS_DIR.parent)} is missing; "
                        "reinstall the extension (or run `make assets` in a source checkout)")
    return path


def _unit_rows(vectors: np.ndarray) -> np.ndarray:
    norms = np.linalg.norm(vectors, axis=1, keepdims=True)
    return vectors / np.where(norms > 0, norms, 1.0)


def canonical_face() -> Mesh:
    """MediaPipe's canonical face (468 vertices = landmarks 0..467, 898 triangles), metres.

    Source: ``assets/mediapipe/canonical_face.obj`` (cm, MediaPipe axes; v already flipped).
    """
    data = read_obj(_path("mediapipe", "canonical_face.obj"))
    if len(data.vertices) != 468 or data.vertex_uvs is None:
        raise UserError("canonical_face.obj: expected 468 vertices with one UV each; run `make assets`")
    vertices = MEDIAPIPE_SCALE * data.vertices @ MEDIAPIPE_TO_FH.T
    return Mesh("canonical_face", vertices, data.faces, data.vertex_uvs.copy(),
                vertex_normals(vertices, data.faces))


def face_contours() -> FaceContours:
    """Named contours of the canonical face, from ``assets/mediapipe/contours.json``."""
    path = _path("mediapipe", "contours.json")
    try:
        table = json.loads(path.read_text(encoding="utf-8"))
        items = table["contours"]
        lines = {k: np.asarray(v["indices"], dtype=np.int64) for k, v in items.items()}
        closed = {k: bool(v["closed"]) for k, v in items.items()}
        sources = {k: str(v["source"]) for k, v in items.items()}
        refined = {k: np.asarray(v["indices"], dtype=np.int64)
                   for k, v in table.get("refined_landmarks_only", {}).items() if isinstance(v, dict)}
    except (ValueError, KeyError, TypeError) as exc:
        raise UserError(f"contours.json is malformed ({exc}); run `make assets`") from None
    return FaceContours(lines, closed, sources, refined)


# -------------------------------------------------------------------------------------- myo_sim

def _myo_mesh(stem: str, offset: np.ndarray | None = None) -> Mesh:
    vertices, faces = read_stl(_path("myo_sim", "models", "meshes", f"{stem}.stl"))
    if offset is not None:
        vertices = vertices + offset
    vertices = vertices @ OPENSIM_TO_FH.T
    return Mesh(stem, vertices, faces, None, vertex_normals(vertices, faces))


def skull() -> Mesh:
    """myo_sim ``hat_skull.stl`` (cranium + maxilla), metres, project axes.

    Kept in the meshes' own frame, in which skull and jaw are registered (myo-sim's
    ``head/assets/myohead_rigid_chain.xml``, not copied, places both geoms at the same offset), so
    :func:`jaw` fits it as is; the skull spans roughly Z 0.49..0.65 m, centred on X = 0.
    """
    return _myo_mesh("hat_skull")


def jaw() -> Mesh:
    """myo_sim ``hat_jaw.stl`` (mandible) in the same frame as :func:`skull`."""
    return _myo_mesh("hat_jaw")


@lru_cache(maxsize=1)
def _mjcf() -> "_Mjcf":
    return _Mjcf(MYOSIM_DIR / "arm" / "assets")


def hand_bones(include_forearm: bool = True) -> dict[str, Mesh]:
    """The right hand's 27 bones (+ radius and ulna) placed in MyoHand's rest pose, metres.

    Each STL is stored in its own body frame; bodies carry only translations in
    ``myoarm_r_chain.xml``, so the rest pose is the sum of body offsets. The result is expressed
    relative to the wrist centre (origin of body ``lunate_r``): the arm hangs, fingers point to -Z,
    the thumb side faces forward (-Y), the palm faces the body (+X for this right hand).
    """
    model = _mjcf()
    wanted = HAND_BONES + (FOREARM_BONES if include_forearm else ())
    bones = {}
    for stem in wanted:
        body = model.mesh_body.get(stem)
        if body is None:
            raise UserError(f"myoarm_r MJCF does not place mesh {stem}; run `make assets`")
        bones[stem] = _myo_mesh(stem, model.world[body] - model.world[WRIST_BODY])
    return bones


def myohand_model() -> MyoHandModel:
    """Joints (axes, ranges), bodies and the 39 hand muscles (site paths, forces) of MyoHand.

    Source: ``assets/myo_sim/models/arm/assets/myoarm_r_{chain,tendon,muscle}.xml`` (MyoArm MJCF);
    MyoHand keeps its wrist/hand part (myo_sim/build/hand.py prunes the same way: shoulder and elbow
    joints go; the muscles are the 39 ``<muscle>`` actuators). Read with ``xml.etree`` only.
    """
    m = _mjcf()
    origin = m.world[WRIST_BODY]

    def fh(point: np.ndarray) -> np.ndarray:
        return OPENSIM_TO_FH @ (point - origin)

    bodies = {name: MyoBody(name, m.parent[name], OPENSIM_TO_FH @ m.offset[name], fh(m.world[name]),
                            list(m.body_meshes[name])) for name in m.order}
    joints = [MyoJoint(j["name"], j["body"], m.parent[j["body"]], j["type"],
                       _unit_rows((OPENSIM_TO_FH @ j["axis"])[None])[0], j["range"],
                       fh(m.world[j["body"]] + j["pos"]))
              for j in m.joints if j["name"] not in _ARM_ONLY_JOINTS]
    muscles = []
    for a in m.muscles:
        points = []
        for kind, name, sidesite in m.tendons.get(a["tendon"], ()):
            table = m.sites if kind == "site" else m.wraps
            if name not in table:
                raise UserError(f"MyoHand tendon {a['tendon']} uses unknown {kind} {name}")
            body, local = table[name]
            points.append(PathPoint("site" if kind == "site" else "wrap", name, body,
                                    fh(m.world[body] + local), sidesite))
        if not points:
            raise UserError(f"MyoHand muscle {a['name']} has no tendon path {a['tendon']}")
        muscles.append(MyoMuscle(a["name"], a["tendon"], a["force"], a["lengthrange"], points))
    return MyoHandModel(bodies, joints, muscles, OPENSIM_TO_FH @ origin)


def _floats(element: ET.Element, attr: str, count: int, default=None) -> np.ndarray | None:
    text = element.get(attr)
    if text is None:
        return None if default is None else np.asarray(default, dtype=np.float64)
    try:
        values = np.asarray([float(t) for t in text.split()], dtype=np.float64)
    except ValueError:
        values = np.zeros(0)
    if len(values) != count:
        raise UserError(f"MyoHand MJCF: {element.tag} {element.get('name')!r} has a bad {attr}={text!r}")
    return values


class _Mjcf:
    """The parts of the MyoArm MJCF (MuJoCo XML) the hand needs, in the SOURCE frame (OpenSim axes)."""

    def __init__(self, folder: Path):
        chain = self._parse(folder / "myoarm_r_chain.xml")
        assets = self._parse(folder / "myoarm_r_assets.xml")
        tendon = self._parse(folder / "myoarm_r_tendon.xml")
        muscle = self._parse(folder / "myoarm_r_muscle.xml")
        mesh_file = {m.get("name"): Path(m.get("file", "")).stem for m in assets.iter("mesh")}
        self.order: list[str] = []
        self.parent: dict[str, str | None] = {}
        self.offset: dict[str, np.ndarray] = {}
        self.world: dict[str, np.ndarray] = {}
        self.body_meshes: dict[str, list[str]] = {}
        self.mesh_body: dict[str, str] = {}
        self.joints: list[dict] = []
        self.sites: dict[str, tuple[str, np.ndarray]] = {}
        self.wraps: dict[str, tuple[str, np.ndarray]] = {}
        for root_body in chain.findall("body"):
            self._walk(root_body, None, np.zeros(3), mesh_file)
        self.tendons: dict[str, list[tuple[str, str, str | None]]] = {}
        for spatial in tendon.iter("spatial"):
            self.tendons[spatial.get("name")] = [
                ("site", item.get("site"), None) if item.tag == "site"
                else ("geom", item.get("geom"), item.get("sidesite"))
                for item in spatial if item.tag in ("site", "geom")]
        self.muscles = []
        for act in muscle.iter("muscle"):
            try:
                force = float(act.get("force"))
            except (TypeError, ValueError):
                raise UserError(f"MyoHand muscle {act.get('name')!r} has no numeric force") from None
            lr = _floats(act, "lengthrange", 2, (0.0, 0.0))
            self.muscles.append({"name": act.get("name"), "tendon": act.get("tendon"), "force": force,
                                 "lengthrange": (float(lr[0]), float(lr[1]))})
        if WRIST_BODY not in self.world:
            raise UserError(f"MyoHand MJCF has no body {WRIST_BODY}; run `make assets`")

    @staticmethod
    def _parse(path: Path) -> ET.Element:
        if not path.is_file():
            raise UserError(f"MyoHand model file {path.name} is missing; run `make assets`")
        try:
            return ET.parse(path).getroot()
        except ET.ParseError as exc:
            raise UserError(f"{path.name}: not valid XML ({exc}); run `make assets`") from None

    def _walk(self, body: ET.Element, parent: str | None, parent_world: np.ndarray, mesh_file) -> None:
        name = body.get("name")
        rotated = [a for a in ("euler", "axisangle", "xyaxes", "zaxis") if body.get(a) is not None]
        if body.get("quat") is not None and not np.allclose(_floats(body, "quat", 4), (1, 0, 0, 0)):
            rotated.append("quat")
        if rotated:
            raise UserError(f"MyoHand MJCF: body {name} is rotated ({rotated[0]}); this loader expects "
                            "translation-only bodies as in myo_sim 0.2.4")
        offset = _floats(body, "pos", 3, (0.0, 0.0, 0.0))
        world = parent_world + offset
        self.order.append(name)
        self.parent[name], self.offset[name], self.world[name] = parent, offset, world
        self.body_meshes[name] = []
        for child in body:
            if child.tag == "joint":
                rng = _floats(child, "range", 2, (0.0, 0.0))
                self.joints.append({"name": child.get("name"), "body": name,
                                    "type": child.get("type", "hinge"),
                                    "axis": _floats(child, "axis", 3, (0.0, 0.0, 1.0)),
                                    "range": (float(rng[0]), float(rng[1])),
                                    "pos": _floats(child, "pos", 3, (0.0, 0.0, 0.0))})
            elif child.tag == "geom" and child.get("mesh"):
                if child.get("pos") or child.get("quat") or child.get("euler"):
                    raise UserError(f"MyoHand MJCF: mesh geom {child.get('name')} is offset; unsupported")
                stem = mesh_file.get(child.get("mesh"), child.get("mesh"))
                self.body_meshes[name].append(stem)
                self.mesh_body[stem] = name
            elif child.tag == "geom" and child.get("name"):
                self.wraps[child.get("name")] = (name, _floats(child, "pos", 3, (0.0, 0.0, 0.0)))
            elif child.tag == "site" and child.get("name"):
                self.sites[child.get("name")] = (name, _floats(child, "pos", 3, (0.0, 0.0, 0.0)))
            elif child.tag == "body":
                self._walk(child, name, world, mesh_file)


# ---------------------------------------------------------------------------------------- WebXR

def webxr_hand(side: str) -> SkinnedHand:
    """The WebXR generic hand (``left`` or ``right``), skinned to 25 joints, project axes, metres.

    Source: ``assets/webxr/generic-hand/{side}.glb``; WebXR user-space axes converted with
    ``(-x, z, y)`` (module docstring); UVs flipped to Blender's convention (v up). At rest the hand
    hangs: fingers to -Z, thumb forward (-Y), palm towards the body. The joints are siblings under the
    armature in the file (no bone hierarchy), so ``parents`` is -1 for all of them.
    """
    if side not in ("left", "right"):
        raise UserError(f"webxr_hand: side must be 'left' or 'right', not {side!r}")
    path = _path("webxr", "generic-hand", f"{side}.glb")
    glb = read_glb(path)
    mesh_nodes = [i for i, n in enumerate(glb.nodes) if n.mesh is not None and n.skin is not None]
    if len(mesh_nodes) != 1 or len(glb.meshes[glb.nodes[mesh_nodes[0]].mesh]) != 1:
        raise UserError(f"{path.name}: expected one skinned mesh with one primitive")
    node = glb.nodes[mesh_nodes[0]]
    prim = glb.meshes[node.mesh][0]
    skin = glb.skins[node.skin]
    if prim.joints is None or prim.normals is None or prim.uvs is None:
        raise UserError(f"{path.name}: the hand mesh lacks normals, UVs or skin weights")
    conv = np.eye(4)
    conv[:3, :3] = WEBXR_TO_FH

    def to_fh(matrix: np.ndarray) -> np.ndarray:  # change of basis of a 4x4 transform
        return conv @ matrix @ conv.T

    # glTF skinning ignores the skinned mesh node's own transform: positions are in skeleton space.
    vertices = prim.positions @ WEBXR_TO_FH.T
    normals = _unit_rows(prim.normals @ WEBXR_TO_FH.T)
    uvs = np.column_stack([prim.uvs[:, 0], 1.0 - prim.uvs[:, 1]])
    joint_index = {j: k for k, j in enumerate(skin.joints)}
    parents = np.array([joint_index.get(glb.nodes[j].parent, -1) for j in skin.joints], dtype=np.int64)
    mesh = Mesh(f"webxr_hand_{side}", vertices, prim.indices.copy(), uvs, normals)
    return SkinnedHand(side, mesh, [glb.nodes[j].name for j in skin.joints], parents,
                       np.stack([to_fh(glb.nodes[j].matrix) for j in skin.joints]),
                       np.stack([to_fh(glb.world_matrix(j)) for j in skin.joints]),
                       np.stack([to_fh(m) for m in skin.inverse_bind]),
                       prim.joints.copy(), prim.weights.copy())
