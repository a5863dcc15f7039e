# SPDX-License-Identifier: GPL-3.0-or-later
"""The fused substep kernel (thesis 3.1.2 "Mass Spring Network"): forces, attachments, damping and the
leapfrog update of :class:`~.integrator.LeapfrogIntegrator` in one compiled loop.

The numpy path of :mod:`.springs` / :mod:`.integrator` stays the reference and the fallback: it computes
every step as a chain of whole-array operations, each of which streams its temporaries through memory.
This kernel does the same arithmetic per spring and per node in one pass (biphasic law, guarded divisor,
zero-rest attachment pair ``c (anchor + mirror) - 2 c x``, exact damping factor ``exp(-2h)``, kick
``dt (1 - e^-2h) / 2h``, kinematic nodes held, attachment pull and driven nodes interpolated over the
substeps), compiled by numba; the bone/teeth half-space guard and the eye-sphere guard
(:mod:`.collision`) have compiled loops too. It agrees with the numpy path to rounding (summation order of the spring
forces differs; ``tests/engine/physics/test_physics_kernel.py`` requires 1e-9 m).

Compiled code is cached only in the folder :func:`set_cache_folder` names (the add-on passes its user
folder, ``bpy.utils.extension_path_user(...)/cache/numba``), never next to the installed sources; without
a folder the kernel is compiled in memory on first use. ``FH_PHYSICS_KERNEL=numpy`` selects the reference
path; numba missing or failing to import (e.g. Intel macOS, for which numba ships no wheels) selects it
too, silently.

One choice for every process (``"auto"``, the default backend): the kernel wherever numba is usable,
whatever the network's size, the take's length or what ran before in the process. The two loops agree only
to rounding, so a rule that chose by size, length or session (the rule before this one: numpy for small
networks and short takes until something loaded the kernel) gave the same line two different files in one
process, and a farm's bytes depended on which rows a worker had run first. Loading the cached kernel is paid
once per process; on a short ``./fh speak`` line it costs no measurable time (the face-only head: 4.07 s
with the old rule's numpy, 4.05 s with the kernel; the character: 6.9 s and 6.1 s). ``FH_PHYSICS_KERNEL=numpy``
(or a caller's backend ``"numpy"``) keeps the reference path.
"""
from __future__ import annotations

import math
import os
import threading
import time
from pathlib import Path

__all__ = ["set_cache_folder", "cache_folder", "available", "substep_kernel", "guard_kernels",
           "compile_seconds", "ENV_VARIABLE", "loaded", "BACKENDS", "compiled", "largest_move", "numba_usable"]

#: environment variable: "numpy" forces the reference path; unset (or "numba"): the kernel wherever numba is usable
ENV_VARIABLE = "FH_PHYSICS_KERNEL"
#: "auto" and "numba": the kernel wherever numba is usable (one choice per process, module docstring)
BACKENDS = ("auto", "numba", "numpy")

_LOADING = threading.Lock()
_COMPILED: dict = {}
_STATE = {"folder": None, "kernel": None, "half_space": None, "sphere": None, "still_planes": None, "tried": False,
          "compile_s": None, "error": None}


def set_cache_folder(folder: str | os.PathLike | None) -> None:
    """Where numba may store compiled code (the extension's user folder); ``None``: compile in memory.
    Takes effect for a kernel not yet built in this process."""
    _STATE["folder"] = None if folder is None else Path(folder)


def cache_folder() -> Path | None:
    return _STATE["folder"]


def compile_seconds() -> float | None:
    """Wall time of the first call (numba import + compile or cache load), once it happened."""
    return _STATE["compile_s"]


