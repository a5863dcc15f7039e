# SPDX-License-Identifier: GPL-3.0-or-later
"""Time integration of the mass-spring network with a stability guard (thesis 3.1.2 "Mass Spring Network").

Equation of motion per node: ``m x'' + gamma x' - F(x) - F_ext = 0``. As in MEDUSA, the first time step is
an Euler step and every later one a leapfrog Verlet step [AT89]. Within the leapfrog velocity update the
damping term is integrated exactly over the step (velocity factor ``exp(-gamma dt / m)``, force impulse
weighted by ``(1 - exp(-2h)) / 2h`` with ``h = gamma dt / 2m``); for the linear test equation
``x'' + (gamma/m) x' + omega^2 x = 0`` this is stable whenever
``omega^2 dt^2 (1 - e^-2h) / 2h < 2 (1 + e^-2h)`` -- that is ``omega dt < 2`` without damping, and a
*larger* step the heavier the damping (the classic overdamped limit ``dt < 2 gamma / (m omega^2)``).
Velocities never flip sign from one step to the next, however heavy the damping.

The guard picks the substep: a Gershgorin bound on the largest eigenvalue of ``M^-1 K``, where ``K`` uses
every spring's *stiff* biphasic branch (the largest tangent stiffness it can ever have), is put into the
damped stability condition above with the *lightest* damping of any node, and the largest substep that
satisfies it with a safety margin is used. If a frame would need more than ``max_substeps`` substeps (very
stiff settings), the integrator scales all masses up for that frame instead (mass scaling: the same
equilibrium, reached more slowly), so every parameter value the UI allows gives a finite, non-growing
simulation at a bounded cost. A last check after every frame restores the previous state if anything
became non-finite anyway.

The substeps run in the fused numba kernel of :mod:`.kernel` wherever numba is usable (``backend``
``"auto"``, the default, the same choice in every process: :mod:`.kernel`'s docstring); the numpy code here
is the reference and the fallback (``backend = "numpy"``).
"""
from __future__ import annotations

import math
from typing import Callable

import numpy as np

from ..core.errors import UserError
from . import kernel
from .springs import SpringNetwork

__all__ = ["gershgorin_eigen_bound", "stable_time_step", "LeapfrogIntegrator"]

#: fraction of the theoretical stability limit actually used
SAFETY = 0.9


def gershgorin_eigen_bound(network: SpringNetwork) -> np.ndarray:
    """Per-node Gershgorin row sums of ``M^-1 K`` (1/s^2), ``K`` at the stiff biphasic branch.

    A spring's 3x3 stiffness block has norm <= max(df/dl, |f/l|) <= k_stiff (the force law clamps the
    divisor so compression never exceeds it); it appears once on the diagonal and once off it, hence
    ``2 * k_stiff`` per incident spring. Each attachment pair (spring + mirrored spring) adds
    ``2 * stiffness`` on the diagonal only, its ends being kinematic.
    """
    count = network.node_count
    springs = network.springs
    row = np.zeros(count)
    if springs.count:
        k = 2.0 * springs.max_stiffness
        row += np.bincount(springs.start, k, minlength=count)
        row += np.bincount(springs.end, k, minlength=count)
    att = network.attachments
    if att.count:
        row[att.node] += 2.0 * att.stiffness
    return row / network.masses


def _damped_stability(eigen: float, damping_rate: float, dt: np.ndarray) -> np.ndarray:
    """``g(dt)`` of the damped leapfrog stability condition ``g < 1`` (see the module docstring)."""
    h = 0.5 * damping_rate * dt
    decay = np.exp(-2.0 * h)
    impulse = np.where(h > 1e-12, (1.0 - decay) / np.maximum(2.0 * h, 1e-300), 1.0 - h)
    return eigen * dt * dt * impulse / (2.0 * (1.0 + decay))


