# SPDX-License-Identifier: GPL-3.0-or-later
"""``FaceRig``: the animatable MEDUSA head (thesis 3.1.2) the operators drive.

Per frame (3.1.2 "Muscle Deformation" then "Mass Spring Network"): the controls give the jaw pose, gaze and
lid rotation; the muscles deform (contraction, jaw, connections, stretch, bulge); every skin node's
attachment point is carried by its bone (jaw weight), its lid and the muscles whose zone it lies in; then
the spring network runs the guard's substeps, with the skull guard after each one. Outputs are plain arrays
for ``foreach_set``: skin positions (N, 3) float32, 4x4 matrices for jaw, eyes, teeth and tongue, muscle
fibre polylines with their contraction, and wrinkle strengths.

Coordinates: the rig simulates in *head space* (metres, Z up, face along -Y, human scale). Every output
(positions, rest positions, part and bone meshes, rigid transforms, muscle fibres) is in the coordinates of
the skin mesh: for the default head that is head space (``head_to_mesh`` is the identity); a rig fitted to
an artist's mesh (:mod:`.fitted`) returns them in that mesh's own coordinates, ``head_to_mesh`` being the
4x4 similarity from head space to the mesh.

Deterministic: the same template, material, control values and frame times give byte-identical positions.
"""
from __future__ import annotations

import json
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np

from ..errors import UserError
from . import kinematics
from .controls import ControlSpec, clamp_controls, control_specs
from .network import FaceNetwork, SkinMaterial, build_network
from .template import HeadTemplate, TemplateInputs, build_template, default_inputs

__all__ = ["FaceRig", "build_default_rig", "WRINKLE_DRIVERS"]

FORMAT = "faces_hands.face_rig/1"
GUARD_EVERY = 4          # the skull/eye guard runs after every 4th substep and after the last one

#: 3.1.2 "Expressive Wrinkles": region -> (muscle, weight); strength = clamp(sum of weight * contraction)
WRINKLE_DRIVERS = {
    "forehead": (("frontalis_inner_L", 0.35), ("frontalis_inner_R", 0.35), ("frontalis_outer_L", 0.15),
                 ("frontalis_outer_R", 0.15)),
    "brow_furrow": (("corrugator_supercilii_L", 0.4), ("corrugator_supercilii_R", 0.4), ("procerus", 0.2)),
    "nose_bridge": (("procerus", 0.5), ("levator_labii_alaeque_nasi_L", 0.25),
                    ("levator_labii_alaeque_nasi_R", 0.25)),
}