def _substeps(x, v, force, s_start, s_end, rest, material, materials, has_yield,
              att_node, att_per_node, att_two_c, pull, start_pull, delta_pull, interp_pull,
              kin_index, start_driven, delta_driven, interp_driven,
              inverse_mass, decay, kick, free, dt, first, count, substeps, diff,
              scale):  # pragma: no cover - compiled
    """Substeps ``first .. first + count - 1`` of a frame of ``substeps`` (see the module docstring): the
    spring forces (:func:`_spring_forces`), the attachment pairs, then the leapfrog update. With
    ``att_per_node`` (attachment ``j`` is on node ``j`` for every node, as the face networks build them) the
    attachment loop reads no index (a loop the compiler vectorises; the same sums)."""
    nodes = x.shape[1]
    attached = att_node.shape[0]
    driven = kin_index.shape[0]
    for index in range(first, first + count):
        fraction = index / substeps
        if interp_pull:
            for c in range(3):
                for a in range(attached):
                    pull[c, a] = delta_pull[c, a] * fraction + start_pull[c, a]
        if interp_driven:
            for j in range(driven):
                k = kin_index[j]
                for c in range(3):
                    x[c, k] = start_driven[c, j] + fraction * delta_driven[c, j]
        _spring_forces(x, force, s_start, s_end, rest, material, materials, has_yield, diff, scale)
        if att_per_node:
            for c in range(3):
                for i in range(nodes):
                    force[c, i] += pull[c, i] - x[c, i] * att_two_c[i]
        else:
            for j in range(attached):
                k = att_node[j]
                for c in range(3):
                    force[c, k] += pull[c, j] - x[c, k] * att_two_c[j]
        for i in range(nodes):
            keep = free[i]
            mass_factor = inverse_mass[i]
            damp = decay[i]
            impulse = kick[i]
            for c in range(3):
                velocity = (v[c, i] * damp + (force[c, i] * mass_factor) * impulse) * keep
                v[c, i] = velocity
                x[c, i] += dt * velocity


def _spring_forces(x, force, s_start, s_end, rest, material, materials, has_yield, diff,
                   scale):  # pragma: no cover - compiled
    """The springs' forces on every node (``force`` (3, N), overwritten) in three passes over the scratch
    ``diff`` (3, S) and ``scale`` (S,): gather the edge vectors (a spring's three axes at once: its two
    node indices are read once, not once per axis), the biphasic ``f / l`` of every spring (a loop without
    gathers, which the compiler vectorises), then the forces scattered in spring order (the same sums, in
    the same order, as one pass). In the scatter the start node's sums stay in registers while consecutive
    springs share it (the network lists its springs by start node): the same additions in the same order,
    without a store and a reload per spring; any order of springs gives the same sums.

    A spring's constants come from its ``material`` row of ``materials`` (``SpringNetwork.kernel_materials``:
    soft constant, stiff extra, compression change, strain threshold, shortest-length ratio; the knee and
    the guarded divisor are formed here as the network forms them, the same bytes). A face has three
    materials: one byte a spring instead of five float64 arrays, so two settles side by side keep their
    springs in the shared cache. Up to four materials are picked by comparison (the loop stays vectorised);
    more are read from the table."""
    nodes = x.shape[1]
    springs = s_start.shape[0]
    for c in range(3):
        for i in range(nodes):
            force[c, i] = 0.0
    for s in range(springs):
        a = s_start[s]
        b = s_end[s]
        diff[0, s] = x[0, b] - x[0, a]
        diff[1, s] = x[1, b] - x[1, a]
        diff[2, s] = x[2, b] - x[2, a]
    if materials.shape[0] == 4:
        # the table read into locals first: the loop's stores could alias it, so it would be read again per spring
        soft0, soft1, soft2, soft3 = materials[0, 0], materials[1, 0], materials[2, 0], materials[3, 0]
        extra0, extra1, extra2, extra3 = materials[0, 1], materials[1, 1], materials[2, 1], materials[3, 1]
        yield0, yield1, yield2, yield3 = materials[0, 2], materials[1, 2], materials[2, 2], materials[3, 2]
        knee0, knee1, knee2, knee3 = materials[0, 3], materials[1, 3], materials[2, 3], materials[3, 3]
        ratio0, ratio1, ratio2, ratio3 = materials[0, 4], materials[1, 4], materials[2, 4], materials[3, 4]
        for s in range(springs):
            k = material[s]
            scale[s] = _biphasic(diff[0, s], diff[1, s], diff[2, s], rest[s], has_yield,
                                 _pick(k, soft0, soft1, soft2, soft3), _pick(k, extra0, extra1, extra2, extra3),
                                 _pick(k, yield0, yield1, yield2, yield3), _pick(k, knee0, knee1, knee2, knee3),
                                 _pick(k, ratio0, ratio1, ratio2, ratio3))
    else:
        for s in range(springs):
            k = material[s]
            scale[s] = _biphasic(diff[0, s], diff[1, s], diff[2, s], rest[s], has_yield, materials[k, 0],
                                 materials[k, 1], materials[k, 2], materials[k, 3], materials[k, 4])
    current = -1
    ax = ay = az = 0.0
    for s in range(springs):
        a = s_start[s]
        if a != current:
            if current >= 0:
                force[0, current] = ax
                force[1, current] = ay
                force[2, current] = az
            current = a
            ax = force[0, a]
            ay = force[1, a]
            az = force[2, a]
        b = s_end[s]
        fx = diff[0, s] * scale[s]
        fy = diff[1, s] * scale[s]
        fz = diff[2, s] * scale[s]
        ax += fx
        ay += fy
        az += fz
        if b == current:                       # a spring from a node to itself (none is ever built)
            ax -= fx
            ay -= fy
            az -= fz
        else:
            force[0, b] -= fx
            force[1, b] -= fy
            force[2, b] -= fz
    if current >= 0:
        force[0, current] = ax
        force[1, current] = ay
        force[2, current] = az


