# SPDX-License-Identifier: GPL-3.0-or-later
"""``FaceRig``: the animatable MEDUSA head (thesis 3.1.2), a :class:`..core.rig.Rig`.

Per frame (3.1.2 "Muscle Deformation" then "Mass Spring Network"): the controls give the jaw pose, gaze and
lid rotation; the muscles deform (contraction, jaw, connections, stretch, bulge); every skin node's
attachment target is carried by its bone, its lid and the muscles it is attached to (:mod:`.attachment`,
Fig. 3.4); then the spring network runs the guard's substeps, with the skull guard after each one. Outputs
are plain arrays: skin positions (N, 3) float32, 4x4 matrices for jaw, eyes, teeth and tongue, muscle fibre
polylines with their contraction, and wrinkle strengths.

Coordinates: the rig simulates in *head space* (metres, Z up, face along -Y, human scale). Every output
(positions, rest positions, part and bone meshes, rigid transforms, muscle fibres) is in the coordinates of
the skin mesh: for the default head that is head space (``head_to_mesh`` is the identity); a rig fitted to
an artist's mesh (:mod:`.fitted`) returns them in that mesh's own coordinates, ``head_to_mesh`` being the
4x4 similarity from head space to the mesh.

Deterministic: the same template, material, control values and frame times give byte-identical positions.
"""
from __future__ import annotations

from dataclasses import replace
from functools import lru_cache
from pathlib import Path
from typing import Mapping

import numpy as np

from ..anim.layers import mix, weighted_sum
from ..core.controls import ControlSpec, clamp_controls
from ..core.errors import UserError
from ..core.rig import Pose, write_rig_archive
from ..physics import kernel
from . import FACE_RIG_FORMAT, kinematics
from .controls import control_specs
from .lip_contact import LipContact
from .pressure import CheekPressure
from .network import FaceNetwork, SkinMaterial, build_network
from .persistence import read_saved_rig, restore_state, saved_state
from .skin import hidden_nodes
from .template import HeadTemplate, build_template, default_inputs
from .unfold import FoldMender, touching

__all__ = ["FaceRig", "build_default_rig", "WRINKLE_DRIVERS", "RESOLUTIONS"]

LIP_CONTACT = 0.001      # m: an inner-lip margin node this near the other lip touches it (the mend holds it)
GUARD_EVERY = 4          # the skull/eye guard runs after every 4th substep and after the last one
_IDENTITY = np.eye(4)
_IDENTITY.flags.writeable = False
RESOLUTIONS = ("default", "10k", "coarse")

#: 3.1.2 "Expressive Wrinkles": region -> (muscle, weight); strength = clamp(sum of weight * contraction)
WRINKLE_DRIVERS = {
    "forehead": (("frontalis_inner_L", 0.35), ("frontalis_inner_R", 0.35), ("frontalis_outer_L", 0.15),
                 ("frontalis_outer_R", 0.15)),
    "brow_furrow": (("corrugator_supercilii_L", 0.4), ("corrugator_supercilii_R", 0.4), ("procerus", 0.2)),
    "nose_bridge": (("procerus", 0.5), ("levator_labii_alaeque_nasi_L", 0.25),
                    ("levator_labii_alaeque_nasi_R", 0.25)),
}

LayerValues = Mapping[str, Mapping[str, float]]