class FaceRig:
    """A head template + its spring network + the current control values and simulation state."""

    def __init__(self, template: HeadTemplate, material: SkinMaterial | None = None) -> None:
        self.template = template
        self.face: FaceNetwork = build_network(template, material)
        self.material = self.face.material
        self.specs: dict[str, ControlSpec] = control_specs(template.muscles.names)
        self.controls: dict[str, float] = {name: spec.default for name, spec in self.specs.items()}
        self._rest = template.skin.vertices.copy()
        self._muscle_index = {name: i for i, name in enumerate(template.muscles.names)}
        self._muscle_matrix = (template.attachment_matrix if template.attachment_matrix is not None
                               else _attachment_matrix(template))
        #: 4x4 similarity from the rig's head space to the skin mesh's coordinates (see the module docstring)
        self.head_to_mesh = np.eye(4)
        self.warnings: list[str] = []      # problems that leave the rig usable (fitted heads: no mouth opening)
        self._driven = template.kinematic is not None and bool(np.any(template.kinematic))
        self._cache_key = None
        self._targets = None
        self.time = 0.0
        self.frame_substeps = 0

    # -- controls --------------------------------------------------------------------------------
    def control_specs(self) -> dict[str, ControlSpec]:
        """Name -> :class:`ControlSpec` (range, default, UI region) of every control."""
        return dict(self.specs)

    def set_controls(self, values: dict[str, float], strict: bool = True) -> None:
        """Set some controls (clamped to their ranges); unknown names raise unless ``strict=False``."""
        self.controls.update(clamp_controls(dict(values), self.specs, strict))

    def reset_controls(self) -> None:
        self.controls = {name: spec.default for name, spec in self.specs.items()}

    def reset_state(self) -> None:
        """Put the skin back at rest, at rest (positions, velocities, attachments, guards); controls stay."""
        face, rest = self.face, self._rest
        face.network.positions[...] = rest.T
        face.integrator.velocity[...] = 0.0
        face.integrator.started = False
        face.integrator.mass_scale = 1.0
        face.network.set_attachment_targets((rest + face.anchor_offset).T, (rest - face.anchor_offset).T)
        face.bone_guard.reset()
        face.teeth_guard.reset()
        self._cache_key = None
        self.time = 0.0

    # -- geometry handed to Blender ---------------------------------------------------------------
    @property
    def faces(self) -> np.ndarray:
        """Skin triangles (M, 3) int32."""
        return self.template.skin.faces.astype(np.int32)

    @property
    def rest_positions(self) -> np.ndarray:
        """Skin rest positions (N, 3) float32, mesh coordinates (head space for the default head)."""
        return self._rest.astype(np.float32)

    @property
    def positions(self) -> np.ndarray:
        """Current skin node positions (N, 3) float32 (C-contiguous, ready for ``foreach_set``), mesh
        coordinates (head space for the default head; see the module docstring)."""
        return np.ascontiguousarray(self.face.network.positions.T, dtype=np.float32)

    def part_meshes(self) -> dict:
        """Rest meshes of eyes, teeth and tongue (``organs.PartMesh``: vertices, faces, face_material)."""
        return dict(self.template.parts)

    def bone_meshes(self) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        """Fitted skull and jaw (vertices, faces) in rest pose."""
        b = self.template.bones
        return {"skull": (b.skull_vertices, b.skull_faces), "jaw": (b.jaw_vertices, b.jaw_faces)}

    # -- per frame -------------------------------------------------------------------------------
    def _jaw(self) -> np.ndarray:
        c, b = self.controls, self.template.bones
        return kinematics.jaw_matrix(b.tmj_pivot, b.tmj_axis, c["jaw_open"], c["jaw_yaw"], c["jaw_forward"],
                                     c["jaw_drop"], glide=self.template.jaw_glide)

    def rigid_transforms(self) -> dict[str, np.ndarray]:
        """4x4 matrices (head coordinates, applied to the rest meshes) for the current controls."""
        c, t = self.controls, self.template
        jaw = self._jaw()
        out = {"jaw": jaw, "teeth_upper": np.eye(4), "teeth_lower": jaw, "skull": np.eye(4)}
        for side, centre in t.eye_centres.items():
            out[f"eye_{side}"] = kinematics.eye_matrix(centre, c["eye_yaw"], c["eye_pitch"])
        out["tongue"] = kinematics.tongue_matrix(jaw, t.tongue_pivot, c["tongue_tip_up"], c["tongue_back"],
                                                 c["tongue_out"])
        return out

    def _contraction_vector(self) -> np.ndarray:
        return np.array([self.controls[name] for name in self.template.muscles.names])

    def attachment_targets(self) -> np.ndarray:
        """Where every skin node's attachment pair wants it (N, 3): bone-carried rest position + lid
        rotation + displacement of the muscles it is attached to. Cached per control state."""
        key = tuple(sorted(self.controls.items()))
        if key == self._cache_key:
            return self._targets
        t, rest = self.template, self._rest
        jaw = self._jaw()
        carried = rest @ jaw[:3, :3].T + jaw[:3, 3]
        target = rest + t.jaw_weight[:, None] * (carried - rest)
        for side, lid in t.lids.items():
            rotated = lid.rotate(rest, self.controls[f"eyelid_close_{side}"], self.controls["eye_pitch"])
            target[lid.index] += rotated[lid.index] - rest[lid.index]
        state = t.muscles.deform(self._contraction_vector(), self.controls["orbicularis_oris_protrusion"], jaw)
        self._muscle_state = state
        muscle = self._muscle_matrix @ state.displacement          # sum of weight * closest muscle point
        for _ in range(t.smoothing_passes):          # the skin layer spreads the muscles' pull smoothly
            muscle = t.smoothing @ muscle
        target += muscle
        self._cache_key, self._targets = key, target
        self._jaw_now = jaw
        return target

    def step_frame(self, dt: float = 1 / 24) -> np.ndarray:
        """Advance the simulation by one frame of ``dt`` seconds; returns positions (N, 3) float32."""
        target = self.attachment_targets()
        face = self.face
        jaw = self._jaw_now
        offset = face.anchor_offset.copy()
        on_jaw = self.template.jaw_weight > 0.5
        offset[on_jaw] = offset[on_jaw] @ jaw[:3, :3].T
        for guard in (face.bone_guard, face.teeth_guard):
            guard.begin_frame()                        # planes slide with the jaw during the frame
            guard.set_bone_transforms([np.eye(4), jaw])
            guard.refresh(face.network.positions)
        self.frame_substeps = face.integrator.advance(dt, anchor=(target + offset).T, mirror=(target - offset).T,
                                                      driven=target.T if self._driven else None,
                                                      constraint=face.constrain, constraint_every=GUARD_EVERY)
        self.time += dt
        return self.positions

    def settle(self, max_time: float = 1.5, dt: float = 1 / 24, tolerance: float = 2e-4) -> np.ndarray:
        """Step until the skin is at rest (max node speed below ``tolerance`` m/s, at least 3 frames) or
        ``max_time`` seconds have been simulated; returns the positions."""
        frames = max(3, int(np.ceil(max_time / dt)))
        for frame in range(frames):
            self.step_frame(dt)
            if frame >= 2 and float(np.abs(self.face.integrator.velocity).max()) < tolerance:
                break
        return self.positions

    def substeps_per_frame(self, dt: float = 1 / 24) -> int:
        """Substeps the stability guard uses for a frame of ``dt`` seconds (after the cap)."""
        integ = self.face.integrator
        return min(integ.substeps_for(dt), integ.max_substeps)

    # -- visualisation ---------------------------------------------------------------------------
    def muscle_fibres(self) -> list[tuple[str, np.ndarray, float]]:
        """(muscle name, fibre polyline (R, 3) float32, contraction) for the current controls."""
        self.attachment_targets()
        points = self._muscle_state.points
        return [(name, line.astype(np.float32), self.controls[name])
                for name, line in self.template.muscles.fibres(points)]

    def wrinkles(self) -> dict[str, float]:
        """Expressive-wrinkle strengths per region in [0, 1] (3.1.2 "Expressive Wrinkles")."""
        return {region: float(np.clip(sum(w * self.controls.get(m, 0.0) for m, w in drivers), 0.0, 1.0))
                for region, drivers in WRINKLE_DRIVERS.items()}

    def wrinkle_masks(self) -> dict[str, np.ndarray]:
        """Per-node weights (N,) float32 of each wrinkle region, e.g. for a colour attribute."""
        return {k: v.astype(np.float32) for k, v in self.template.wrinkle_regions.items()}

    # -- persistence -----------------------------------------------------------------------------
    def _saved_state(self, inputs: TemplateInputs | None = None) -> tuple[dict, dict[str, np.ndarray]]:
        """Metadata and arrays every saved rig holds: the build ``inputs`` (default: the template's),
        material, controls, simulation and guard state (shared by :meth:`save` and ``FittedFaceRig.save``)."""
        inputs = self.template.inputs if inputs is None else inputs
        meta = {"material": self.material.to_dict(), "controls": self.controls, "time": self.time,
                "started": self.face.integrator.started, "contours": sorted(inputs.contours),
                "landmarks_json": inputs.landmarks_json, "muscles_json": inputs.muscles_json}
        arrays = {"canonical_vertices": inputs.canonical_vertices, "canonical_faces": inputs.canonical_faces,
                  "skull_vertices": inputs.skull_vertices, "skull_faces": inputs.skull_faces,
                  "jaw_vertices": inputs.jaw_vertices, "jaw_faces": inputs.jaw_faces,
                  "positions": self.face.network.positions, "velocity": self.face.integrator.velocity,
                  "anchor": self.face.network.attachments.anchor, "mirror": self.face.network.attachments.mirror,
                  "mass_scale": np.array([self.face.integrator.mass_scale])}
        for name, line in inputs.contours.items():
            arrays[f"contour__{name}"] = np.asarray(line)
        for guard_name in GUARDS:
            for key, value in getattr(self.face, guard_name).state().items():
                arrays[f"{guard_name}__{key}"] = value
        return meta, arrays

    @staticmethod
    def _write(path: str | Path, meta: dict, arrays: dict[str, np.ndarray]) -> None:
        meta_json = np.frombuffer(json.dumps(meta, sort_keys=True).encode("utf-8"), np.uint8)
        with open(Path(path), "wb") as handle:
            np.savez_compressed(handle, meta_json=meta_json, **arrays)

    def save(self, path: str | Path) -> None:
        """Write the rig to ``path`` (.npz, ``allow_pickle=False`` safe): build inputs, material, controls
        and simulation state. :meth:`load` rebuilds the template from the inputs (deterministic)."""
        meta, arrays = self._saved_state()
        meta.update(format=FORMAT, resolution=self.template.resolution)
        self._write(path, meta, arrays)

    def _restore_state(self, saved: "SavedRig") -> None:
        """Put back controls, simulation and guard state read by :func:`read_saved_rig`."""
        self.set_controls(saved.meta["controls"], strict=False)
        network, integrator = self.face.network, self.face.integrator
        network.positions[...] = saved.arrays["positions"]
        integrator.velocity[...] = saved.arrays["velocity"]
        network.set_attachment_targets(saved.arrays["anchor"], saved.arrays["mirror"])
        integrator.mass_scale = float(saved.arrays["mass_scale"][0])
        jaw = self._jaw()
        for name, state in saved.guards.items():
            guard = getattr(self.face, name)
            guard.set_bone_transforms([np.eye(4), jaw])
            guard.set_state(state)
        integrator.started = bool(saved.meta["started"])
        self.time = float(saved.meta["time"])

    @classmethod
    def load(cls, path: str | Path) -> "FaceRig":
        """Read a rig written by :meth:`save` (never unpickles anything); a rig fitted to an artist's mesh
        (:meth:`.fitted.FittedFaceRig.save`) comes back as a :class:`.fitted.FittedFaceRig`."""
        from . import fitted
        if fitted.is_fitted_rig_file(path):
            return fitted.FittedFaceRig.load(path)
        saved = read_saved_rig(path, FORMAT, "face rig")
        rig = cls(build_template(saved.meta["resolution"], saved.inputs), SkinMaterial(**saved.meta["material"]))
        if saved.arrays["positions"].shape != rig.face.network.positions.shape:
            raise UserError(f"{path}: the saved state does not match the rebuilt rig; rebuild the rig")
        rig._restore_state(saved)
        return rig