def stable_time_step(network: SpringNetwork, damping: np.ndarray, safety: float = SAFETY) -> float:
    """Largest substep the guard allows for ``network`` with per-node ``damping`` gamma (kg/s).

    Solves ``g(dt) = safety^2`` for the Gershgorin eigenvalue bound and the lightest relative damping
    ``min(gamma / m)`` of all free nodes (g grows monotonically with dt; bisection in log space).
    """
    free = ~network.kinematic
    if not np.any(free):
        return math.inf
    eigen = float(np.max(gershgorin_eigen_bound(network)[free]))
    if eigen <= 0:
        return math.inf
    gamma = np.broadcast_to(np.asarray(damping, np.float64), free.shape)[free]
    rate = float(np.min(gamma / network.masses[free]))
    low, high = 0.0, 2.0 / math.sqrt(eigen)
    target = safety * safety
    while _damped_stability(eigen, rate, np.array(high)) < target:   # heavy damping allows more
        low, high = high, high * 2.0
        if high > 1e6:
            return math.inf
    for _ in range(60):
        middle = 0.5 * (low + high)
        if _damped_stability(eigen, rate, np.array(middle)) < target:
            low = middle
        else:
            high = middle
    return low


def _held(att, anchor: np.ndarray | None, mirror: np.ndarray | None) -> bool:
    """Are the frame's attachment targets where the attachments already are (a settle, a held pose)? Then
    nothing needs interpolating over the substeps: every interpolated value would equal the current one."""
    return ((anchor is None or np.array_equal(anchor, att.anchor))
            and (mirror is None or np.array_equal(mirror, att.mirror)))


