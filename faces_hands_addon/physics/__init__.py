# SPDX-License-Identifier: GPL-3.0-or-later
"""Mass-spring physics (thesis 3.1.2 "Mass Spring Network", Fig. 3.4) and radial-basis warps.

``springs``    nodes, biphasic skin springs, attachment + mirrored springs, vectorised forces
``integrator`` Euler first step, then leapfrog Verlet with midpoint damping; the Gershgorin stability guard
``collision``  keeps skin nodes outside the bone surface (tangent half-spaces that move with the bones)
``rbf``        thin-plate style radial-basis warp with an affine part
"""
from .collision import BoneHalfSpaceGuard, CapBulge, SphereGuard
from .integrator import LeapfrogIntegrator, gershgorin_eigen_bound, stable_time_step
from .rbf import RBFWarp
from .springs import Attachments, SpringNetwork, SpringSet, biphasic_force

__all__ = ["Attachments", "BoneHalfSpaceGuard", "CapBulge", "LeapfrogIntegrator", "RBFWarp", "SpringNetwork",
           "SphereGuard", "SpringSet", "biphasic_force", "gershgorin_eigen_bound", "stable_time_step"]
