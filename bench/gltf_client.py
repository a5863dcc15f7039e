# SPDX-License-Identifier: GPL-3.0-or-later
"""Engine-ready GLB in a real glTF client: size, morph targets, fit residual, validator, three.js playback.

For a ~30-s line (and a 2.5-s one) ``./fh speak`` writes the GLB both ways, engine-ready weights (the
default) and ``--animation frames`` (the exact per-frame cache). For each file:

* the Khronos glTF-Validator (npm ``gltf-validator``) reports errors / warnings / infos / hints; any error
  fails the run;
* three.js (``GLTFLoader``) loads it in Debian's headless chromium (driven by ``playwright-core``), an
  ``AnimationMixer`` plays the clip forward with ``mixer.update(dt)`` as a render loop does, and at every key
  time and every mid-point between keys the page reads the skin mesh's ``morphTargetInfluences`` and the world
  positions of the lip vertices at the mouth centre (``Mesh.getVertexPosition``: morph targets applied on the
  CPU by three.js, then ``matrixWorld``);
* the same quantities are computed here from the GLB bytes alone (numpy over the accessors, sparse ones
  included: base positions + sum of weight x target, the ``weights`` channel interpolated as its sampler
  says), so the browser is checked against the file, not against the exporter that wrote it;
* the lip aperture (lowest upper-lip vertex minus highest lower-lip vertex at the mouth centre, mm) over time
  is reported from both, with their agreement, and the clip duration against the WAV written beside the GLB.

The head of the 30-s weights GLB is rendered by three.js at its most open and most closed sample
(``out/bench/gltf_client/*_open.png``, ``*_closed.png``). The run fails (non-zero exit) when the validator
reports an error or the browser cannot play the clip as the file holds it.

Needs ``make bench-client`` (``npm ci`` in ``bench/client``; Debian's ``/usr/bin/chromium``) and
``make install`` (for ``./fh``). ``--glb FILE ...`` checks given files instead of speaking. Times are wall
time and CPU time (this process's children) of each whole ``./fh speak`` command, median of ``--runs``.
The last line is ``RESULT key=value ...``.
"""
from __future__ import annotations

import argparse
import json
import os
import re
import resource
import shutil
import struct
import subprocess
import sys
import tempfile
import time
import wave
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
CLIENT = ROOT / "bench" / "client"
OUT = ROOT / "out" / "bench" / "gltf_client"
CHROMIUM = os.environ.get("FH_CHROMIUM", "/usr/bin/chromium")

SENTENCES = (
    "Good morning, and welcome to the studio.",
    "Today we will walk through the new pipeline together, from the first line of dialogue to the finished "
    "shot.",
    "Every character speaks with lips, jaw and tongue moving in time with the voice, and the same curves "
    "drive any avatar that has the usual blend shapes.",
    "If something looks wrong, stop the playback, change the sentence, and try again.",
    "When you are happy with the take, export it and send it to the game team.",
    "Thank you for listening, and enjoy the rest of your day.",
    "See you all tomorrow.",
)
WORDS_PER_SECOND = 3.2  # espeak-ng en-us at 175 wpm with sentence pauses: 97 words -> 29.7 s here
SHORT_TEXT = "Can you show me the way to the conference hall?"  # 2.5 s
RESIDUAL = re.compile(r"fit residual median ([0-9.]+) mm, (?:p90 [0-9.]+ mm, )?max ([0-9.]+) mm")
SPEECH = re.compile(r"([0-9.]+) s of speech")
JAW_TARGETS = ("jawOpen", "FH.jaw_open", "viseme_aa")
POSITION_TOL_MM, INFLUENCE_TOL = 0.01, 1e-5
SEVERITY = {0: "error", 1: "warning", 2: "info", 3: "hint"}


class Failure(Exception):
    """A check that must hold; main() prints it and exits non-zero."""


def text_for(seconds: float) -> str:
    """Whole sentences of the paragraph (repeated if needed) up to ~``seconds`` of speech at the default rate."""
    words, out, k = 0, [], 0
    while words < seconds * WORDS_PER_SECOND:
        sentence = SENTENCES[k % len(SENTENCES)]
        out.append(sentence)
        words += len(sentence.split())
        k += 1
    return " ".join(out)