def _pick(k, first, second, third, fourth):  # pragma: no cover - compiled
    """Row ``k`` (0-3) of a four-row column, by comparison (vectorises, unlike an indexed read)."""
    return first if k == 0 else (second if k == 1 else (third if k == 2 else fourth))


def _biphasic(dx, dy, dz, rest, has_yield, k_soft, k_extra, k_yield, threshold,
              ratio):  # pragma: no cover - compiled
    """``f / l`` of one spring with edge vector ``(dx, dy, dz)`` (3.1.2 biphasic law, as
    ``SpringNetwork.forces``): knee ``threshold * rest``, divisor at least ``max(rest * ratio, 1e-12)``."""
    length = math.sqrt(dx * dx + dy * dy + dz * dz)
    stretch = length - rest
    over = stretch - threshold * rest
    extra = (over if over > 0.0 else 0.0) * k_extra
    if has_yield:
        extra = extra + (stretch if stretch < 0.0 else 0.0) * k_yield
    magnitude = stretch * k_soft + extra
    shortest = max(rest * ratio, 1e-12)
    return magnitude / (shortest if length < shortest else length)


def _half_space(x, v, nodes, point, normal, start_point, start_normal, interpolate, fraction,
                clearance, still, still_point, still_normal):  # pragma: no cover - compiled
    """:class:`~.collision.BoneHalfSpaceGuard` ``__call__``: planes slid from the start of the frame by
    ``fraction``, nodes projected out of the clearance band, their inward velocity removed. A plane that
    does not move this frame (``still[j]``) is read from ``still_point`` / ``still_normal``, which
    :func:`_still_planes` computed once for the frame with the same arithmetic (for such a plane the slid
    plane is the same at every fraction)."""
    for j in range(nodes.shape[0]):
        k = nodes[j]
        if interpolate and still[j]:
            px, py, pz = still_point[0, j], still_point[1, j], still_point[2, j]
            nx, ny, nz = still_normal[0, j], still_normal[1, j], still_normal[2, j]
        elif interpolate:
            px, py, pz, nx, ny, nz = _slid_plane(point, normal, start_point, start_normal, j, fraction)
        else:
            px, py, pz = point[0, j], point[1, j], point[2, j]
            nx, ny, nz = normal[0, j], normal[1, j], normal[2, j]
        depth = clearance[j] - ((x[0, k] - px) * nx + (x[1, k] - py) * ny + (x[2, k] - pz) * nz)
        if depth > 0.0:
            x[0, k] += nx * depth
            x[1, k] += ny * depth
            x[2, k] += nz * depth
            inward = v[0, k] * nx + v[1, k] * ny + v[2, k] * nz
            if inward < 0.0:
                v[0, k] -= nx * inward
                v[1, k] -= ny * inward
                v[2, k] -= nz * inward


