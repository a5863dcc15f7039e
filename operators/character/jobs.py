# SPDX-License-Identifier: GPL-3.0-or-later
"""The character's long work as :class:`..bases.jobs.Job` steps: the engine builds everything first (mesh,
skeleton, the face rig fitted to the head, the hand rigs: ``character.fitting``), then ``commit`` makes the
Blender objects, so cancelling leaves the scene as it was."""
from __future__ import annotations

from ...faces_hands_addon.character.fitting import rig_stages
from ...faces_hands_addon.character.model import SKELETONS
from ...faces_hands_addon.core.errors import UserError
from ..bases.jobs import Job
from . import objects

__all__ = ["BuildCharacterJob"]


class BuildCharacterJob(Job):
    """Build the default character with ``skeleton`` and its rig; ``commit`` makes its objects."""

    label = "Building the character"

    def __init__(self, name: str = "FH Character", skeleton: str = "game_engine", hands: bool = True):
        if skeleton not in SKELETONS:
            raise UserError(f"unknown skeleton {skeleton!r}; use one of {', '.join(SKELETONS)}")
        self.name, self.skeleton, self.hands = name, skeleton, hands
        self.rig = None
        self._stages = rig_stages(skeleton, hands)

    def step(self) -> float:
        item = next(self._stages)
        if isinstance(item, tuple):
            fraction, self.label = item
            return min(fraction, 0.99)
        self.rig = item
        self.warnings = tuple(item.warnings)
        return 1.0

    def commit(self, context) -> str:
        arm, body = objects.create_character_objects(context, self.rig, self.name)
        context.view_layer.objects.active = body
        mesh = self.rig.character.mesh
        return (f"Built '{body.name}': {len(mesh.vertices):,} vertices, {len(self.rig.character.skeleton.names)} "
                f"bones ({self.skeleton} skeleton), {len(self.rig.control_specs())} controls")