GUARDS = ("bone_guard", "teeth_guard")
STATE_ARRAYS = ("positions", "velocity", "anchor", "mirror", "mass_scale")


@dataclass
class SavedRig:
    """What :func:`read_saved_rig` read from a saved rig: metadata, template inputs, state and guard arrays
    (``arrays`` also holds any ``extra`` arrays the caller asked for)."""
    meta: dict
    inputs: TemplateInputs
    arrays: dict[str, np.ndarray]
    guards: dict[str, dict[str, np.ndarray]]


def read_saved_rig(path: str | Path, expected_format: str, what: str, extra: tuple[str, ...] = ()) -> SavedRig:
    """Read a rig ``.npz`` (never unpickles anything), checking its format; bad files raise UserError."""
    try:
        with np.load(Path(path), allow_pickle=False) as data:
            meta = json.loads(bytes(data["meta_json"]).decode("utf-8"))
            if meta.get("format") != expected_format:
                raise UserError(f"{path}: not a Faces & Hands {what} (format {meta.get('format')!r})")
            contours = {name: data[f"contour__{name}"] for name in meta["contours"]}
            inputs = TemplateInputs(data["canonical_vertices"], data["canonical_faces"], contours,
                                    data["skull_vertices"], data["skull_faces"], data["jaw_vertices"],
                                    data["jaw_faces"], meta["landmarks_json"], meta["muscles_json"])
            arrays = {key: data[key] for key in STATE_ARRAYS + tuple(extra)}
            guards = {g: {k.split("__", 1)[1]: data[k] for k in data.files if k.startswith(g + "__")}
                      for g in GUARDS}
    except (OSError, KeyError, ValueError) as exc:
        raise UserError(f"{path}: cannot read the {what} ({exc})") from None
    return SavedRig(meta, inputs, arrays, guards)