def _slid_plane(point, normal, start_point, start_normal, j, fraction):  # pragma: no cover - compiled
    """Plane ``j`` slid from its start of the frame by ``fraction`` (point, then the normal renormalised):
    ``(px, py, pz, nx, ny, nz)``, for :func:`_half_space` and :func:`_still_planes` alike."""
    px = start_point[0, j] + fraction * (point[0, j] - start_point[0, j])
    py = start_point[1, j] + fraction * (point[1, j] - start_point[1, j])
    pz = start_point[2, j] + fraction * (point[2, j] - start_point[2, j])
    nx = start_normal[0, j] + fraction * (normal[0, j] - start_normal[0, j])
    ny = start_normal[1, j] + fraction * (normal[1, j] - start_normal[1, j])
    nz = start_normal[2, j] + fraction * (normal[2, j] - start_normal[2, j])
    size = math.sqrt(nx * nx + ny * ny + nz * nz)
    if size < 1e-12:
        size = 1e-12
    return px, py, pz, nx / size, ny / size, nz / size


def _still_planes(point, normal, start_point, start_normal, still, still_point, still_normal):  # pragma: no cover
    """For :func:`_half_space`: which planes are the same at the start and the end of the frame (``still``),
    and for those the slid plane (:func:`_slid_plane`; ``start + f (end - start)`` is ``start + f * 0``, the
    same for every fraction ``f`` in (0, 1]: 0.5 here)."""
    for j in range(point.shape[1]):
        same = True
        for c in range(3):
            if point[c, j] != start_point[c, j] or normal[c, j] != start_normal[c, j]:
                same = False
        still[j] = same
        if same:
            px, py, pz, nx, ny, nz = _slid_plane(point, normal, start_point, start_normal, j, 0.5)
            still_point[0, j], still_point[1, j], still_point[2, j] = px, py, pz
            still_normal[0, j], still_normal[1, j], still_normal[2, j] = nx, ny, nz


def _sphere(x, nodes, centre, radius, bulge, scale, peak, cap_deg, sag, slacken, rest, slack,
            fade):  # pragma: no cover - compiled
    """:class:`~.collision.SphereGuard` ``__call__``: nodes pushed out to ``radius`` from ``centre``, plus
    the :class:`~.collision.CapBulge` (``scale``, ``peak``, ``cap_deg``, ``sag``) when ``bulge``, less
    the ``slack`` of nodes near their ``rest`` place when ``slacken`` (the numpy path's arithmetic)."""
    for j in range(nodes.shape[0]):
        k = nodes[j]
        dx = x[0, k] - centre[0]
        dy = x[1, k] - centre[1]
        dz = x[2, k] - centre[2]
        dist = math.sqrt(dx * dx + dy * dy + dz * dz)
        if dist < 1e-12:
            dist = 1e-12
        wanted = radius
        if bulge:
            ahead = -(dy / dist)
            ahead = -1.0 if ahead < -1.0 else (1.0 if ahead > 1.0 else ahead)
            angle = math.degrees(math.acos(ahead))
            cap = peak * math.cos(math.radians(angle) * 90 / cap_deg) ** 2 if angle < cap_deg else 0.0
            wanted = wanted + (scale * cap + sag[j])
        if slacken:
            mx = x[0, k] - rest[0, j]
            my = x[1, k] - rest[1, j]
            mz = x[2, k] - rest[2, j]
            near = 1.0 - math.sqrt(mx * mx + my * my + mz * mz) / fade
            near = 0.0 if near < 0.0 else (1.0 if near > 1.0 else near)
            wanted = wanted - slack[j] * near
        factor = wanted / dist
        if factor > 1.0:
            x[0, k] = centre[0] + dx * factor
            x[1, k] = centre[1] + dy * factor
            x[2, k] = centre[2] + dz * factor


