# SPDX-License-Identifier: GPL-3.0-or-later
"""The character's long work as :class:`..common.jobs.Job` steps: the engine builds everything first (mesh,
skeleton, the face rig fitted to the head, the hand rigs), then ``commit`` makes the Blender objects, so
cancelling leaves the scene as it was."""
from __future__ import annotations

from ..common.jobs import Job
from . import objects

__all__ = ["BuildCharacterJob"]


class BuildCharacterJob(Job):
    """Build the default character with ``skeleton``; ``commit`` makes its objects (armature + body)."""

    label = "Building the character"

    def __init__(self, name: str = "FH Character", skeleton: str = "game_engine"):
        from ...faces_hands_addon.character.model import SKELETONS
        from ...faces_hands_addon.core.errors import UserError
        if skeleton not in SKELETONS:
            raise UserError(f"unknown skeleton {skeleton!r}; use one of {', '.join(SKELETONS)}")
        self.name, self.skeleton = name, skeleton
        self.character = None
        self.stage = 0

    def step(self) -> float:
        from ...faces_hands_addon.character.model import build_character
        if self.character is None:
            self.character = build_character(self.skeleton)
        return 1.0

    def commit(self, context) -> str:
        arm, body = objects.create_character_objects(context, self.character, self.name)
        context.view_layer.objects.active = body
        mesh = self.character.mesh
        return (f"Built '{body.name}': {len(mesh.vertices):,} vertices, {len(self.character.skeleton.names)} bones "
                f"({self.skeleton} skeleton)")