def _attachment_matrix(template: HeadTemplate):
    """Sparse (N, P) map from muscle control-point displacements to skin attachment displacements:
    weight x barycentric coordinate of the closest point on each attached muscle (3.1.2)."""
    from scipy import sparse
    n, k = template.attach_weight.shape
    corner = template.muscles.cells[np.maximum(template.attach_cell, 0)]            # (N, K, 3)
    data = (template.attach_weight[:, :, None] * template.attach_bary).ravel()
    rows = np.repeat(np.arange(n), k * 3)
    matrix = sparse.csr_matrix((data, (rows, corner.ravel())), shape=(n, len(template.muscles.rest)))
    matrix.eliminate_zeros()
    return matrix


@lru_cache(maxsize=4)
def _default_template(resolution: str) -> HeadTemplate:
    return build_template(resolution, default_inputs())


def build_default_rig(resolution: str = "default", material: SkinMaterial | None = None) -> FaceRig:
    """The default head (MediaPipe canonical face, myo-sim skull and jaw) at ``"default"`` (~2.6k skin
    nodes) or ``"10k"`` (~10k) resolution. The template is built once per process and shared (read-only)."""
    if resolution not in ("default", "10k", "coarse"):
        raise UserError(f"unknown face resolution {resolution!r}; use 'default' or '10k'")
    return FaceRig(_default_template(resolution), material)
