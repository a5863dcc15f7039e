# SPDX-License-Identifier: GPL-3.0-or-later
"""The 26 source feature points of the reference hand (thesis 6.2.3, Table 6.5, Fig. 6.19 centre):

======  ====================================================================
 5       finger tips I-V: the skin's far end along each distal phalanx
 4       DIP II-V, 1 IP I, 4 PIP II-V, 5 MCP I-V: the joint centres
 4       interdigital skin: the skin of the web between adjacent fingers
 2       radial and ulnar wrist: the skin's sides at the wrist crease
 1       head of the ulna: the skin over the ulna's distal end
======  ====================================================================

In a photograph of a flat hand these are what an artist clicks (knuckle creases over the joints, the notch of
each web, the wrist's outline, the bump of the ulna); the photo warp (:mod:`.photo`) lifts the clicks to 3D
with the source points' heights.
"""
from __future__ import annotations

import numpy as np

from .reference import PALM_NORMAL
from .skeleton import FINGERS, Skeleton

__all__ = ["FEATURE_NAMES", "feature_points", "MIN_FEATURES", "CHAINS", "WEBS"]

MIN_FEATURES = 16
CHAINS = {"thumb": ("thumb_mcp", "thumb_ip", "thumb_tip"),
          **{f: (f"{f}_mcp", f"{f}_pip", f"{f}_dip", f"{f}_tip") for f in FINGERS[1:]}}
WEBS = ("web_thumb_index", "web_index_middle", "web_middle_ring", "web_ring_pinky")
FEATURE_NAMES = (tuple(f"{f}_tip" for f in FINGERS) + tuple(f"{f}_dip" for f in FINGERS[1:]) + ("thumb_ip",)
                 + tuple(f"{f}_pip" for f in FINGERS[1:]) + tuple(f"{f}_mcp" for f in FINGERS) + WEBS
                 + ("wrist_radial", "wrist_ulnar", "ulna_head"))
_JOINT_BONE = {"mcp": "phalanx-proximal", "pip": "phalanx-intermediate", "dip": "phalanx-distal",
               "ip": "phalanx-distal"}


def _bone(finger: str, part: str) -> str:
    return f"thumb-{_JOINT_BONE[part]}" if finger == "thumb" else f"{finger}-finger-{_JOINT_BONE[part]}"


def feature_points(skeleton: Skeleton, skin: np.ndarray) -> dict[str, np.ndarray]:
    """Name -> 3D position of the 26 source feature points (module docstring) on ``skin`` (N, 3)."""
    sk = skeleton
    out = {}
    for finger in FINGERS:
        distal = sk.index[_bone(finger, "dip")]
        u = sk.tail[distal] - sk.position[distal]
        u /= np.linalg.norm(u)
        near = skin[np.linalg.norm(skin - sk.tail[distal], axis=1) < 0.015]
        out[f"{finger}_tip"] = near[np.argmax((near - sk.position[distal]) @ u)]
        for part in (("mcp", "ip") if finger == "thumb" else ("mcp", "pip", "dip")):
            out[f"{finger}_{part}"] = sk.position[sk.index[_bone(finger, part)]].copy()
    pairs = zip(FINGERS[:-1], FINGERS[1:])
    for web, (a, b) in zip(WEBS, pairs):
        ba, bb = sk.index[_bone(a, "mcp")], sk.index[_bone(b, "mcp")]
        reach = 0.35 if a != "thumb" else 0.0
        middle = 0.5 * (sk.position[ba] + reach * (sk.tail[ba] - sk.position[ba])
                        + sk.position[bb] + reach * (sk.tail[bb] - sk.position[bb]))
        out[web] = skin[np.argmin(np.linalg.norm(skin - middle, axis=1))]
    wrist = sk.position[sk.index["wrist"]]
    band = skin[np.abs(skin[:, 2] - wrist[2]) < 0.006]
    lateral = band[:, 1]
    out["wrist_radial"] = band[np.argmin(lateral)]
    out["wrist_ulnar"] = band[np.argmax(lateral)]
    ulna = sk.asset_mesh("ulna")
    head = ulna[np.argmin(ulna[:, 2])]
    dorsal = skin[(skin - head) @ PALM_NORMAL < 0.0]
    out["ulna_head"] = dorsal[np.argmin(np.linalg.norm(dorsal - head, axis=1))]
    return {name: out[name] for name in FEATURE_NAMES}