# ------------------------------------------------------------------------------------ GLB, numpy only
COMPONENTS = {5120: np.int8, 5121: np.uint8, 5122: np.int16, 5123: np.uint16, 5125: np.uint32, 5126: np.float32}
WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}


class Glb:
    """The JSON document and BIN chunk of a GLB, with accessor reading (strided and sparse) and node world
    matrices, written from the glTF 2.0 specification (sections 3.6 Buffers, 3.6.2.3 Sparse accessors,
    3.5 Node transforms) independently of the extension's own reader."""

    def __init__(self, path: Path):
        blob = path.read_bytes()
        magic, version, length = struct.unpack_from("<4sII", blob, 0)
        if magic != b"glTF" or version != 2 or length != len(blob):
            raise Failure(f"{path}: not a complete glTF 2.0 binary")
        json_length, json_type = struct.unpack_from("<I4s", blob, 12)
        if json_type != b"JSON":
            raise Failure(f"{path}: first GLB chunk is not JSON")
        self.gltf = json.loads(blob[20:20 + json_length])
        bin_at = 20 + json_length
        bin_length, bin_type = struct.unpack_from("<I4s", blob, bin_at)
        if bin_type != b"BIN\x00":
            raise Failure(f"{path}: second GLB chunk is not BIN")
        self.bin = blob[bin_at + 8:bin_at + 8 + bin_length]
        self.path, self.size = path, len(blob)

    def _view(self, view_index: int, offset: int, count: int, component: int, width: int) -> np.ndarray:
        view = self.gltf["bufferViews"][view_index]
        dtype = np.dtype(COMPONENTS[component]).newbyteorder("<")
        stride = view.get("byteStride") or dtype.itemsize * width
        return np.ndarray((count, width), dtype, buffer=self.bin, offset=view.get("byteOffset", 0) + offset,
                          strides=(stride, dtype.itemsize)).astype(np.float64 if component == 5126 else np.int64)

    def accessor(self, index: int) -> np.ndarray:
        acc = self.gltf["accessors"][index]
        width, count = WIDTH[acc["type"]], acc["count"]
        if "bufferView" in acc:
            data = self._view(acc["bufferView"], acc.get("byteOffset", 0), count, acc["componentType"], width)
        else:
            data = np.zeros((count, width))
        if acc.get("normalized"):
            raise Failure(f"{self.path}: normalized accessor {index} not handled by this bench")
        sparse = acc.get("sparse")
        if sparse:
            ind, val = sparse["indices"], sparse["values"]
            where = self._view(ind["bufferView"], ind.get("byteOffset", 0), sparse["count"], ind["componentType"], 1)
            data[where[:, 0]] = self._view(val["bufferView"], val.get("byteOffset", 0), sparse["count"],
                                           acc["componentType"], width)
        return data

    def world_matrices(self) -> dict[int, np.ndarray]:
        nodes, out = self.gltf["nodes"], {}

        def local(node: dict) -> np.ndarray:
            if "matrix" in node:
                return np.array(node["matrix"], float).reshape(4, 4).T
            x, y, z, w = node.get("rotation", (0, 0, 0, 1))
            r = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                          [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                          [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
            m = np.eye(4)
            m[:3, :3] = r * np.asarray(node.get("scale", (1, 1, 1)), float)
            m[:3, 3] = node.get("translation", (0, 0, 0))
            return m

        def visit(index: int, parent: np.ndarray) -> None:
            out[index] = parent @ local(nodes[index])
            for child in nodes[index].get("children", ()):
                visit(child, out[index])

        scene = self.gltf["scenes"][self.gltf.get("scene", 0)]
        for root in scene["nodes"]:
            visit(root, np.eye(4))
        return out

    def mesh_targets(self) -> dict[str, int]:
        """Morph targets per mesh (a mesh's primitives share one weights array)."""
        return {m.get("name", str(i)): len(m["primitives"][0].get("targets", ()))
                for i, m in enumerate(self.gltf["meshes"])}


def skin_mesh(glb: Glb) -> tuple[int, int]:
    """(mesh, node) of the face skin: the morphed single-primitive mesh with the most vertices."""
    best = None
    for node_index, node in enumerate(glb.gltf["nodes"]):
        if "mesh" not in node:
            continue
        prims = glb.gltf["meshes"][node["mesh"]]["primitives"]
        if len(prims) != 1 or not prims[0].get("targets"):
            continue
        count = glb.gltf["accessors"][prims[0]["attributes"]["POSITION"]]["count"]
        if best is None or count > best[0]:
            best = (count, node["mesh"], node_index)
    if best is None:
        raise Failure(f"{glb.path}: no mesh with morph targets")
    return best[1], best[2]


def weights_channel(glb: Glb, clip_name: str | None, node: int) -> tuple[np.ndarray, np.ndarray, str]:
    """(key times, weights per key (keys x targets), interpolation) of the clip's weights channel on ``node``."""
    anims = glb.gltf.get("animations", [])
    clip = next((a for a in anims if clip_name is None or a.get("name") == clip_name), None)
    if clip is None:
        raise Failure(f"{glb.path}: no animation {clip_name or ''}")
    for channel in clip["channels"]:
        if channel["target"].get("node") == node and channel["target"]["path"] == "weights":
            sampler = clip["samplers"][channel["sampler"]]
            times = glb.accessor(sampler["input"])[:, 0]
            values = glb.accessor(sampler["output"])[:, 0]
            interpolation = sampler.get("interpolation", "LINEAR")
            per_key = 3 if interpolation == "CUBICSPLINE" else 1
            return times, values.reshape(len(times), per_key, -1)[:, per_key // 2], interpolation
    raise Failure(f"{glb.path}: clip {clip.get('name')} has no weights channel on the skin node")


def weights_at(times: np.ndarray, values: np.ndarray, interpolation: str, t: np.ndarray) -> np.ndarray:
    """Sampler evaluation at ``t`` (glTF 2.0 appendix C): LINEAR and STEP, clamped outside the key range."""
    if interpolation == "STEP":
        k = np.clip(np.searchsorted(times, t, side="right") - 1, 0, len(times) - 1)
        return values[k]
    if interpolation != "LINEAR":
        raise Failure(f"{interpolation} weights are not handled by this bench")
    return np.stack([np.interp(t, times, values[:, j]) for j in range(values.shape[1])], axis=1)


class Skin:
    """Base positions and morph targets (POSITION) of the skin mesh, in world space."""

    def __init__(self, glb: Glb):
        self.mesh, self.node = skin_mesh(glb)
        mesh = glb.gltf["meshes"][self.mesh]
        prim = mesh["primitives"][0]
        world = glb.world_matrices()[self.node]
        self.linear, self.offset = world[:3, :3], world[:3, 3]
        self.base = glb.accessor(prim["attributes"]["POSITION"])
        self.targets = np.stack([glb.accessor(t["POSITION"]) if "POSITION" in t else np.zeros_like(self.base)
                                 for t in prim["targets"]])
        self.names = mesh.get("extras", {}).get("targetNames", [])

    def rest(self, vertices: np.ndarray) -> np.ndarray:
        """World positions with every weight 0."""
        return self.base[vertices] @ self.linear.T + self.offset

    def world(self, weights: np.ndarray, vertices: np.ndarray) -> np.ndarray:
        """(times x vertices x 3) world positions for weights (times x targets)."""
        local = self.base[vertices][None] + np.einsum("tk,kvc->tvc", weights, self.targets[:, vertices])
        return local @ self.linear.T + self.offset


def lip_vertices(skin: Skin, motion: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Upper- and lower-lip vertices at the mouth centre: skin vertices on the mid-sagittal plane (|x| < 0.1%
    of the head width) split by how far the jaw-open target (or, without one, the clip: ``motion``, the
    lowest world y each vertex reaches minus its rest y) moves them down; the lower lip is the moving vertices
    within 10 mm of the highest one, the upper lip the still ones within 10 mm above it (and within 10 mm in
    depth). The aperture is min y(upper) - max y(lower)."""
    rest = skin.rest(np.arange(len(skin.base)))
    low, high = rest[:, 0].min(), rest[:, 0].max()
    mid = np.flatnonzero(np.abs(rest[:, 0] - (low + high) / 2) < 1e-3 * (high - low))
    jaw = next((skin.names.index(n) for n in JAW_TARGETS if n in skin.names), None)
    if jaw is not None:
        down = (skin.targets[jaw][mid] @ skin.linear.T)[:, 1]
    elif motion is not None:
        down = motion[mid]
    else:
        raise Failure("no jaw target and no clip motion to find the lips")
    moving = down < 0.5 * down.min()
    lower_mid = mid[moving]
    top = lower_mid[np.argmax(rest[lower_mid, 1])]
    y0, z0 = rest[top, 1], rest[top, 2]
    lower = lower_mid[(rest[lower_mid, 1] > y0 - 0.010) & (np.abs(rest[lower_mid, 2] - z0) < 0.010)]
    still = mid[~moving]
    upper = still[(rest[still, 1] > y0) & (rest[still, 1] < y0 + 0.010) & (np.abs(rest[still, 2] - z0) < 0.010)]
    if len(upper) == 0 or len(lower) == 0:
        raise Failure("could not find upper and lower lip vertices at the mouth centre")
    return upper, lower


def aperture_mm(positions: np.ndarray, n_upper: int) -> np.ndarray:
    return (positions[:, :n_upper, 1].min(axis=1) - positions[:, n_upper:, 1].max(axis=1)) * 1000.0


# ------------------------------------------------------------------------------------------ Node side
def node_json(script: str, *args: str) -> subprocess.CompletedProcess:
    if not (CLIENT / "node_modules" / "three").is_dir():
        raise Failure("bench/client has no node_modules: run `make bench-client` first")
    if not Path(CHROMIUM).exists():
        raise Failure(f"no chromium at {CHROMIUM}: apt-get install chromium (or set FH_CHROMIUM)")
    return subprocess.run(["node", str(CLIENT / script), *args], capture_output=True, text=True, cwd=CLIENT)


def validate(paths: list[Path]) -> list[dict]:
    done = node_json("validate.mjs", *map(str, paths))
    if done.returncode != 0:
        raise Failure(f"glTF-Validator did not run: {done.stderr.strip()}")
    return json.loads(done.stdout)


def play(path: Path, skin: Skin, clip: str, times: np.ndarray, vertices: np.ndarray, shots: list[dict],
         influences: bool = True, views_shots: list[dict] = (), size: tuple[int, int] = (1500, 600),
         all_meshes: bool = False) -> dict:
    """Play the GLB in three.js; ``shots`` are fhRender screenshots, ``views_shots`` fhRenderViews ones
    ({time, png, views: [{yaw, pitch, target, distance, fov}]}) at ``size`` pixels; ``all_meshes``: the
    samples are every vertex of every mesh (``samples["meshes"]``, fhSampleMeshes) instead of ``vertices``."""
    with tempfile.TemporaryDirectory(prefix="fh-gltf-client-") as tmp:
        job, result = Path(tmp) / "job.json", Path(tmp) / "result.json"
        job.write_text(json.dumps({"glb": str(path), "mesh": skin.mesh, "clip": clip, "times": times.tolist(),
                                   "influences": influences, "views_shots": list(views_shots),
                                   "all_meshes": all_meshes,
                                   "vertices": vertices.tolist(), "shots": shots, "chromium": CHROMIUM,
                                   "focus": skin.rest(vertices).mean(axis=0).tolist(),
                                   "width": size[0], "height": size[1]}))
        started = time.perf_counter()
        done = node_json("play.mjs", str(job), str(result))
        wall = time.perf_counter() - started
        if done.returncode != 0:
            raise Failure(f"three.js in chromium could not play {path.name}: {done.stderr.strip()[-2000:]}")
        out = json.loads(result.read_text())
    out["wall_s"] = wall
    return out


# -------------------------------------------------------------------------------------- the checks
def sample_times(keys: np.ndarray) -> np.ndarray:
    """Every key time and every mid-point between keys (tests the interpolation, not just the keys)."""
    return np.unique(np.concatenate([keys, (keys[1:] + keys[:-1]) / 2]))


def wav_seconds(path: Path) -> float | None:
    if not path.exists():
        return None
    with wave.open(str(path)) as w:
        return w.getnframes() / w.getframerate()


def check_file(path: Path, report: dict, lips: tuple | None = None, shots_at: list | None = None) -> dict:
    """Play ``path`` in the browser and compare with the file; returns figures, raises Failure on a defect.
    ``shots_at``: [] renders the most open and most closed sample, [(label, time), ...] those times."""
    glb = Glb(path)
    skin = Skin(glb)
    clip = path.stem if any(a.get("name") == path.stem for a in glb.gltf.get("animations", [])) else None
    keys, values, interpolation = weights_channel(glb, clip, skin.node)
    times = sample_times(keys)
    expected_w = weights_at(keys, values, interpolation, times)
    if lips is None:
        every = np.arange(len(skin.base))
        motion = (skin.world(weights_at(keys, values, interpolation, keys), every)[:, :, 1].min(axis=0)
                  - skin.rest(every)[:, 1])
        lips = lip_vertices(skin, motion)
    upper, lower = lips
    vertices = np.concatenate([upper, lower])
    expected_p = skin.world(expected_w, vertices)
    expected_a = aperture_mm(expected_p, len(upper))
    if shots_at is not None and not shots_at:
        shots_at = [("open", float(times[np.argmax(expected_a)])), ("closed", float(times[np.argmin(expected_a)]))]
    shots = [{"label": label, "time": t, "png": str(OUT / f"{path.stem}_{label}.png")}
             for label, t in shots_at or ()]
    got = play(path, skin, glb.gltf["animations"][0]["name"] if clip is None else clip, times, vertices, shots)
    info, samples = got["info"], got["samples"]
    got_w, got_p = np.asarray(samples["influences"]), np.asarray(samples["positions"])
    got_a = aperture_mm(got_p, len(upper))
    channels = sum(len(a["channels"]) for a in glb.gltf["animations"] if a.get("name") == info["clip"])
    figures = {
        "file": str(path), "bytes": glb.size, "skin_targets": len(skin.targets),
        "mesh_targets": glb.mesh_targets(), "clip": info["clip"], "clip_s": info["duration"],
        "file_clip_s": float(keys[-1]), "wav_s": wav_seconds(path.with_suffix(".wav")),
        "fps": (len(keys) - 1) / float(keys[-1] - keys[0]), "samples": len(times),
        "tracks": len(info["tracks"]), "bound_tracks": info["boundTracks"], "channels": channels,
        "influence_diff": float(np.abs(got_w - expected_w).max()),
        "position_diff_mm": float(np.linalg.norm(got_p - expected_p, axis=2).max() * 1000),
        "aperture_diff_mm": float(np.abs(got_a - expected_a).max()),
        "aperture_mm": (float(got_a.min()), float(np.median(got_a)), float(got_a.max())),
        "lips": (upper.tolist(), lower.tolist()), "shots": got["shots"], "three": info["revision"],
        "chromium": got["browser"], "client_wall_s": got["wall_s"],
        "page_errors": [m for m in got["logs"] if m.startswith(("error:", "pageerror:"))],
    }
    write_curve(path, times, got_a, expected_a)
    report[path] = figures
    return figures


def write_curve(path: Path, times: np.ndarray, browser: np.ndarray, python: np.ndarray) -> None:
    rows = ["time_s,aperture_browser_mm,aperture_file_mm"]
    rows += [f"{t:.6f},{a:.5f},{b:.5f}" for t, a, b in zip(times, browser, python)]
    (OUT / f"{path.stem}_aperture.csv").write_text("\n".join(rows) + "\n")


def client_problems(f: dict) -> list[str]:
    """Everything that means the client does not play what the file holds."""
    out = []
    if f["page_errors"]:
        out.append(f"page errors: {f['page_errors'][:3]}")
    if f["bound_tracks"] != f["tracks"] or f["tracks"] < f["channels"]:
        out.append(f"{f['bound_tracks']} of {f['tracks']} tracks bound, file has {f['channels']} channels")
    if abs(f["clip_s"] - f["file_clip_s"]) > 1e-6:
        out.append(f"clip lasts {f['clip_s']} s in three.js, {f['file_clip_s']} s in the file")
    if f["influence_diff"] > INFLUENCE_TOL:
        out.append(f"influences differ from the file by {f['influence_diff']:.2e}")
    if f["position_diff_mm"] > POSITION_TOL_MM:
        out.append(f"vertex positions differ from the file by {f['position_diff_mm']:.4f} mm")
    if f["aperture_mm"][2] - f["aperture_mm"][0] < 1.0:
        out.append(f"the mouth does not move (aperture {f['aperture_mm'][0]:.2f}..{f['aperture_mm'][2]:.2f} mm)")
    if f["wav_s"] is not None and abs(f["clip_s"] - f["wav_s"]) > 1.0 / f["fps"] + 1e-3:
        out.append(f"clip {f['clip_s']:.3f} s vs WAV {f['wav_s']:.3f} s: more than one frame apart")
    return out


def print_file(f: dict, validation: dict) -> None:
    name = Path(f["file"]).name
    wav = "no WAV" if f["wav_s"] is None else (f"WAV {f['wav_s']:.3f} s (clip - WAV "
                                               f"{1000 * (f['clip_s'] - f['wav_s']):+.1f} ms)")
    print(f"{name}: {f['bytes'] / 1e6:.2f} MB, skin morph targets {f['skin_targets']}, per mesh {f['mesh_targets']}")
    print(f"  validator {validation['validatorVersion']}: {validation['numErrors']} errors, "
          f"{validation['numWarnings']} warnings, {validation['numInfos']} infos, {validation['numHints']} hints")
    for m in validation["messages"][:5]:
        severity = SEVERITY.get(m.get("severity"), m.get("severity"))
        print(f"    {severity} {m.get('code')}: {m.get('message')} ({m.get('pointer', '')})")
    print(f"  three.js r{f['three']} in chromium {f['chromium']}: clip '{f['clip']}' {f['clip_s']:.3f} s, "
          f"{f['bound_tracks']}/{f['tracks']} tracks bound; {wav}")
    print(f"  {f['samples']} samples (keys + mid-points, {f['fps']:.1f} fps): browser vs file max |influence| "
          f"diff {f['influence_diff']:.1e}, vertex {f['position_diff_mm']:.1e} mm, aperture "
          f"{f['aperture_diff_mm']:.1e} mm")
    lo, med, hi = f["aperture_mm"]
    print(f"  lip aperture at the mouth centre ({len(f['lips'][0])} upper / {len(f['lips'][1])} lower lip "
          f"vertices): min {lo:.2f}, median {med:.2f}, max {hi:.2f} mm; curve in "
          f"{OUT / (Path(f['file']).stem + '_aperture.csv')}")


def print_curve(path: Path, step: float = 0.5) -> None:
    """The browser's aperture curve at ``step`` seconds (nearest sample), as numbers."""
    rows = np.loadtxt(OUT / f"{path.stem}_aperture.csv", delimiter=",", skiprows=1)
    grid = np.arange(0.0, rows[-1, 0] + 1e-9, step)
    picks = rows[np.abs(rows[:, 0][None] - grid[:, None]).argmin(axis=1)]
    print(f"  aperture curve (mm, every {step} s from 0):")
    for k in range(0, len(picks), 10):
        print("   " + " ".join(f"{a:5.1f}" for a in picks[k:k + 10, 1]))


# ------------------------------------------------------------------------------------------ ./fh speak
def speak(text: str, out: Path, animation: str, runs: int) -> dict:
    """Run ``./fh speak`` ``runs`` times (fresh outputs each time); wall and CPU time of the whole command."""
    walls, cpus, log = [], [], ""
    for _ in range(runs):
        for old in (out, out.with_suffix(".wav")):
            old.unlink(missing_ok=True)  # our own outputs from an earlier run
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        started = time.perf_counter()
        done = subprocess.run([str(ROOT / "fh"), "speak", "--text", text, "--animation", animation,
                               "--out", str(out)], capture_output=True, text=True, cwd=ROOT)
        walls.append(time.perf_counter() - started)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpus.append(after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime)
        log = done.stdout + done.stderr
        (OUT / f"{out.stem}.log").write_text(log)
        if done.returncode != 0 or not out.exists():
            raise Failure(f"./fh speak --animation {animation} failed ({done.returncode}): {log.strip()[-1500:]}")
    residual = RESIDUAL.search(log)
    speech = SPEECH.search(log)
    return {"wall_s": float(np.median(walls)), "cpu_s": float(np.median(cpus)), "walls": walls, "cpus": cpus,
            "residual": tuple(map(float, residual.groups())) if residual else None,
            "speech_s": float(speech.group(1)) if speech else None,
            "bake_line": next((ln for ln in log.splitlines() if ln.startswith("Baked")), "")}


def make_lines(seconds: float, runs: int, reuse: bool) -> dict:
    """Both ways for the long line and the 2.5-s line: {(label, animation): (path, run figures)}; ``reuse``
    takes the GLBs and figures of the last run (``runs.json``) instead of speaking again."""
    saved = OUT / "runs.json"
    if reuse:
        if not saved.exists():
            raise Failure(f"--reuse: no earlier run in {OUT}")
        return {tuple(k.split("/")): (OUT / f"line_{k.replace('/', '_')}.glb", run)
                for k, run in json.loads(saved.read_text()).items()}
    made = {}
    for label, text in (("long", text_for(seconds)), ("short", SHORT_TEXT)):
        for animation in ("weights", "frames"):
            out = OUT / f"line_{label}_{animation}.glb"
            print(f"== ./fh speak --animation {animation} --out {out.relative_to(ROOT)} --text "
                  f"\"{text[:60]}{'...' if len(text) > 60 else ''}\" ({len(text.split())} words, {runs} run(s))",
                  flush=True)
            run = speak(text, out, animation, runs)
            print(f"   {run['bake_line']}")
            print(f"   wall {run['wall_s']:.1f} s, CPU {run['cpu_s']:.1f} s (median of {runs}; runs "
                  f"{', '.join(f'{w:.1f}' for w in run['walls'])} s wall)", flush=True)
            made[label, animation] = (out, run)
    saved.write_text(json.dumps({"/".join(k): run for k, (_, run) in made.items()}, indent=1))
    return made


def twin_figures(weights: Path, cache: Path) -> dict:
    """The weights GLB against the exact cache GLB of the same take, from the two files alone: the per-frame
    fit residual (largest skin-vertex distance at each key, as ``./fh`` defines it) and the browser-sampled
    lip aperture difference (weights - cache)."""
    poses, keys = [], []
    for path in (weights, cache):
        glb = Glb(path)
        skin = Skin(glb)
        times, values, _ = weights_channel(glb, path.stem, skin.node)
        keys.append(times)
        poses.append(skin.world(values, np.arange(len(skin.base))))
    if len(keys[0]) != len(keys[1]) or not np.allclose(keys[0], keys[1]):
        raise Failure(f"{weights.name} and {cache.name} have different key times")
    residual = np.linalg.norm(poses[0] - poses[1], axis=2).max(axis=1) * 1000
    a, b = (np.loadtxt(OUT / f"{path.stem}_aperture.csv", delimiter=",", skiprows=1)[:, 1]
            for path in (weights, cache))
    print(f"{weights.name} vs {cache.name} (from the files): fit residual median {np.median(residual):.2f} mm, "
          f"max {residual.max():.2f} mm (frame {residual.argmax()}); lip aperture weights - cache: median "
          f"|diff| {np.median(np.abs(a - b)):.2f} mm, max {np.abs(a - b).max():.2f} mm, mean {np.mean(a - b):+.2f} mm")
    return {"median": float(np.median(residual)), "max": float(residual.max()),
            "aperture_median": float(np.median(np.abs(a - b))), "aperture_max": float(np.abs(a - b).max())}


# ------------------------------------------------------------------------------------------------ main
def check_all(paths: list[Path], screenshot: set[Path], reference: dict[Path, Path]) -> tuple[dict, dict]:
    """Validator on all, then the client on each; a cache file reuses its weights twin's lip vertices when
    both hold the same base mesh, and is rendered at the twin's shot times when the twin was rendered."""
    validations = {Path(v["file"]): v for v in validate(paths)}
    report: dict = {}
    lips_of: dict[Path, tuple] = {}
    for path in paths:
        twin = reference.get(path)
        lips = lips_of.get(twin) if twin is not None else None
        if lips is not None and not np.array_equal(Skin(Glb(path)).base, Skin(Glb(twin)).base):
            lips = None
        shots = [] if path in screenshot else None
        if twin in screenshot and twin in report:
            shots = [(shot["label"], shot["time"]) for shot in report[twin]["shots"]]
        f = check_file(path, report, lips, shots)
        lips_of[path] = (np.asarray(f["lips"][0]), np.asarray(f["lips"][1]))
        print_file(f, validations[path])
        if path in screenshot:
            print_curve(path)
        if shots is not None:
            for shot in f["shots"]:
                print(f"  rendered {shot['label']} mouth at {shot['time']:.3f} s -> {shot['png']} "
                      f"({shot['renderer']})")
        problems = client_problems(f)
        f["client_ok"] = not problems
        for problem in problems:
            print(f"  CLIENT PROBLEM: {problem}")
    return validations, report


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--glb", nargs="+", type=Path, help="check these GLBs instead of speaking new ones")
    parser.add_argument("--seconds", type=float, default=30.0, help="length of the long line (default 30)")
    parser.add_argument("--runs", type=int, default=1, help="./fh runs per line for the time medians")
    parser.add_argument("--reuse", action="store_true", help="check the GLBs of the last run without speaking")
    args = parser.parse_args()
    OUT.mkdir(parents=True, exist_ok=True)
    try:
        if args.glb:
            paths = [p.resolve() for p in args.glb]
            missing = [str(p) for p in paths if not p.is_file()]
            if missing:
                raise Failure(f"no such GLB: {', '.join(missing)}")
            validations, report = check_all(paths, set(paths[:1]), {})
            return finish(validations, report, None)
        made = make_lines(args.seconds, args.runs, args.reuse)
        paths = [made[k][0] for k in made]  # weights first: its cache twin reuses its lips and shot times
        reference = {made[label, "frames"][0]: made[label, "weights"][0] for label in ("long", "short")}
        validations, report = check_all(paths, {made["long", "weights"][0]}, reference)
        return finish(validations, report, made)
    except Failure as exc:
        print(f"FAILED: {exc}", file=sys.stderr)
        return 1


def finish(validations: dict, report: dict, made: dict | None) -> int:
    errors = sum(v["numErrors"] for v in validations.values())
    client_ok = all(f["client_ok"] for f in report.values())
    agree = max(f["aperture_diff_mm"] for f in report.values())
    fields = {"files": len(report), "validator_errors": errors,
              "validator_warnings": sum(v["numWarnings"] for v in validations.values()),
              "client_ok": int(client_ok), "aperture_agreement_mm": f"{agree:.1e}"}
    if made:
        long_w, long_c = report[made["long", "weights"][0]], report[made["long", "frames"][0]]
        short_w, short_c = report[made["short", "weights"][0]], report[made["short", "frames"][0]]
        residual = made["long", "weights"][1]["residual"] or (float("nan"), float("nan"))
        twin = twin_figures(made["long", "weights"][0], made["long", "frames"][0])
        fields = {"seconds": f"{long_w['wav_s']:.2f}", "weights_mb": f"{long_w['bytes'] / 1e6:.2f}",
                  "cache_mb": f"{long_c['bytes'] / 1e6:.2f}", "weights_targets": long_w["skin_targets"],
                  "cache_targets": long_c["skin_targets"], "short_weights_targets": short_w["skin_targets"],
                  "short_cache_targets": short_c["skin_targets"],
                  "targets_fixed": int(short_w["mesh_targets"] == long_w["mesh_targets"]),
                  "short_weights_mb": f"{short_w['bytes'] / 1e6:.2f}",
                  "short_cache_mb": f"{short_c['bytes'] / 1e6:.2f}",
                  "residual_median_mm": residual[0], "residual_max_mm": residual[1],
                  "file_residual_median_mm": f"{twin['median']:.2f}", "file_residual_max_mm": f"{twin['max']:.2f}",
                  "aperture_vs_cache_median_mm": f"{twin['aperture_median']:.2f}",
                  "aperture_vs_cache_max_mm": f"{twin['aperture_max']:.2f}",
                  "clip_minus_wav_ms": f"{1000 * (long_w['clip_s'] - long_w['wav_s']):.1f}",
                  "aperture_max_mm": f"{long_w['aperture_mm'][2]:.2f}",
                  "weights_wall_s": f"{made['long', 'weights'][1]['wall_s']:.1f}",
                  "cache_wall_s": f"{made['long', 'frames'][1]['wall_s']:.1f}",
                  "weights_cpu_s": f"{made['long', 'weights'][1]['cpu_s']:.1f}",
                  "cache_cpu_s": f"{made['long', 'frames'][1]['cpu_s']:.1f}", **fields}
    (OUT / "report.json").write_text(json.dumps({str(k): v for k, v in report.items()}, indent=1, default=str))
    print("RESULT " + " ".join(f"{k}={v}" for k, v in fields.items()))
    fixed = fields.get("targets_fixed", 1)
    if not fixed:
        print("FAILED: the weights GLB's morph targets change with the length of the line", file=sys.stderr)
    if errors:
        print(f"FAILED: the glTF-Validator reports {errors} error(s)", file=sys.stderr)
    if not client_ok:
        print("FAILED: the glTF client does not play what the file holds (see CLIENT PROBLEM above)",
              file=sys.stderr)
    return 0 if errors == 0 and client_ok and fixed else 1


if __name__ == "__main__":
    sys.exit(main())
