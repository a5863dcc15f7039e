# SPDX-License-Identifier: GPL-3.0-or-later
"""``HandRig``: the physics-based anatomical hand (thesis 6.2), a :class:`..core.rig.Rig`.

Per frame, in the order of 6.2.1 "Animation" and 6.2.2: the mixed contraction values drive the pseudo
muscles, which rotate the bones (:mod:`.pseudo`, Eqs. 6.1-6.9, joint limits of Table 6.4), and touching
fingers are kept side by side (:mod:`.contact`) and the thumb on the curled fingers (:mod:`.thumb_contact`; both
beyond the thesis); the geometric
muscles follow their bones and bulge (:mod:`.geometric`); every skin node's attachment point is carried by
the bones (the skin's skinning weights), pushed out by the muscle beneath it and kept on its own side of each
bent finger joint (:mod:`.crease`, beyond the thesis); then the mass-spring network is integrated (leapfrog
Verlet, :mod:`..physics`) and the skin follows.

Outputs: ``Pose.positions["skin"]`` (N, 3) float32, ``Pose.positions["muscles"]`` (the geometric muscles'
outer surfaces, for display) and ``Pose.transforms[bone]`` (4x4, rest -> pose) for the 21 bones, named like
the WebXR hand joints. The engine simulates a right hand; ``side="left"`` mirrors every output in X.

A rig built from a photograph (:mod:`.photo`) keeps its photo input and rebuilds the same warped hand when
it is loaded. Deterministic: the same presets, input and control values give byte-identical outputs.
"""
from __future__ import annotations

from pathlib import Path
from typing import Mapping, Sequence

import numpy as np
from scipy import sparse

from ..anim.layers import BASE_LAYER, mix
from ..core import geometry
from ..core.controls import ControlSpec, clamp_controls
from ..core.errors import UserError
from ..core.rig import Pose, read_rig_archive, write_rig_archive
from ..core.skinning import Bone, limit_influences
from . import HAND_RIG_FORMAT
from .contact import FingerContact
from .thumb_contact import ThumbContact
from .crease import Creases, FingerSides, bone_radii
from .geometric import build_geometric_muscles
from .network import HandMaterial, build_hand_network
from .photo import photo_warp
from .pseudo import PseudoMuscles
from .skeleton import mirror_matrix
from .template import DEFAULT_MESH, HandTemplate, PresetTexts, hand_template, warped_template

__all__ = ["HandRig", "build_hand_rig", "SIDES", "control_specs_for"]

SIDES = ("right", "left")
STATE_ARRAYS = ("angles", "angular_velocity", "positions", "velocity")
LayerValues = Mapping[str, Mapping[str, float]]
_VERBS = {("flexion", 1): "flexes", ("flexion", -1): "extends", ("abduction", 1): "abducts",
          ("abduction", -1): "adducts", ("rotation", 1): "rotates", ("rotation", -1): "rotates"}


def _joint_label(bone: str) -> str:
    label = bone.replace("-finger", "").replace("phalanx-proximal", "MCP").replace("phalanx-intermediate", "PIP")
    label = label.replace("phalanx-distal", "DIP").replace("metacarpal", "CMC")
    return label.replace("thumb-DIP", "thumb IP").replace("thumb-MCP", "thumb MCP").replace("-", " ")


def control_specs_for(template: HandTemplate) -> dict[str, ControlSpec]:
    """One muscle control (contraction 0..1) per pseudo muscle, with a one-line description from Table A.1."""
    specs = {}
    twins = {g["pseudo"]: g["name"] for g in template.geometric}
    for m in template.muscles:
        actions = []
        for row in m.rows:
            text = f"{_VERBS[(row.dof, int(row.sign))]} {_joint_label(row.bone)}"
            if text not in actions:
                actions.append(text)
        bulge = "; bulges the skin (geometric muscle)" if m.name in twins else ""
        specs[m.name] = ControlSpec(m.name, 0.0, 1.0, 0.0, m.group, "muscle",
                                    f"{m.name.replace('_', ' ')}: {', '.join(actions)}{bulge}")
    return specs