def largest_move(x, previous):  # pragma: no cover - compiled
    """The largest ``|x - previous|`` over every coordinate (m), and ``previous`` set to ``x``: a settle's
    test for rest (:meth:`..face.rig.FaceRig.settle`) in one pass instead of three. Exact (a maximum of
    exact differences), so the numpy expression gives the same number."""
    largest = 0.0
    for c in range(x.shape[0]):
        for i in range(x.shape[1]):
            step = abs(x[c, i] - previous[c, i])
            if step > largest:
                largest = step
            previous[c, i] = x[c, i]
    return largest


def loaded() -> bool:
    """Has this process already built (or loaded) the kernel? (A question for tests and benchmarks: a
    computation asks :func:`compiled` or :func:`substep_kernel`, which load it, so its path never depends on
    what ran before.)"""
    return _STATE["kernel"] is not None


def available() -> bool:
    """Is the compiled kernel usable here (numba importable and not switched off)? Loads it on the first
    question, as :func:`compiled` does for every compiled helper (lids, muscles, attachments, guards, hand
    joints): each takes the same path on a process's first frame as on its later ones."""
    return substep_kernel() is not None


def substep_kernel():
    """The compiled :func:`_substeps` (built on first call), or ``None`` when the numpy path must run."""
    if os.environ.get(ENV_VARIABLE, "").lower() == "numpy":
        return None
    if _STATE["tried"]:
        return _STATE["kernel"]
    with _LOADING:                        # settles in other threads wait for the kernel, never take the numpy
        if _STATE["tried"]:               # path while it loads (their results would depend on the timing)
            return _STATE["kernel"]
        compiled = _load()
        _STATE["tried"] = True
        return compiled


def _load():
    """Build or load the kernel (``substep_kernel`` holds the lock); None when the numpy path must run."""
    started = time.perf_counter()
    folder = _STATE["folder"]
    try:
        numba = _numba_in_cache_folder()
        jit = numba.njit(cache=folder is not None, nogil=True, boundscheck=False)
        # IEEE division (no zero-divisor check, the guarded divisor is >= 1e-12): lets the spring loop vectorise
        fast = numba.njit(cache=folder is not None, nogil=True, boundscheck=False, error_model="numpy")
        inline = numba.njit(nogil=True, boundscheck=False, error_model="numpy", inline="always")
        law = {"_pick": inline(_pick), "_biphasic": inline(_biphasic)}
        compiled = fast(_calling(_substeps, {"_spring_forces": fast(_calling(_spring_forces, law))}))
        slid_plane = {"_slid_plane": jit(_slid_plane)}
        _STATE["half_space"], _STATE["sphere"] = jit(_calling(_half_space, slid_plane)), jit(_sphere)
        _STATE["still_planes"] = jit(_calling(_still_planes, slid_plane))
        _warm_up(compiled)
    except Exception as error:            # no numba, an unsupported numpy, a broken LLVM: the numpy path
        _STATE["error"] = f"{type(error).__name__}: {error}"
        _STATE["kernel"] = None
        return None
    _STATE["kernel"] = compiled
    _STATE["compile_s"] = time.perf_counter() - started
    return compiled


def guard_kernels():
    """``(half_space, sphere, still_planes)`` compiled guard loops, or ``None`` when the numpy path must run."""
    if substep_kernel() is None:
        return None
    return _STATE["half_space"], _STATE["sphere"], _STATE["still_planes"]


