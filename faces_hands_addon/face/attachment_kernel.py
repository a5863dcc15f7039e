# SPDX-License-Identifier: GPL-3.0-or-later
"""The muscles' pull on the skin attachments per frame (:meth:`.attachment.AttachmentMap.add_muscle_pull`,
thesis 3.1.2 "Mass Spring Network", Fig. 3.4: skin nodes attached "to the closest points on the muscle")
as one compiled pass over the spread muscle matrix, for the live preview.

In numpy it is three sparse products (the muscle displacements, and the jaw-frame correction's two) plus
a few whole-array operations. The jaw-frame correction is linear in the jaw pose, so here it comes from
four products of the spread matrix taken once (:meth:`.attachment.AttachmentMap.jaw_pull_tables`) at O(N)
per frame, and only the displacements' product runs, one pass over the matrix. The numpy methods stay the
reference (same formulas; sums regrouped, which moves the result by rounding only). The rest positions
carried by the jaw and the anchor offsets turned with it (the other per-frame inputs of the attachment
targets, Fig. 3.4) are one pass each here too.
"""
from __future__ import annotations

__all__ = ["add_muscle_pull", "carry_rest", "turn_offsets"]


def add_muscle_pull(indptr, indices, data, displacement, rest_pull, ones_pull, carry_pull, carry_sum, rotation,
                    translation, jaw_weight, target):  # pragma: no cover - compiled
    """``target`` (N, 3) += S d + (S (m c) - w S m), with S the spread muscle matrix (CSR ``indptr``,
    ``indices``, ``data``), d the control points' ``displacement`` (P, 3), m their rest positions r moved
    by the jaw (R r + t - r: ``rotation`` 3x3, ``translation``), c their jaw carry and w the nodes'
    ``jaw_weight`` (:meth:`.attachment.AttachmentMap.jaw_frame_correction`: the node follows the muscle
    carried as far as the node is). S m = (S r) R^T + (S 1) t - S r from ``rest_pull`` = S r and
    ``ones_pull`` = S 1; S (m c) likewise from ``carry_pull`` = S (c r) and ``carry_sum`` = S c."""
    for i in range(target.shape[0]):
        pull0 = pull1 = pull2 = 0.0
        for k in range(indptr[i], indptr[i + 1]):
            j, weight = indices[k], data[k]
            pull0 += weight * displacement[j, 0]
            pull1 += weight * displacement[j, 1]
            pull2 += weight * displacement[j, 2]
        target[i, 0] += pull0
        target[i, 1] += pull1
        target[i, 2] += pull2
        for a in range(3):
            moved = (rest_pull[i, 0] * rotation[a, 0] + rest_pull[i, 1] * rotation[a, 1]
                     + rest_pull[i, 2] * rotation[a, 2]) + ones_pull[i] * translation[a] - rest_pull[i, a]
            own = (carry_pull[i, 0] * rotation[a, 0] + carry_pull[i, 1] * rotation[a, 1]
                   + carry_pull[i, 2] * rotation[a, 2]) + carry_sum[i] * translation[a] - carry_pull[i, a]
            target[i, a] += own - jaw_weight[i] * moved


def carry_rest(rest, rotation, translation, jaw_weight, out):  # pragma: no cover - compiled
    """:meth:`.attachment.AttachmentMap.carried` in one pass: ``out`` (N, 3) = r + w (R r + t - r) for the rest
    positions r (N, 3), the jaw's ``rotation`` R and ``translation`` t, and the nodes' ``jaw_weight`` w."""
    for i in range(rest.shape[0]):
        for a in range(3):
            moved = (rest[i, 0] * rotation[a, 0] + rest[i, 1] * rotation[a, 1] + rest[i, 2] * rotation[a, 2]
                     + translation[a])
            out[i, a] = rest[i, a] + jaw_weight[i] * (moved - rest[i, a])


def turn_offsets(offsets, rotation, jaw_weight, out):  # pragma: no cover - compiled
    """:meth:`.attachment.AttachmentMap.posed_offsets` in one pass: ``out`` (N, 3) = R o for the nodes the
    jaw carries more than half (``jaw_weight`` > 0.5), o elsewhere."""
    for i in range(offsets.shape[0]):
        if jaw_weight[i] > 0.5:
            for a in range(3):
                out[i, a] = (offsets[i, 0] * rotation[a, 0] + offsets[i, 1] * rotation[a, 1]
                             + offsets[i, 2] * rotation[a, 2])
        else:
            for a in range(3):
                out[i, a] = offsets[i, a]