class HandRig:
    """A hand template + its pseudo muscles, geometric muscles, spring network and state."""

    kind = "hand"

    def __init__(self, template: HandTemplate, side: str = "right", material: HandMaterial | None = None,
                 photo: dict | None = None, mesh: str = DEFAULT_MESH):
        if side not in SIDES:
            raise UserError(f"hand side must be 'left' or 'right', not {side!r}")
        self.template, self.side, self.photo, self.mesh = template, side, photo, mesh
        sk = template.skeleton
        self.skeleton = sk
        self.specs = control_specs_for(template)
        self.muscle_names = [m.name for m in template.muscles]
        self.pseudo = PseudoMuscles(sk, template.muscles, template.masses, template.friction, template.capsule)
        self.contact = FingerContact(sk, self.pseudo)
        self.geometric = build_geometric_muscles(template.geometric, sk, template.skin.vertices,
                                                 template.skin.faces, self.muscle_names, template.grids)
        self.hand = build_hand_network(template.skin.vertices, template.skin.faces, material)
        self.material = self.hand.material
        self._weights = sparse.csr_matrix(template.skin.weights)
        self._skinning = limit_influences(template.skin.weights)
        radii = bone_radii(sk, template.skin.vertices, template.skin.weights)
        self.creases = Creases(sk, template.skin.vertices, template.skin.weights, radii)
        self.thumb_contact = ThumbContact(sk, self.pseudo, radii)
        self.sides = FingerSides(sk, template.skin.vertices, template.skin.weights)
        self._rest = template.skin.vertices.copy()
        self.controls = {name: spec.default for name, spec in self.specs.items()}
        self.identity = ""
        self.time = 0.0
        self._mirror = np.array([-1.0, 1.0, 1.0]) if side == "left" else None
        self._surface_key = None

    # -- controls --------------------------------------------------------------------------------
    def control_specs(self) -> dict[str, ControlSpec]:
        return dict(self.specs)

    def set_controls(self, values: Mapping[str, float], strict: bool = True) -> None:
        self.controls.update(clamp_controls(dict(values), self.specs, strict, what="hand muscle"))

    def contraction_vector(self) -> np.ndarray:
        return np.array([self.controls[name] for name in self.muscle_names])

    # -- the rig protocol ------------------------------------------------------------------------
    def reset(self) -> None:
        """Controls at rest (0), joints straight and still, skin at rest."""
        self.controls = {name: spec.default for name, spec in self.specs.items()}
        self.reset_state()

    def reset_state(self) -> None:
        self.pseudo.reset()
        self.thumb_contact.reset()
        net, integ = self.hand.network, self.hand.integrator
        net.positions[...] = self._rest.T
        integ.velocity[...] = 0.0
        integ.started = False
        net.set_attachment_targets(*self.hand.set_targets(self._rest))
        self._surface_key = None
        self.time = 0.0

    def worker_copy(self) -> "HandRig":
        """A rig that settles exactly as this one does (same template, side, material and photo) with a
        simulation state of its own, at rest: :mod:`..anim.baking` settles shapes on it from another thread."""
        copy = HandRig(self.template, self.side, self.material, self.photo, self.mesh)
        copy.reset_state()
        copy.identity = self.identity
        return copy

    def step(self, layer_values: LayerValues, dt: float) -> Pose:
        """Mix the layers (4.3.5: summed, clamped to each control's range), simulate one frame of ``dt``
        seconds, return the pose."""
        self.controls = mix(layer_values, self.specs)
        self.step_frame(dt)
        return self.pose()

    def settled(self, layer_values: LayerValues, max_time: float = 2.0, dt: float = 1 / 30,
                then: Sequence[Mapping[str, float]] = ()) -> Pose:
        """The pose the hand settles into from rest with the mixed ``layer_values``; each contraction set of
        ``then`` is set once the hand has settled before it, and it settles again (up to ``max_time`` each)."""
        self.reset()
        self.controls = mix(layer_values, self.specs)        # checked and clamped there, once
        self.relax(max_time, dt)
        for values in then:
            self.set_controls(values)
            self.relax(max_time, dt)
        return self.pose()

    def settled_stages(self, stages: Sequence[Mapping[str, float]], max_time: float = 2.0,
                       dt: float = 1 / 30) -> Pose:
        """A preset pose stage by stage (:func:`.motion.pose_stages`: a staged pose's squeeze once its first
        stage has settled) settled from rest, as the contact sheets show it."""
        return self.settled({BASE_LAYER: stages[0]}, max_time, dt, stages[1:])

    def rest_pose(self) -> Pose:
        eye = {name: np.eye(4) for name in self.skeleton.names}
        return Pose({"skin": self.rest_positions, "muscles": self._out(self.geometric.layout.rest_points)}, eye)

    def pose(self) -> Pose:
        """The current pose (copies): skin, muscle surfaces, bone transforms."""
        key = self.pseudo.angles.tobytes() + self.contraction_vector().tobytes()
        if self._surface_key != key:
            self._transforms = self.skeleton.bone_transforms(self.pseudo.angles)
            self._surface = self.geometric.surface(self._transforms, self.contraction_vector())[0]
            self._surface_key = key
        transforms = self._mirrored(self._transforms)
        return Pose({"skin": self.positions, "muscles": self._out(self._surface)},
                    {name: transforms[b] for b, name in enumerate(self.skeleton.names)})

    # -- simulation ------------------------------------------------------------------------------
    def attachment_targets(self, transforms: np.ndarray, contraction: np.ndarray) -> np.ndarray:
        """Bone-carried (linear blend of the bone transforms) rest positions plus the muscles' bulge, with the
        flexion creases and the facing sides of neighbouring fingers kept apart (N, 3)."""
        flat = transforms[:, :3, :].reshape(len(transforms), 12)
        blended = (self._weights @ flat).reshape(-1, 3, 4)
        target = np.einsum("nij,nj->ni", blended[:, :, :3], self._rest) + blended[:, :, 3]
        surface, bulge = self.geometric.surface(transforms, contraction)
        self._surface, self._surface_key = surface, self.pseudo.angles.tobytes() + contraction.tobytes()
        target = self.creases.apply(target + self.geometric.skin_displacement(bulge), transforms)
        return self.sides.apply(target, transforms)

    def step_frame(self, dt: float = 1 / 30) -> None:
        contraction = self._advance_joints(dt)
        self._advance_skin(contraction, dt)

    def step_bones(self, layer_values: LayerValues, dt: float) -> dict[str, np.ndarray]:
        """:meth:`step` for a host that skins the hand itself (a character's armature): the joints, their
        limits and contacts advance as in :meth:`step` (6.2.2; the skin never moves a bone), the skin is not
        simulated; returns the bone transforms of :meth:`pose`."""
        self.controls = mix(layer_values, self.specs)
        self._advance_joints(dt)
        self.time += dt
        transforms = self._mirrored(self.contact.transforms(self.pseudo.angles))
        return {name: transforms[b] for b, name in enumerate(self.skeleton.names)}

    def _advance_joints(self, dt: float) -> np.ndarray:
        """The joints one frame on (pseudo muscles, then finger and thumb contact); returns the contractions."""
        if not (dt > 0 and np.isfinite(dt)):
            raise UserError("the frame time step must be a positive number of seconds")
        contraction = self.contraction_vector()
        before = self.pseudo.angles.copy()
        self.pseudo.step(contraction, dt)
        self.contact.resolve()
        angles = self.pseudo.angles
        self.contact.keep(angles, self.thumb_contact.resolve(self.contact.transforms(angles), before))
        return contraction

    def _advance_skin(self, contraction: np.ndarray, dt: float) -> None:
        """One frame of the skin (6.2.1: the bones carry the skin, the springs deform it). The skin is carried
        with the tissue under it: each node first moves by what its attachment target moved this frame, then
        the mass-spring network simulates its deformation relative to that (the equilibrium is unchanged).
        Simulated from a standing start instead, a node trails a moving bone by its response time (critically
        damped at 4 Hz: 80 ms, ~16 mm on a fingertip at 200 mm/s), and the bone showed through the skin."""
        self._transforms = self.contact.transforms(self.pseudo.angles)
        target = self.attachment_targets(self._transforms, contraction)
        net = self.hand.network
        carried = target.T - 0.5 * (net.attachments.anchor + net.attachments.mirror)
        net.positions += carried
        net.set_attachment_targets(*self.hand.set_targets(target))
        self.frame_substeps = self.hand.integrator.advance(dt)
        self.time += dt

    def relax(self, max_time: float = 2.0, dt: float = 1 / 30, tolerance: float = 2e-3) -> None:
        """Step until joints and skin are at rest (joint speed below ``tolerance`` rad/s, skin below
        ``tolerance`` m/s, at least 3 frames) or ``max_time`` seconds have passed."""
        frames = max(3, int(np.ceil(max_time / dt)))
        for frame in range(frames):
            self.step_frame(dt)
            if frame >= 2 and self.pseudo.speed() < tolerance and \
                    float(np.abs(self.hand.integrator.velocity).max()) < tolerance:
                break

    def pose_joints(self, angles: np.ndarray, settle_time: float = 0.6, dt: float = 1 / 30) -> Pose:
        """Put the joints at ``angles`` (radians, clamped to Table 6.4; rotations coupled) with the current
        contractions' bulge, let the skin settle there, and return the pose (direct posing)."""
        self.pseudo.set_angles(np.asarray(angles, np.float64))
        contraction = self.contraction_vector()
        for _ in range(max(3, int(np.ceil(settle_time / dt)))):
            self._advance_skin(contraction, dt)
        return self.pose()

    def geometric_twins(self) -> list[str]:
        """The pseudo muscles whose contraction also bulges a geometric muscle (6.2.2, Fig. 6.15)."""
        return [self.muscle_names[i] for i in self.geometric.pseudo]

    def bulge_lift(self, angles: np.ndarray, settle_time: float = 2.5) -> tuple[np.ndarray, Pose, Pose]:
        """What the geometric muscles add at the joint ``angles`` with the current contractions (Fig. 6.18): the
        skin settled there with their bulge ("on") and with their twins at 0 ("off", the joints held, so
        nothing else changes). Returns each node's outward lift (m, along the "off" skin's normal) and both
        poses; the controls are left as they were."""
        controls = dict(self.controls)
        on = self.pose_joints(angles, settle_time)
        self.set_controls({name: 0.0 for name in self.geometric_twins()})
        off = self.pose_joints(angles, settle_time)
        self.controls = controls
        skin_on, skin_off = (p.positions["skin"].astype(np.float64) for p in (on, off))
        lift = np.einsum("ij,ij->i", skin_on - skin_off, geometry.vertex_normals(skin_off, self.faces))
        return lift, on, off

    # -- outputs ---------------------------------------------------------------------------------
    def _out(self, points: np.ndarray) -> np.ndarray:
        points = points if self._mirror is None else points * self._mirror
        return np.ascontiguousarray(points, dtype=np.float32)

    @property
    def positions(self) -> np.ndarray:
        return self._out(self.hand.network.positions.T)

    @property
    def rest_positions(self) -> np.ndarray:
        return self._out(self._rest)

    @property
    def faces(self) -> np.ndarray:
        faces = self.template.skin.faces.astype(np.int32)
        return faces[:, ::-1].copy() if self._mirror is not None else faces

    @property
    def corner_uvs(self) -> np.ndarray:
        uvs = self.template.skin.corner_uvs
        return uvs[:, ::-1].copy() if self._mirror is not None else uvs

    @property
    def joint_angles(self) -> np.ndarray:
        return self.pseudo.angles.copy()

    def transforms(self, angles: np.ndarray | None = None) -> np.ndarray:
        """(B, 4, 4) bone transforms (mirrored for a left hand) for ``angles`` (default: the current ones)."""
        return self._mirrored(self.skeleton.bone_transforms(self.pseudo.angles if angles is None else angles))

    def _mirrored(self, m: np.ndarray) -> np.ndarray:
        if self._mirror is None:
            return m.copy()
        s = mirror_matrix()
        return s @ m @ s

    def skin_weights(self) -> np.ndarray:
        """(vertices x bones) linear-blend-skinning weights as Blender and every exported file play them:
        at most four bones per vertex (:mod:`..core.skinning`; the reference skin has up to five)."""
        return self._skinning

    def bone_meshes(self) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        """Bone -> (vertices, faces) of its bone meshes in rest pose (mirrored for a left hand)."""
        sk = self.skeleton
        faces = {n: (f[:, ::-1] if self._mirror is not None else f) for n, f in sk.mesh_faces.items()}
        return {n: (self._out(v), faces[n]) for n, v in sk.mesh_vertices.items()}

    def joints(self) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]:
        """Bone -> (head, tail, frame 3x3 columns x/y/z) at rest (mirrored for a left hand)."""
        sk, out = self.skeleton, {}
        for b, name in enumerate(sk.names):
            head, tail, frame = sk.position[b].copy(), sk.tail[b].copy(), sk.frame[b].copy()
            if self._mirror is not None:
                head, tail = head * self._mirror, tail * self._mirror
                frame = np.diag(self._mirror) @ frame
            out[name] = (head, tail, frame)
        return out

    def bones(self) -> list[Bone]:
        """The skeleton as armature bones (6.2.1): X the flexion axis, Y along the bone, Z minus the frame's
        abduction axis; the forearm carries the wrist and moves no skin."""
        joints, sk = self.joints(), self.skeleton
        return [Bone(name, tuple(joints[name][0]), tuple(joints[name][1]), tuple(-joints[name][2][:, 1]),
                     sk.names[sk.parent[b]] if sk.parent[b] >= 0 else None, name != "forearm")
                for b, name in enumerate(sk.names)]

    def muscle_quads(self) -> np.ndarray:
        quads = self.geometric.grid_quads()
        return quads[:, ::-1].copy() if self._mirror is not None else quads

    def feature_points(self) -> dict[str, np.ndarray]:
        return {k: self._out(v[None])[0] for k, v in self.template.features.items()}

    # -- persistence -----------------------------------------------------------------------------
    def save(self, path: str | Path) -> None:
        """Write the rig (.npz, no pickles): presets, side, photo input, material, controls and state (the
        joints, the skin and the thumb's sticking hold)."""
        p = self.template.presets
        meta = {"format": HAND_RIG_FORMAT, "side": self.side, "photo": self.photo, "mesh": self.mesh,
                "material": self.material.to_dict(),
                "controls": {k: float(v) for k, v in self.controls.items()}, "time": self.time,
                "started": self.hand.integrator.started,
                "presets": {"joints": p.joints, "muscles": p.muscles, "geometric": p.geometric}}
        arrays = {"angles": self.pseudo.angles, "angular_velocity": self.pseudo.velocity,
                  "positions": self.hand.network.positions, "velocity": self.hand.integrator.velocity,
                  **self.thumb_contact.state()}
        write_rig_archive(path, meta, arrays)

    @classmethod
    def load(cls, path: str | Path) -> "HandRig":
        meta, arrays = read_rig_archive(path, HAND_RIG_FORMAT, "hand rig", STATE_ARRAYS, ("thumb_held_",))
        try:
            texts = PresetTexts(**meta["presets"])
            rig = build_hand_rig(meta["side"], meta.get("photo"), HandMaterial(**meta["material"]), texts,
                                 meta.get("mesh", "tube"))     # rigs saved before the MPFB2 hand: the tube
        except (KeyError, TypeError) as error:
            raise UserError(f"{path}: the saved hand rig is incomplete ({error})") from None
        if arrays["positions"].shape != rig.hand.network.positions.shape or \
                arrays["angles"].shape != rig.pseudo.angles.shape:
            raise UserError(f"{path}: the saved state does not match the rebuilt hand; rebuild the rig")
        rig.set_controls(meta["controls"], strict=False)
        rig.pseudo.angles[:] = arrays["angles"]
        rig.pseudo.velocity[:] = arrays["angular_velocity"]
        rig.hand.network.positions[...] = arrays["positions"]
        rig.hand.integrator.velocity[...] = arrays["velocity"]
        rig.hand.integrator.started = bool(meta["started"])
        rig.thumb_contact.restore(arrays)
        rig._transforms = rig.skeleton.bone_transforms(rig.pseudo.angles)
        rig.hand.network.set_attachment_targets(*rig.hand.set_targets(
            rig.attachment_targets(rig._transforms, rig.contraction_vector())))
        rig.time = float(meta["time"])
        return rig


def build_hand_rig(side: str = "right", photo: dict | None = None, material: HandMaterial | None = None,
                   texts: PresetTexts | None = None, mesh: str = DEFAULT_MESH) -> HandRig:
    """The reference hand on the skin ``mesh`` (:data:`.template.MESHES`), or the
    hand of a photograph (``photo``: the parsed feature-point input of :func:`.photo.read_photo_points`), as a
    rig of ``side``."""
    template = hand_template(texts, mesh)
    if photo is not None:
        template = warped_template(template, photo_warp(template.features, photo))
    rig = HandRig(template, side, material, photo, mesh)
    rig.reset_state()
    return rig