def _numba_in_cache_folder():
    """numba, its compiled code cached in :func:`set_cache_folder`'s folder (if one is set)."""
    folder = _STATE["folder"]
    if folder is not None:
        folder.mkdir(parents=True, exist_ok=True)
        os.environ.setdefault("NUMBA_CACHE_DIR", str(folder))
    import numba
    if folder is not None:
        numba.config.CACHE_DIR = str(folder)
    return numba


def numba_usable() -> bool:
    """Is numba importable here and not switched off? Asked without loading the substep kernel (the weight
    fit of a retarget needs numba, not the kernel); the answer depends on the environment alone."""
    if os.environ.get(ENV_VARIABLE, "").lower() == "numpy":
        return False
    if "numba" not in _STATE:
        try:
            import numba  # noqa: F401
            _STATE["numba"] = True
        except Exception:                 # not installed, or an unsupported numpy
            _STATE["numba"] = False
    return _STATE["numba"]


def compiled(function, *helpers, standalone: bool = False):
    """``function`` compiled as the substep kernel is (numba, ``nogil``, cached in the same folder), once
    per process, or ``None`` where the numpy path must run (numba missing or switched off). For other
    engine loops that earn a compiled version (e.g. the weight fit of :mod:`..anim.weights`). ``helpers``:
    module-level functions ``function`` calls, compiled first and called compiled. ``standalone``: without
    loading the substep kernel (a loop that needs no physics, e.g. the weight fit: it spares the load)."""
    if standalone:
        if not numba_usable():
            return None
        _numba_in_cache_folder()
    elif substep_kernel() is None:
        return None
    key = (function.__module__, function.__qualname__)
    if key not in _COMPILED:
        import numba
        names = {helper.__name__: compiled(helper, standalone=standalone) for helper in helpers}
        if names:
            function = _calling(function, names)
        _COMPILED[key] = numba.njit(cache=_STATE["folder"] is not None, nogil=True, boundscheck=False)(function)
    return _COMPILED[key]


def _calling(function, names: dict):
    """``function`` with the module-level names ``names`` (their compiled versions) in its globals."""
    import types
    copy = types.FunctionType(function.__code__, {**function.__globals__, **names}, function.__name__,
                              function.__defaults__, function.__closure__)
    copy.__qualname__, copy.__module__ = function.__qualname__, function.__module__
    return copy


def _warm_up(compiled) -> None:
    """Compile (or load from the cache) for the argument types the integrator passes."""
    import numpy as np
    f3 = np.zeros((3, 2))
    one = np.zeros(2)
    index = np.zeros(1, np.int64)
    small = np.zeros(1, np.int32)               # the integrator passes its node indices as int32
    compiled(f3.copy(), f3.copy(), f3.copy(), small, small + 1, one[:1], np.zeros(1, np.uint8), np.zeros((4, 5)),
             False, np.zeros(0, np.int32), False, np.zeros(0), np.zeros((3, 0)), np.zeros((3, 0)),
             np.zeros((3, 0)), False, np.zeros(0, np.int32), np.zeros((3, 0)), np.zeros((3, 0)), False,
             one + 1.0, one + 1.0, one, one + 1.0, 0.01, 1, 1, 1, np.zeros((3, 1)), np.zeros(1))
    half_space, sphere, still_planes = _STATE["half_space"], _STATE["sphere"], _STATE["still_planes"]
    still = np.zeros(1, np.bool_)
    still_planes(f3[:, :1].copy(), f3[:, :1] + 1.0, f3[:, :1].copy(), f3[:, :1] + 1.0, still, f3[:, :1].copy(),
                 f3[:, :1].copy())
    half_space(f3.copy(), f3.copy(), index, f3[:, :1].copy(), f3[:, :1] + 1.0, f3[:, :1].copy(),
               f3[:, :1] + 1.0, True, 0.5, one[:1], still, f3[:, :1].copy(), f3[:, :1].copy())
    sphere(f3.copy(), index, np.zeros(3), 0.01, True, 0.01, 0.03, 30.0, one[:1], True, f3[:, :1].copy(), one[:1],
           0.001)