class LeapfrogIntegrator:
    """Euler first step, then leapfrog Verlet with midpoint damping (3.1.2), substepped by the guard.

    ``damping`` is the per-node friction factor gamma (kg/s). Kinematic nodes of the network never move
    by integration; :meth:`advance` moves them (and the attachment anchors) linearly from their current
    positions to the given targets over the substeps of a frame, so a driven node never jumps.
    """

    def __init__(self, network: SpringNetwork, damping: float | np.ndarray, safety: float = SAFETY,
                 max_substeps: int = 100) -> None:
        damping = np.broadcast_to(np.asarray(damping, np.float64), (network.node_count,)).copy()
        if np.any(~np.isfinite(damping)) or np.any(damping < 0):
            raise UserError("damping must be a finite value >= 0")
        if not 0 < safety <= 1:
            raise UserError("the stability safety factor must lie in (0, 1]")
        self.network = network
        self.damping = damping
        self.safety = safety
        self.max_substeps = max(1, int(max_substeps))
        self.mass_scale = 1.0        # > 1 only while a frame would need more than max_substeps
        self.velocity = np.zeros_like(network.positions)   # v at t (before start) or at t - dt/2
        self.started = False
        self.time = 0.0
        self._free = (~network.kinematic).astype(np.float64)
        self._inverse_mass = self._free / network.masses
        self._accel = np.empty_like(network.positions)
        self._factor_cache = None
        self._spring_scratch = None          # the fused kernel's per-spring scratch (diff, scale)
        self._kernel_index = None            # the fused kernel's int32 spring/attachment indices, see _indices
        #: "auto" or "numba" (the fused kernel of .kernel wherever numba is usable) or "numpy" (the reference path)
        self.backend = "auto"
        self.refresh()

    def refresh(self) -> None:
        """Recompute the guard's substep after masses, stiffness, damping or kinematic flags changed."""
        self._factor_cache = None
        self._free = (~self.network.kinematic).astype(np.float64)
        self._inverse_mass = self._free / self.network.masses
        self._no_index = np.zeros(0, np.int32)
        self.max_substep = stable_time_step(self.network, self.damping, self.safety)
        free = ~self.network.kinematic
        self._eigen = float(np.max(gershgorin_eigen_bound(self.network)[free])) if np.any(free) else 0.0
        self._rate = float(np.min(self.damping[free] / self.network.masses[free])) if np.any(free) else 0.0

    def mass_scale_for(self, dt: float) -> float:
        """Smallest uniform mass factor (>= 1) that makes a substep of ``dt`` satisfy the guard."""
        scale = 1.0
        target = self.safety * self.safety
        while _damped_stability(self._eigen / scale, self._rate / scale, np.array(dt)) > target:
            scale *= 1.1
        return scale

    def substeps_for(self, frame_dt: float) -> int:
        """Number of equal substeps the guard needs for one frame of length ``frame_dt`` (s), before the
        ``max_substeps`` cap (see :meth:`advance`)."""
        if not (frame_dt > 0 and math.isfinite(frame_dt)):
            raise UserError("the frame time step must be a positive number of seconds")
        if not math.isfinite(self.max_substep):
            return 1
        return max(1, math.ceil(frame_dt / self.max_substep - 1e-9))

    def _factors(self, dt: float):
        """Per-node factors of a substep of ``dt`` (cached: a frame's substeps all have the same length)."""
        key = (dt, self.mass_scale, self.started)
        if self._factor_cache is None or self._factor_cache[0] != key:
            inverse_mass = self._inverse_mass if self.mass_scale == 1.0 else self._inverse_mass / self.mass_scale
            h = (0.5 * dt) * self.damping * inverse_mass            # gamma dt / (2m); 0 on kinematic nodes
            if not self.started:
                # Euler start over half a step, v(dt/2) = v(0) + dt/2 (F - gamma v(0)) / m, damping exact
                h *= 0.5
                dt_kick = 0.5 * dt
            else:
                dt_kick = dt
            decay = np.exp(-2.0 * h)
            impulse = np.divide(1.0 - decay, 2.0 * h, out=np.ones_like(h), where=h > 1e-12)
            self._factor_cache = (key, inverse_mass, decay, dt_kick * impulse)
        return self._factor_cache[1:]

    def step(self, dt: float) -> None:
        """One substep of length ``dt``: Euler if it is the first, leapfrog Verlet afterwards (3.1.2)."""
        net = self.network
        x, v, accel = net.positions, self.velocity, self._accel
        force = net.forces(x)
        inverse_mass, decay, kick = self._factors(dt)
        self.started = True
        np.multiply(force, inverse_mass, out=accel)
        # leapfrog: v(t+dt/2) = e^-2h v(t-dt/2) + dt F/m (1 - e^-2h)/2h  (exact for the damping term)
        v *= decay
        accel *= kick
        v += accel
        v *= self._free
        x += dt * v
        self.time += dt

    def advance(self, frame_dt: float, anchor: np.ndarray | None = None, mirror: np.ndarray | None = None,
                driven: np.ndarray | None = None,
                constraint: Callable[[np.ndarray, np.ndarray, float], None] | None = None,
                constraint_every: int = 1) -> int:
        """Simulate one frame; returns the number of substeps used.

        ``anchor``/``mirror`` (3, A) are the attachment targets at the end of the frame and ``driven``
        (3, N) the kinematic node positions (only kinematic columns are read); all are interpolated over the
        substeps. ``constraint(x, v, fraction)`` (e.g. the skull guard) runs after every
        ``constraint_every``-th substep and always after the last one.
        """
        net = self.network
        att = net.attachments
        needed = self.substeps_for(frame_dt)
        substeps = min(needed, self.max_substeps)
        dt = frame_dt / substeps
        # mass scaling when capped (same equilibrium, slower motion); 1 whenever the cap is not hit
        scale = 1.0 if substeps == needed else self.mass_scale_for(dt)
        if scale != self.mass_scale:
            self.velocity *= math.sqrt(self.mass_scale / scale)      # keeps the kinetic energy
            self.mass_scale = scale
        backup_x = net.positions.copy()
        moving = (anchor is not None or mirror is not None) and not _held(att, anchor, mirror)
        if moving:
            end_anchor = att.anchor.copy() if anchor is None else np.asarray(anchor, np.float64)
            end_mirror = att.mirror.copy() if mirror is None else np.asarray(mirror, np.float64)
        fast = moving and net.zero_rest_attachments
        if fast:
            start_pull = net.attachment_pull.copy()
            delta_pull = (end_anchor + end_mirror) * att.stiffness - start_pull
        elif moving:
            start_anchor, start_mirror = att.anchor.copy(), att.mirror.copy()
        kin = net.kinematic
        start_driven = net.positions[:, kin].copy() if driven is not None else None
        every = max(1, int(constraint_every))
        compiled = self._kernel()
        if compiled is not None and net.zero_rest_attachments:
            self._advance_fused(compiled, dt, substeps, fast, start_pull if fast else None,
                                delta_pull if fast else None, driven, start_driven, constraint, every)
            substeps_done = True
        else:
            substeps_done = False
        for index in range(1, 0 if substeps_done else substeps + 1):
            fraction = index / substeps
            if fast:
                np.multiply(delta_pull, fraction, out=net.attachment_pull)
                net.attachment_pull += start_pull
            elif moving:
                np.add(start_anchor, fraction * (end_anchor - start_anchor), out=att.anchor)
                np.add(start_mirror, fraction * (end_mirror - start_mirror), out=att.mirror)
            if driven is not None:
                net.positions[:, kin] = start_driven + fraction * (driven[:, kin] - start_driven)
            self.step(dt)
            if constraint is not None and (index % every == 0 or index == substeps):
                constraint(net.positions, self.velocity, fraction)
        if moving:
            net.set_attachment_targets(end_anchor, end_mirror)
        if not math.isfinite(float(net.positions.sum() + self.velocity.sum())):
            net.positions[...] = backup_x          # fail-safe; the guard should make this unreachable
            self.velocity[...] = 0.0
            self.started = False
        return substeps

    def _kernel(self):
        """The fused numba kernel (:mod:`.kernel`) if this integrator may use it, else ``None``."""
        return None if self.backend == "numpy" else kernel.substep_kernel()

    def _advance_fused(self, compiled, dt: float, substeps: int, fast: bool, start_pull, delta_pull,
                       driven, start_driven, constraint, every: int) -> None:
        """The substeps of :meth:`advance` in the fused kernel, in runs between two guard calls."""
        net = self.network
        sp = net.springs
        att = net.attachments
        empty3 = np.zeros((3, 0))
        if fast:
            start_pull = np.ascontiguousarray(start_pull)
            delta_pull = np.ascontiguousarray(delta_pull)
        else:
            start_pull = delta_pull = empty3
        if driven is not None:
            kin_index = np.flatnonzero(net.kinematic).astype(np.int32)      # as the numpy path reads them
            delta_driven = np.ascontiguousarray(np.asarray(driven, np.float64)[:, kin_index] - start_driven)
            start_driven = np.ascontiguousarray(start_driven)
        else:
            kin_index, start_driven, delta_driven = self._no_index, empty3, empty3
        if self._spring_scratch is None or self._spring_scratch[1].shape[0] != sp.count:
            self._spring_scratch = (np.empty((3, sp.count)), np.empty(sp.count))
        start, end, att_node, att_per_node = self._indices()
        index = 1
        while index <= substeps:
            run_end = min(substeps, ((index - 1) // every + 1) * every) if constraint is not None else substeps
            if not self.started:
                run_end = index                      # the Euler start has its own factors
            inverse_mass, decay, kick = self._factors(dt)
            self.started = True
            compiled(net.positions, self.velocity, net.force, start, end, sp.rest, *net.kernel_materials,
                     net._has_yield, att_node, att_per_node, net._att_two_c,
                     net.attachment_pull, start_pull, delta_pull, fast, kin_index, start_driven,
                     delta_driven, driven is not None, inverse_mass, decay, kick, self._free, dt, index,
                     run_end - index + 1, substeps, *self._spring_scratch)
            for _ in range(run_end - index + 1):
                self.time += dt
            if constraint is not None and (run_end % every == 0 or run_end == substeps):
                constraint(net.positions, self.velocity, run_end / substeps)
            index = run_end + 1

    def _indices(self):
        """The springs' ``start``/``end`` and the attachments' ``node`` as int32 for the fused kernel (half
        the bytes its gathers and scatters stream; same values), and whether attachment ``j`` is on node
        ``j`` for every node (the kernel's attachment loop then reads no index); rebuilt whenever the
        network's arrays are replaced."""
        sp, att = self.network.springs, self.network.attachments
        cached = self._kernel_index
        if cached is None or cached[0] is not sp.start or cached[1] is not sp.end or cached[2] is not att.node:
            node = np.asarray(att.node)
            per_node = len(node) == self.network.node_count and np.array_equal(node, np.arange(len(node)))
            self._kernel_index = cached = (sp.start, sp.end, att.node,
                                           *(np.ascontiguousarray(a, np.int32) for a in (sp.start, sp.end, att.node)),
                                           bool(per_node))
        return cached[3:]

    def kinetic_energy(self) -> float:
        masses = self.network.masses * self.mass_scale
        return float(0.5 * np.sum(masses * np.einsum("ij,ij->j", self.velocity, self.velocity)))