class FaceRig:
    """A head template + its spring network + the current control values and simulation state."""

    kind = "face"

    def __init__(self, template: HeadTemplate, material: SkinMaterial | None = None) -> None:
        self.template = template
        self.face: FaceNetwork = build_network(template, material)
        self.material = self.face.material
        self.specs: dict[str, ControlSpec] = control_specs(template.muscles.names)
        self.controls: dict[str, float] = {name: spec.default for name, spec in self.specs.items()}
        self._rest = template.skin.vertices.copy()
        #: 4x4 similarity from the rig's head space to the skin mesh's coordinates (see the module docstring)
        self.head_to_mesh = np.eye(4)
        self.warnings: list[str] = []      # problems that leave the rig usable (fitted heads: no mouth opening)
        self.identity = ""                 # set by the rig store (core.rig.save_rig / load_rig_bytes)
        self._driven = template.skin.driven
        self._lip_contact = LipContact.build(template.skin, template.attachment.node_bone)
        self._pressure = CheekPressure.build(template.skin, np.asarray(template.skin.normals, np.float64))
        self._cache_key = None
        self._targets = self._frame_inputs = self._rigid = self._jaw = None
        self.time = 0.0
        self.frame_substeps = 0
        self._lip_midline: tuple[int, int] | None = None
        self._mender: FoldMender | None = None

    # -- controls --------------------------------------------------------------------------------
    def control_specs(self) -> dict[str, ControlSpec]:
        """Name -> :class:`ControlSpec` (range, default, UI group) of every control."""
        return dict(self.specs)

    def set_controls(self, values: Mapping[str, float], strict: bool = True) -> None:
        """Set some controls (clamped to their ranges); unknown names raise unless ``strict=False``."""
        self.controls.update(clamp_controls(dict(values), self.specs, strict, what="face control"))

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

    # -- the rig protocol (core.rig.Rig) ----------------------------------------------------------
    def reset(self) -> None:
        """Controls at their defaults, skin at rest."""
        self.reset_controls()
        self.reset_state()

    def worker_copy(self) -> "FaceRig":
        """A rig that settles exactly as this one does (same template and material, same simulation
        backend) with a simulation state of its own: :mod:`..anim.baking` settles shapes on it from
        another thread. Static shapes start from rest, so nothing else of this rig's state matters."""
        copy = type(self)._copy_of(self)
        copy.identity = self.identity
        copy.face.integrator.backend = self.face.integrator.backend
        for mine, theirs in zip((copy.face.bone_guard, copy.face.teeth_guard, *copy.face.eye_guards),
                                (self.face.bone_guard, self.face.teeth_guard, *self.face.eye_guards)):
            mine.backend = theirs.backend
        return copy

    @classmethod
    def _copy_of(cls, rig: "FaceRig") -> "FaceRig":
        return cls(rig.template, rig.material)

    def pose(self) -> Pose:
        """The current pose: skin positions and the rigid parts' transforms (copies)."""
        return Pose({"skin": np.array(self.positions, dtype=np.float32, copy=True)}, self.rigid_transforms())

    def rest_pose(self) -> Pose:
        return Pose({"skin": self.rest_positions}, {name: np.eye(4) for name in self.rigid_transforms()})

    def step(self, layer_values: LayerValues, dt: float) -> Pose:
        """Mix the control layers (thesis 4.3.5), advance one frame of ``dt`` seconds, return the pose."""
        self.controls = mix(layer_values, self.specs)        # checked and clamped there, once
        positions = self.step_frame(dt)            # a fresh array: the pose owns it (no second copy)
        return Pose({"skin": positions}, self.rigid_transforms())

    def settled(self, layer_values: LayerValues, max_time: float = 1.5, dt: float = 1 / 24) -> Pose:
        """The pose the face settles into from rest with the mixed ``layer_values``."""
        self.reset()
        self.controls = mix(layer_values, self.specs)
        self.relax(max_time=max_time, dt=dt)
        return self.pose()

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
        return dict(self.template.organs.parts)

    def bone_meshes(self) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        """Fitted skull and jaw (vertices, faces) in rest pose."""
        b = self.template.bones
        return {"skull": (b.skull_vertices, b.skull_faces), "jaw": (b.jaw_vertices, b.jaw_faces)}

    # -- per frame -------------------------------------------------------------------------------
    def jaw_transform(self) -> np.ndarray:
        """The jaw's 4x4 pose (head space) for the current controls (3.1.1: four degrees of freedom)."""
        self._sync_controls()
        if self._jaw is None:
            c, b = self.controls, self.template.bones
            self._jaw = kinematics.jaw_matrix(b.tmj_pivot, b.tmj_axis, c["jaw_open"], c["jaw_yaw"],
                                              c["jaw_forward"], c["jaw_drop"], glide=b.jaw_glide)
        return self._jaw.copy()

    def _sync_controls(self) -> None:
        """Drop what was computed for other control values (targets, jaw, part transforms): every per-frame
        quantity that depends on the controls only is computed once per control state."""
        key = tuple(sorted(self.controls.items()))
        if key != self._cache_key:
            self._cache_key = key
            self._targets = self._frame_inputs = self._rigid = self._jaw = None

    def rigid_transforms(self) -> dict[str, np.ndarray]:
        """4x4 matrices (head coordinates, applied to the rest meshes) for the current controls (copies of
        the ones computed once per control state)."""
        self._sync_controls()
        if self._rigid is None:
            self._rigid = self._rigid_transforms(self.jaw_transform())
        return {name: matrix.copy() for name, matrix in self._rigid.items()}

    def _rigid_transforms(self, jaw: np.ndarray) -> dict[str, np.ndarray]:
        c, organs = self.controls, self.template.organs
        out = {"jaw": jaw, "teeth_upper": np.eye(4), "teeth_lower": jaw, "skull": np.eye(4)}
        for side, centre in organs.eye_centres.items():
            yaw, pitch = self.eye_gaze(side)
            out[f"eye_{side}"] = kinematics.eye_matrix(centre, yaw, pitch)
        out["tongue"] = kinematics.tongue_matrix(jaw, organs.tongue_pivot, c["tongue_tip_up"], c["tongue_back"],
                                                 c["tongue_out"])
        return out

    def eye_gaze(self, side: str) -> tuple[float, float]:
        """(yaw, pitch) of one eye in [-1, 1]: the conjugate gaze (``eye_yaw``, ``eye_pitch``, what
        behaviour drives) plus that eye's own offset (``eye_yaw_L`` ..., what an ARKit look key drives, so
        eyeLookInLeft turns the left eye only)."""
        c = self.controls
        return (float(np.clip(c["eye_yaw"] + c.get(f"eye_yaw_{side}", 0.0), -1.0, 1.0)),
                float(np.clip(c["eye_pitch"] + c.get(f"eye_pitch_{side}", 0.0), -1.0, 1.0)))

    def _contraction_vector(self) -> np.ndarray:
        return np.array([self.controls[name] for name in self.template.muscles.names])

    def attachment_targets(self) -> np.ndarray:
        """Where every skin node's attachment pair wants it (N, 3): bone-carried rest position + lid
        rotation + displacement of the muscles it is attached to. Cached per control state."""
        self._sync_controls()
        if self._targets is not None:
            return self._targets
        t, rest = self.template, self._rest
        jaw = self.jaw_transform()
        target = t.attachment.carried(rest, jaw)
        for side, lid in t.organs.lids.items():
            lid_rest = rest[lid.index]
            rotated = lid.rotate_lid(lid_rest, self.controls[f"eyelid_close_{side}"], self.eye_gaze(side)[1],
                                     self.controls.get(f"eyelid_raise_{side}", 0.0),
                                     self.controls.get(f"orbicularis_oculi_{side}", 0.0))
            target[lid.index] += rotated - lid_rest
        state = t.muscles.deform(self._contraction_vector(), self.controls["orbicularis_oris_protrusion"], jaw)
        self._muscle_state = state
        t.attachment.add_muscle_pull(state.displacement, t.muscles.rest, t.muscles.jaw_carry, jaw, target)
        if self._pressure is not None:                    # air in the mouth (cheekPuff)
            puff = self._pressure.displacement(self.controls.get("cheek_puff", 0.0),
                                               {s: self.controls.get(f"buccinator_{s}", 0.0) for s in "LR"})
            if puff is not None:
                target += puff
        if self._lip_contact is not None:                 # the lips meet instead of passing through each other
            target[:, 2] += self._lip_contact.correction(target)
            target = self._lip_contact.commissures(target, rest)
        self._targets = target
        self._jaw_now = jaw
        return target

    def _frame_targets(self):
        """``(anchor, mirror, driven)`` (3, N) arrays the integrator moves the attachments and kinematic
        nodes to over a frame, for the current controls (cached with :meth:`attachment_targets`: a settle
        or a held pose does not rebuild them every frame)."""
        target = self.attachment_targets()
        if self._frame_inputs is None:
            offset = self.template.attachment.posed_offsets(self.face.anchor_offset, self._jaw_now)
            self._frame_inputs = (np.ascontiguousarray((target + offset).T),
                                  np.ascontiguousarray((target - offset).T),
                                  np.ascontiguousarray(target.T) if self._driven else None)
        return self._frame_inputs

    def _advance(self, dt: float) -> None:
        """Simulate one frame of ``dt`` seconds (guards slide with the jaw during the frame); the state only
        (:meth:`step_frame` also returns the positions, which :meth:`settle` needs only after its last frame)."""
        anchor, mirror, driven = self._frame_targets()
        face = self.face
        bones = [_IDENTITY, self._jaw_now]
        for guard in (face.bone_guard, face.teeth_guard):
            guard.begin_frame()                        # planes slide with the jaw during the frame
            guard.set_bone_transforms(bones)
            guard.refresh(face.network.positions)
        self.frame_substeps = face.integrator.advance(dt, anchor=anchor, mirror=mirror, driven=driven,
                                                      constraint=face.constrain, constraint_every=GUARD_EVERY)
        self.time += dt

    def step_frame(self, dt: float = 1 / 24) -> np.ndarray:
        """Advance the simulation by one frame of ``dt`` seconds; returns positions (N, 3) float32."""
        self._advance(dt)
        return self.positions

    def relax(self, max_time: float = 1.5, dt: float = 1 / 24, tolerance: float = 2e-4) -> np.ndarray:
        """Step until the skin is at rest or ``max_time`` seconds have been simulated; returns the positions.
        At rest: at least 3 frames, and no node coordinate moved more than ``tolerance * dt`` over the last
        frame (``tolerance`` m/s as a mean speed). The test is on displacement, not on the integrator's
        velocity: a node a guard holds (skull, teeth, eyeball) keeps the velocity its springs give it while
        the guard puts it back every substep, so a velocity test waits for nodes that do not move."""
        frames = max(3, int(np.ceil(max_time / dt)))
        x = self.face.network.positions
        previous = x.copy()
        largest_move = kernel.compiled(kernel.largest_move)
        if largest_move is None:
            moved = np.empty_like(x)

            def largest_move(x, previous):     # the numpy path: the same number
                step = float(np.abs(np.subtract(x, previous, out=moved), out=moved).max())
                previous[...] = x
                return step
        for frame in range(frames):
            self._advance(dt)                  # the state only: the positions are built once, at the end
            if largest_move(x, previous) < tolerance * dt and frame >= 2:
                break
        self.mend_folds()
        return self.positions

    def mend_folds(self) -> int:
        """Mend the visible skin triangles the settle turned over (:mod:`.unfold`), in the simulation state;
        returns the folds left. Pinned: the nodes a camera does not see, the lid margins, the driven ring,
        and the inner-lip margin nodes that touch the other lip now (within ``LIP_CONTACT``), so the lips'
        and lids' contact is what the simulation made it; a margin apart from the other lip may move."""
        skin = self.template.skin
        if self._mender is None:
            hidden = hidden_nodes(skin)
            pinned = hidden.copy()
            for key in ("eye_L_upper", "eye_L_lower", "eye_R_upper", "eye_R_lower"):
                if key in skin.contours:
                    pinned[np.asarray(skin.contours[key])] = True
            if skin.kinematic is not None:
                pinned |= np.asarray(skin.kinematic, bool)
            faces = np.asarray(skin.faces)
            self._mender = FoldMender(self._rest, faces, ~pinned, ~np.any(hidden[faces], axis=1))
        x = self.face.network.positions
        positions = np.array(x.T, dtype=np.float64)
        folds = self._mender.folded(positions)
        if len(folds) == 0:
            return 0
        movable = self._mender.movable.copy()
        margins = [np.asarray(skin.contours.get(k, ()), np.int64) for k in ("lips_inner_upper", "lips_inner_lower")]
        movable[touching(positions, *margins, LIP_CONTACT)] = False
        left = self._mender.mend(positions, movable, folds)
        if self._mender.mended:
            x[...] = positions.T
        return left

    def lip_gap(self) -> float:
        """The simulated lips' gap at the midline now (m, head space; negative when pressed together): the
        inner upper lip's lowest midline node over the inner lower lip's (3.1.3 closures; used by the
        per-frame bake's ``anim.closure_drive``)."""
        if self._lip_midline is None:
            contours, rest = self.template.skin.contours, self._rest
            self._lip_midline = tuple(int(nodes[np.argmin(np.abs(rest[nodes, 0]))]) for nodes in
                                      (np.asarray(contours[k]) for k in ("lips_inner_upper", "lips_inner_lower")))
        upper, lower = self._lip_midline
        z = self.face.network.positions[2]
        return float(z[upper] - z[lower])

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

    def muscle_display(self) -> tuple[np.ndarray, np.ndarray]:
        """What :meth:`muscle_fibres` shows, as two flat arrays for a display that draws every fibre as one
        mesh: all fibre points (K, 3) float32 in :meth:`muscle_fibres`' order and each point's contraction
        (K,) float32 (one gather instead of a polyline per fibre: the live preview's every tick)."""
        self.attachment_targets()
        index, lengths, muscle = self.template.muscles.fibre_order()
        values = np.array([self.controls[name] for name in self.template.muscles.names], np.float32)
        return self._display_points(self._muscle_state.points[index]), np.repeat(values[muscle], lengths)

    def _display_points(self, points: np.ndarray) -> np.ndarray:
        return points.astype(np.float32)

    def wrinkles(self) -> dict[str, float]:
        """Expressive-wrinkle strengths per region in [0, 1] (3.1.2 "Expressive Wrinkles"), by the same
        rule the wrinkle drivers use (:func:`..anim.layers.weighted_sum`)."""
        return {region: weighted_sum(drivers, self.controls) for region, drivers in WRINKLE_DRIVERS.items()}

    def wrinkle_masks(self) -> dict[str, np.ndarray]:
        """Per-node weights (N,) float32 of each wrinkle region, e.g. for a colour attribute."""
        return {k: v.astype(np.float32) for k, v in self.template.skin.wrinkle_regions.items()}

    # -- persistence -----------------------------------------------------------------------------
    def save(self, path: str | Path) -> None:
        """Write the rig to ``path`` (.npz, no pickles): build inputs, material, controls and simulation
        state. :meth:`load` rebuilds the template from the inputs (deterministic)."""
        meta, arrays = saved_state(self, self.template.inputs)
        meta.update(format=FACE_RIG_FORMAT, resolution=self.template.resolution)
        write_rig_archive(path, meta, arrays)

    @classmethod
    def load(cls, path: str | Path) -> "FaceRig":
        """Read a rig written by :meth:`save` (never unpickles anything). Rigs of any kind load through
        :func:`..core.rig.load_rig`."""
        saved = read_saved_rig(path, FACE_RIG_FORMAT, "face rig")
        if saved.meta.get("resolution") not in RESOLUTIONS:
            raise UserError(f"{path}: unknown face resolution {saved.meta.get('resolution')!r}")
        rig = cls(build_template(saved.meta["resolution"], saved.inputs), SkinMaterial(**saved.meta["material"]))
        if saved.arrays["positions"].shape != rig.face.network.positions.shape:
            raise UserError(f"{path}: the saved state does not match the rebuilt rig; rebuild the rig")
        restore_state(rig, saved)
        return rig


@lru_cache(maxsize=4)
def _default_template(resolution: str, landmarks_json: str, muscles_json: str) -> HeadTemplate:
    inputs = default_inputs()
    return build_template(resolution, replace(inputs, landmarks_json=landmarks_json, muscles_json=muscles_json))


def build_default_rig(resolution: str = "default", material: SkinMaterial | None = None) -> FaceRig:
    """The default head (MediaPipe canonical face, myo-sim skull and jaw) at ``"default"`` (~2.9k skin
    nodes) or ``"10k"`` (~11k) resolution. The template is built once per process for each version of the
    face presets (an edited preset in the user folder gives a new template) and shared (read-only)."""
    if resolution not in RESOLUTIONS:
        raise UserError(f"unknown face resolution {resolution!r}; use 'default' or '10k'")
    inputs = default_inputs()
    return FaceRig(_default_template(resolution, inputs.landmarks_json, inputs.muscles_json), material)

