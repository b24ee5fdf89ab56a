"""Compiled kernels of the simulated pad: penetration of the sub-tactel samples into the scene's
objects, tactel forces, foam spread, characteristic, noise and quantisation, and the contact
wrench and stiffness a compliant arm steps against.

numba ``nopython`` versions of :class:`tactile_bt.sim.pad.SensorModel`'s hot path, with the
objects' signed distances and ray depths (:mod:`tactile_bt.sim.objects`,
:mod:`tactile_bt.sim.shapes`, :mod:`tactile_bt.sim.mesh_object`) written out per shape: the same
formulas, evaluated point by point instead of as numpy array operations.  ``tests/oracles_sim.py``
keeps the numpy implementation of the pad they replaced, and ``tests/perception/test_kernels.py`` checks the
two against each other (and every shape against its numpy ``depth`` and ``sdf``).

:class:`tactile_bt.sim.pad.SensorModel` calls three kernels: :func:`pad_contact` (the forces,
wrench and stiffness at a pose), :func:`foam_spread` and :func:`raw_counts`; the compliant arm's
step (:func:`tactile_bt.robot.kernels.arm_step`) alternates with :func:`pad_contact`, from Python
(:class:`tactile_bt.robot.stepping.ArmStepper`).  numba
links and optimises a kernel's whole call tree into its machine code, so the kernels Python
calls are the only ones that link the shapes' functions, and none links another's tree.  Their
arguments always have the same types (float64 and int64 C arrays, writable), so each is
compiled (and cached on disk) once.

Objects
-------
Every object is a row of the layout :data:`OBJ` (:func:`pack_objects`): its shape code, whether
its pose is the identity, the stiffness of one sample spring, its rotation and position, its
world bounds, and the shape's parameters; the signed-distance grids of cables and meshes are
concatenated in one array.  A shape gives its code and parameters by ``kernel_shape()``: the
table, cable, box, sphere and cylinder have branches of their own here; any other shape (meshes,
the torus, a shape a plugin registers) is read through a signed-distance grid, the
``SHAPE_MESH`` branch (:mod:`tactile_bt.sim.sdf_grid`).  The pad's other records (:data:`PAD`,
:data:`BROAD`, :data:`LAST`, :data:`JOB`) are laid out the same way, by
:class:`~tactile_bt.robot.layout.Layout`.

:func:`pad_contact` runs in stages, each a helper inlined into it: the broad phase, the
samples' depths per object, their tactel forces and moments, the springs' wrench and
stiffness.

Layer: sim.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from tactile_bt.robot.kernels import CONTACT, INLINE, OPTS
from tactile_bt.robot.layout import Layout

__all__ = [
    "SHAPE_TABLE",
    "SHAPE_CABLE",
    "SHAPE_BOX",
    "SHAPE_SPHERE",
    "SHAPE_CYLINDER",
    "SHAPE_MESH",
    "OBJ",
    "PAD",
    "BROAD",
    "LAST",
    "JOB",
    "OBJ_SIZE",
    "PAD_SIZE",
    "pack_objects",
    "local_sdf",
    "local_depth",
    "to_local",
    "pad_contact",
    "foam_spread",
    "raw_counts",
]

#: Shape codes of :func:`pack_objects`.
SHAPE_TABLE, SHAPE_CABLE, SHAPE_BOX, SHAPE_SPHERE, SHAPE_CYLINDER, SHAPE_MESH = 0, 1, 2, 3, 4, 5
#: An object's row (:func:`pack_objects`): shape code, identity pose, stiffness of one sample
#: spring (N/m), rotation (row-major) and position of its pose, world bounds (m), and the
#: shape's parameters (``kernel_shape()``).
OBJ = Layout("object", ("code", 1), ("identity", 1), ("spring", 1), ("R", (3, 3)), ("t", 3), ("bounds_lo", 3),
             ("bounds_hi", 3), ("params", 13))
F_CODE, F_IDENT, F_SCALE, F_R, F_T, F_BLO, F_BHI, F_P = map(OBJ.offset, OBJ.fields)
#: Numbers per object row.
OBJ_SIZE = OBJ.size
# Where the grid of a cable and a mesh is described in its parameters: offset, shape.
CABLE_GRID, MESH_GRID = F_P + 5, F_P + 8
#: The pad's numbers: tactel reach (m), broad-phase margin (m), noise (counts, relative), ADC
#: maximum (counts).
PAD = Layout("pad", ("reach", 1), ("margin", 1), ("noise", 1), ("noise_relative", 1), ("adc_max", 1))
PF_REACH, PF_MARGIN, PF_NOISE, PF_NOISE_REL, PF_ADC = map(PAD.offset, PAD.fields)
#: Numbers of the pad's record.
PAD_SIZE = PAD.size
#: The broad phase's state: valid, and the pad corners (world, m) it was made for.
BROAD = Layout("broad phase", ("valid", 1), ("corners", (4, 3)))
B_VALID, B_CORNERS = map(BROAD.offset, BROAD.fields)
#: Length of the broad phase's state.
BROAD_SIZE = BROAD.size
#: The last evaluation: valid, pose (4x4), wrench and stiffness (the 42 numbers of
#: :data:`tactile_bt.robot.kernels.CONTACT`), deepest penetration (m).
LAST = Layout("last evaluation", ("valid", 1), ("T", (4, 4)), ("wrench", 6), ("stiffness", (6, 6)), ("deepest", 1))
LAST_VALID, LAST_T, LAST_W, LAST_K, LAST_DEEPEST = map(LAST.offset, LAST.fields)
#: Length of the last evaluation's record.
LAST_SIZE = LAST.size
#: What :func:`pad_contact` is asked for (non-zero: yes): the tactel forces, the wrench and
#: stiffness; and where it puts the deepest penetration (m).
JOB = Layout("job", ("forces", 1), ("contact", 1), ("deepest", 1))
J_FORCES, J_CONTACT, J_DEEPEST = map(JOB.offset, JOB.fields)
#: Numbers of the contact record (wrench and stiffness) :func:`pad_contact` writes.
CONTACT_SIZE = CONTACT.size
if LAST.offset("stiffness") != LAST.end("wrench") or CONTACT_SIZE != LAST.end("stiffness") - LAST_W:
    raise AssertionError("the last evaluation must hold the wrench and stiffness as one contact record")


def pack_objects(objects, foam_stiffness: float, tactel_area: float, samples: int) -> tuple[np.ndarray, np.ndarray]:
    """The objects as the kernels read them: ``(rows, grids)``.

    Each object's ``kernel_shape()`` gives ``(code, parameters, grid or None)``; the stiffness
    of one sample spring is the object's per-area stiffness in series with the foam's, times
    the area of one sample (:class:`tactile_bt.sim.pad.SensorModel`).
    """
    rows = np.zeros((max(len(objects), 1), OBJ_SIZE))
    grids = []
    offset = 0
    for i, obj in enumerate(objects):
        shape = getattr(obj, "kernel_shape", None)
        if shape is None:
            raise TypeError(f"{type(obj).__name__} has no compiled contact model (kernel_shape)")
        code, params, grid = shape()
        params = list(params)
        if grid is not None:
            grid = np.asarray(grid, dtype=float)
            params += [float(offset), *map(float, grid.shape)]
            grids.append(grid.ravel())
            offset += grid.size
        if len(params) > OBJ.length("params"):
            raise ValueError(f"{type(obj).__name__}: too many shape parameters")
        k = 1.0 / (1.0 / foam_stiffness + 1.0 / obj.area_stiffness)
        lo, hi = obj.bounds()
        OBJ.pack(rows[i], code=code, identity=1.0 if obj.identity_pose else 0.0, spring=k * tactel_area / samples,
                 R=obj.pose[:3, :3], t=obj.pose[:3, 3], bounds_lo=lo, bounds_hi=hi)
        OBJ.view(rows[i], "params")[:len(params)] = params
    flat = np.concatenate(grids) if grids else np.zeros(1)
    return rows, np.ascontiguousarray(flat, dtype=float)


# ---------------------------------------------------------------------- shapes
@njit(**OPTS)
def _grid2(grids, off, n0, n1, c0, c1):
    """Bilinear interpolation of a grid ``(n0, n1)`` at ``off`` at coordinates (in cells) clamped
    into it (``scipy.ndimage.map_coordinates(order=1, mode="nearest")``)."""
    c0 = min(max(c0, 0.0), n0 - 1.0)
    c1 = min(max(c1, 0.0), n1 - 1.0)
    i0 = min(int(math.floor(c0)), n0 - 2)
    i1 = min(int(math.floor(c1)), n1 - 2)
    t0 = c0 - i0
    t1 = c1 - i1
    base = off + i0 * n1 + i1
    return ((1.0 - t0) * ((1.0 - t1) * grids[base] + t1 * grids[base + 1])
            + t0 * ((1.0 - t1) * grids[base + n1] + t1 * grids[base + n1 + 1]))


@njit(**OPTS)
def _grid3(grids, off, n0, n1, n2, c0, c1, c2):
    """Trilinear interpolation of a grid ``(n0, n1, n2)`` at ``off``, coordinates clamped."""
    c0 = min(max(c0, 0.0), n0 - 1.0)
    c1 = min(max(c1, 0.0), n1 - 1.0)
    c2 = min(max(c2, 0.0), n2 - 1.0)
    i0 = min(int(math.floor(c0)), n0 - 2)
    i1 = min(int(math.floor(c1)), n1 - 2)
    i2 = min(int(math.floor(c2)), n2 - 2)
    t0 = c0 - i0
    t1 = c1 - i1
    t2 = c2 - i2
    s1 = n2
    s0 = n1 * n2
    b = off + i0 * s0 + i1 * s1 + i2
    v00 = (1.0 - t2) * grids[b] + t2 * grids[b + 1]
    v01 = (1.0 - t2) * grids[b + s1] + t2 * grids[b + s1 + 1]
    v10 = (1.0 - t2) * grids[b + s0] + t2 * grids[b + s0 + 1]
    v11 = (1.0 - t2) * grids[b + s0 + s1] + t2 * grids[b + s0 + s1 + 1]
    return (1.0 - t0) * ((1.0 - t1) * v00 + t1 * v01) + t0 * ((1.0 - t1) * v10 + t1 * v11)


@njit(**OPTS)
def local_sdf(objf, grids, o, L, m, out):
    """Signed distance (m) of the object-frame points ``L[:m]`` to object ``o`` into ``out[:m]``
    (the object's ``local_sdf``)."""
    code = objf[o, F_CODE]
    p = F_P
    if code == SHAPE_TABLE:
        h = objf[o, p]
        for i in range(m):
            out[i] = L[i, 2] - h
    elif code == SHAPE_CABLE:
        r = objf[o, p]
        zc = objf[o, p + 1] + r
        ox, oy, inv = objf[o, p + 2], objf[o, p + 3], objf[o, p + 4]
        off, n0, n1 = int(objf[o, CABLE_GRID]), int(objf[o, CABLE_GRID + 1]), int(objf[o, CABLE_GRID + 2])
        for i in range(m):
            lat = _grid2(grids, off, n0, n1, (L[i, 0] - ox) * inv, (L[i, 1] - oy) * inv)
            dz = L[i, 2] - zc
            out[i] = math.sqrt(lat * lat + dz * dz) - r
    elif code == SHAPE_BOX:
        hx, hy, hz = objf[o, p], objf[o, p + 1], objf[o, p + 2]
        for i in range(m):
            q0 = abs(L[i, 0]) - hx
            q1 = abs(L[i, 1]) - hy
            q2 = abs(L[i, 2]) - hz
            a0 = max(q0, 0.0)
            a1 = max(q1, 0.0)
            a2 = max(q2, 0.0)
            out[i] = math.sqrt(a0 * a0 + a1 * a1 + a2 * a2) + min(max(q0, max(q1, q2)), 0.0)
    elif code == SHAPE_SPHERE:
        r = objf[o, p]
        for i in range(m):
            out[i] = math.sqrt(L[i, 0] * L[i, 0] + L[i, 1] * L[i, 1] + L[i, 2] * L[i, 2]) - r
    elif code == SHAPE_CYLINDER:
        r, half = objf[o, p], objf[o, p + 1]
        for i in range(m):
            radial = math.sqrt(L[i, 1] * L[i, 1] + L[i, 2] * L[i, 2]) - r
            axial = abs(L[i, 0]) - half
            a0 = max(radial, 0.0)
            a1 = max(axial, 0.0)
            out[i] = math.sqrt(a0 * a0 + a1 * a1) + min(max(radial, axial), 0.0)
    else:  # mesh: the grid, and outside it the conservative continuation of MeshObject.local_sdf
        lo0, lo1, lo2, inv = objf[o, p], objf[o, p + 1], objf[o, p + 2], objf[o, p + 3]
        hi0, hi1, hi2, border = objf[o, p + 4], objf[o, p + 5], objf[o, p + 6], objf[o, p + 7]
        g = MESH_GRID
        off, n0, n1, n2 = int(objf[o, g]), int(objf[o, g + 1]), int(objf[o, g + 2]), int(objf[o, g + 3])
        for i in range(m):
            x, y, z = L[i, 0], L[i, 1], L[i, 2]
            v = _grid3(grids, off, n0, n1, n2, (x - lo0) * inv, (y - lo1) * inv, (z - lo2) * inv)
            e0 = max(lo0 - x, 0.0) + max(x - hi0, 0.0)
            e1 = max(lo1 - y, 0.0) + max(y - hi1, 0.0)
            e2 = max(lo2 - z, 0.0) + max(z - hi2, 0.0)
            d_out = math.sqrt(e0 * e0 + e1 * e1 + e2 * e2)
            if d_out > 0.0:
                v = max(v - d_out, d_out + border)
            out[i] = v


@njit(**OPTS)
def _slab(p, n, half):
    """Ray parameters ``s`` of ``p - s n`` with ``|coordinate| <= half`` along one axis."""
    if n == 0.0:
        if abs(p) <= half:
            return -np.inf, np.inf
        return np.inf, -np.inf
    a = (p - half) / n
    b = (p + half) / n
    return min(a, b), max(a, b)


@njit(**OPTS)
def local_depth(objf, grids, o, L, m, nx, ny, nz, out):
    """Indentation (m, >= 0) of the object-frame points ``L[:m]`` pressed along the object-frame
    direction ``(nx, ny, nz)`` into object ``o``, into ``out[:m]`` (the object's ``depth``: ray
    depth for cables pressed from above, boxes, spheres and cylinders; ``-sdf`` otherwise)."""
    code = objf[o, F_CODE]
    p = F_P
    if code == SHAPE_CABLE and nz <= -0.5:
        r = objf[o, p]
        top = objf[o, p + 1] + r
        ox, oy, inv = objf[o, p + 2], objf[o, p + 3], objf[o, p + 4]
        off, n0, n1 = int(objf[o, CABLE_GRID]), int(objf[o, CABLE_GRID + 1]), int(objf[o, CABLE_GRID + 2])
        for i in range(m):
            lat = _grid2(grids, off, n0, n1, (L[i, 0] - ox) * inv, (L[i, 1] - oy) * inv)
            half = math.sqrt(max(r * r - lat * lat, 0.0))
            out[i] = max((top + half - L[i, 2]) / -nz, 0.0) if half > 0.0 else 0.0
    elif code == SHAPE_BOX:
        hx, hy, hz = objf[o, p], objf[o, p + 1], objf[o, p + 2]
        for i in range(m):
            lo, hi = _slab(L[i, 0], nx, hx)
            a, b = _slab(L[i, 1], ny, hy)
            lo = max(lo, a)
            hi = min(hi, b)
            a, b = _slab(L[i, 2], nz, hz)
            lo = max(lo, a)
            hi = min(hi, b)
            out[i] = hi if hi > 0.0 and lo <= hi else 0.0
    elif code == SHAPE_SPHERE:
        r = objf[o, p]
        for i in range(m):
            x, y, z = L[i, 0], L[i, 1], L[i, 2]
            b = x * nx + y * ny + z * nz
            disc = b * b - (x * x + y * y + z * z) + r * r
            out[i] = 0.0
            if disc > 0.0:
                root = math.sqrt(disc)
                if b + root > 0.0:
                    out[i] = b + root
    elif code == SHAPE_CYLINDER:
        r, half = objf[o, p], objf[o, p + 1]
        a = ny * ny + nz * nz
        for i in range(m):
            x, y, z = L[i, 0], L[i, 1], L[i, 2]
            lo, hi = _slab(x, nx, half)
            if a > 1e-12:  # the ray crosses the round surface
                b = (y * ny + z * nz) / a
                disc = b * b - (y * y + z * z - r * r) / a
                if disc > 0.0:
                    root = math.sqrt(disc)
                    lo = max(lo, b - root)
                    hi = min(hi, b + root)
                else:
                    lo = np.inf
                    hi = -np.inf
            elif not y * y + z * z <= r * r:  # along the axis, outside the round surface
                lo = np.inf
                hi = -np.inf
            out[i] = hi if hi > 0.0 and lo <= hi else 0.0
    else:
        local_sdf(objf, grids, o, L, m, out)
        for i in range(m):
            out[i] = max(-out[i], 0.0)


@njit(**OPTS)
def to_local(objf, o, P, m, L):
    """World points ``P[:m]`` in object ``o``'s frame, ``(p - t) R``, into ``L[:m]``."""
    if objf[o, F_IDENT] != 0.0:
        for i in range(m):
            L[i, 0] = P[i, 0]
            L[i, 1] = P[i, 1]
            L[i, 2] = P[i, 2]
        return
    t0, t1, t2 = objf[o, F_T], objf[o, F_T + 1], objf[o, F_T + 2]
    r = F_R
    r00, r01, r02 = objf[o, r], objf[o, r + 1], objf[o, r + 2]
    r10, r11, r12 = objf[o, r + 3], objf[o, r + 4], objf[o, r + 5]
    r20, r21, r22 = objf[o, r + 6], objf[o, r + 7], objf[o, r + 8]
    for i in range(m):
        dx = P[i, 0] - t0
        dy = P[i, 1] - t1
        dz = P[i, 2] - t2
        L[i, 0] = dx * r00 + dy * r10 + dz * r20
        L[i, 1] = dx * r01 + dy * r11 + dz * r21
        L[i, 2] = dx * r02 + dy * r12 + dz * r22


# ---------------------------------------------------------------------- the pad's contact, in stages
# Each stage has one caller, pad_contact, and is inlined into it at numba's level.
@njit(**INLINE)
def _broad_phase(T, centres, padf, objf, grids, near, nnear, broad, cw, P, L, D):
    """Per object, the tactels that can touch it: those whose centre (at ``T``) is within the
    tactel's reach plus the margin of the object's surface, listed in ``near[o, :nnear[o]]``
    (an object whose bounds are farther than the margin from the pad's box is skipped).  The
    corners ``cw`` are kept in ``broad``; ``P``, ``L``, ``D`` are scratch space."""
    nt = centres.shape[0]
    margin = padf[PF_MARGIN]
    lo = np.empty(3)
    hi = np.empty(3)
    for k in range(3):
        lo[k] = min(min(cw[0, k], cw[1, k]), min(cw[2, k], cw[3, k]))
        hi[k] = max(max(cw[0, k], cw[1, k]), max(cw[2, k], cw[3, k]))
    for i in range(nt):
        for k in range(3):
            P[i, k] = centres[i, 0] * T[k, 0] + centres[i, 1] * T[k, 1] + centres[i, 2] * T[k, 2] + T[k, 3]
    for o in range(nnear.shape[0]):
        nnear[o] = 0
        apart = False
        for k in range(3):
            apart = apart or hi[k] + margin < objf[o, F_BLO + k] or lo[k] - margin > objf[o, F_BHI + k]
        if apart:
            continue
        to_local(objf, o, P, nt, L)
        local_sdf(objf, grids, o, L, nt, D)
        cnt = 0
        for i in range(nt):
            if D[i] < padf[PF_REACH] + margin:
                near[o, cnt] = i
                cnt += 1
        nnear[o] = cnt
    broad[B_VALID] = 1.0
    for c in range(4):
        for k in range(3):
            broad[B_CORNERS + 3 * c + k] = cw[c, k]


@njit(**INLINE)
def _sample_depths(T, centres, offsets, objf, grids, near, o, m, P, L, D):
    """The samples of object ``o``'s ``m`` near tactels at ``T``: their world points into ``P``
    and their indentation (m, >= 0) into the object along the pad's +z into ``D``, tactel by
    tactel (``offsets.shape[0]`` samples each)."""
    ns = offsets.shape[0]
    j = 0
    for ii in range(m):
        i = near[o, ii]
        for s in range(ns):
            l0 = centres[i, 0] + offsets[s, 0]
            l1 = centres[i, 1] + offsets[s, 1]
            l2 = centres[i, 2] + offsets[s, 2]
            for k in range(3):
                P[j, k] = l0 * T[k, 0] + l1 * T[k, 1] + l2 * T[k, 2] + T[k, 3]
            j += 1
    mj = m * ns  # (not j: a counter that starts at a constant would compile another copy)
    to_local(objf, o, P, mj, L)
    n0, n1, n2 = T[0, 2], T[1, 2], T[2, 2]  # the pressing direction in the object's frame
    nx = n0 * objf[o, F_R] + n1 * objf[o, F_R + 3] + n2 * objf[o, F_R + 6]
    ny = n0 * objf[o, F_R + 1] + n1 * objf[o, F_R + 4] + n2 * objf[o, F_R + 7]
    nz = n0 * objf[o, F_R + 2] + n1 * objf[o, F_R + 5] + n2 * objf[o, F_R + 8]
    local_depth(objf, grids, o, L, mj, nx, ny, nz, D)


@njit(**INLINE)
def _integrate(P, D, near, o, m, ns, scale, last_force, S):
    """Tactel forces and spring moments of object ``o``'s samples (depths ``D``, points ``P``).

    Each tactel's force (N) is ``scale`` (the stiffness of one sample spring, N/m) times the sum
    of its samples' depths; a tactel keeps the largest over the objects, in ``last_force``.
    Over the penetrating samples (depth ``d > 0`` at world point ``p``) it sums ``1``, ``d``,
    ``d p``, ``p`` and ``p p^T`` (upper triangle, into ``S``) for :func:`_add_springs`.

    Returns ``(count, sum d, sum d p (3), sum p (3), deepest)``.
    """
    cnt = 0
    sd = 0.0
    sdp0 = 0.0
    sdp1 = 0.0
    sdp2 = 0.0
    sp0 = 0.0
    sp1 = 0.0
    sp2 = 0.0
    deepest = 0.0
    for a in range(3):
        for b in range(3):
            S[a, b] = 0.0
    j = 0
    for ii in range(m):
        total = 0.0
        for _ in range(ns):
            d = D[j]
            total += d
            if d > 0.0:
                p0, p1, p2 = P[j, 0], P[j, 1], P[j, 2]
                deepest = max(deepest, d)
                cnt += 1
                sd += d
                sdp0 += d * p0
                sdp1 += d * p1
                sdp2 += d * p2
                sp0 += p0
                sp1 += p1
                sp2 += p2
                S[0, 0] += p0 * p0
                S[0, 1] += p0 * p1
                S[0, 2] += p0 * p2
                S[1, 1] += p1 * p1
                S[1, 2] += p1 * p2
                S[2, 2] += p2 * p2
            j += 1
        i = near[o, ii]
        last_force[i] = max(last_force[i], total * scale)
    return cnt, sd, sdp0, sdp1, sdp2, sp0, sp1, sp2, deepest


@njit(**INLINE)
def _add_springs(w, K, S, scale, cnt, sd, sdp0, sdp1, sdp2, sp0, sp1, sp2, n0, n1, n2):
    """Add the wrench and stiffness of ``cnt`` penetrating sample springs (stiffness ``scale``,
    N/m, along the pad normal ``n``; sums of :func:`_integrate`) into ``w`` and ``K``:
    ``wrench = -k sum d [n; p x n]`` (global frame, torque about the origin) and
    ``K_x = k sum a a^T`` with ``a = [n; p x n]``."""
    S[1, 0] = S[0, 1]
    S[2, 0] = S[0, 2]
    S[2, 1] = S[1, 2]
    w[0] -= scale * sd * n0
    w[1] -= scale * sd * n1
    w[2] -= scale * sd * n2
    w[3] -= scale * (sdp1 * n2 - sdp2 * n1)
    w[4] -= scale * (sdp2 * n0 - sdp0 * n2)
    w[5] -= scale * (sdp0 * n1 - sdp1 * n0)
    nv = np.empty(3)
    mv = np.empty(3)
    nv[0], nv[1], nv[2] = n0, n1, n2
    mv[0] = sp1 * n2 - sp2 * n1
    mv[1] = sp2 * n0 - sp0 * n2
    mv[2] = sp0 * n1 - sp1 * n0
    kc = scale * cnt
    for a in range(3):
        for b in range(3):
            K[a, b] += kc * nv[a] * nv[b]
            K[a, 3 + b] += scale * nv[a] * mv[b]
            K[3 + a, b] += scale * mv[a] * nv[b]
    # N S N^T with N = [n]x: the sum of (p x n)(p x n)^T
    N = np.zeros((3, 3))
    N[0, 1] = -n2
    N[0, 2] = n1
    N[1, 0] = n2
    N[1, 2] = -n0
    N[2, 0] = -n1
    N[2, 1] = n0
    for a in range(3):
        for b in range(3):
            acc = 0.0
            for c in range(3):
                for e in range(3):
                    acc += N[a, c] * S[c, e] * N[b, e]
            K[3 + a, 3 + b] += scale * acc


@njit(**OPTS)
def pad_contact(T, data, wK):
    """Penetration of the pad's samples at pose ``T`` into the objects: the force image and the
    contact wrench and stiffness (for the arm's equilibrium, :func:`tactile_bt.robot.kernels.arm_step`).

    ``data`` is ``(centres, offsets, corners, padf, objf, grids, near, nnear, broad, force, job,
    last, last_force)``.  The result for the last pose is kept (``last``, :data:`LAST`;
    ``last_force``): the arm's next step starts where its last one ended, and the sensor reads
    the frame there.  Otherwise, in stages: the broad phase (:func:`_broad_phase`) is redone when
    the pad's corners have moved more than half the margin since it was made (state: ``near``,
    ``nnear``, ``broad``); then per object, the depths of the samples of its near tactels
    (:func:`_sample_depths`), the tactel forces and moments (:func:`_integrate`) and the wrench
    and stiffness of the sample springs (:func:`_add_springs`).
    ``job`` (:data:`JOB`) asks for the tactel forces (N, the largest over the objects of the sum
    over its samples of spring stiffness times depth; before the foam spread,
    :func:`foam_spread`) into ``force``, and for the wrench ``[f; tau]`` on the pad (global
    frame, torque about the origin) and its stiffness ``sum k a a^T``, ``a = [n; p x n]``
    (row-major) into ``wK`` (:data:`tactile_bt.robot.kernels.CONTACT`).  Returns the deepest
    penetration (m), also put in ``job``.
    """
    centres, offsets, corners, padf, objf, grids, near, nnear, broad, force, job, last, last_force = data
    hit = last[LAST_VALID] != 0.0  # the result for exactly this pose is kept
    for i in range(4):
        for k in range(4):
            hit = hit and T[i, k] == last[LAST_T + 4 * i + k]
    if not hit:
        w = np.zeros(6)
        K = np.zeros((6, 6))
        nt = centres.shape[0]
        ns = offsets.shape[0]
        cw = np.empty((4, 3))
        drift = 0.0  # the largest move of a corner's coordinate since the broad phase (m)
        for c in range(4):
            for k in range(3):
                cw[c, k] = corners[c, 0] * T[k, 0] + corners[c, 1] * T[k, 1] + corners[c, 2] * T[k, 2] + T[k, 3]
                drift = max(drift, abs(cw[c, k] - broad[B_CORNERS + 3 * c + k]))
        P = np.empty((nt * ns, 3))  # world points
        L = np.empty((nt * ns, 3))  # the same in an object's frame
        D = np.empty(nt * ns)  # their depths or distances
        if broad[B_VALID] == 0.0 or drift > padf[PF_MARGIN] / 2:
            _broad_phase(T, centres, padf, objf, grids, near, nnear, broad, cw, P, L, D)
        for i in range(nt):
            last_force[i] = 0.0
        deepest = 0.0
        S = np.empty((3, 3))
        for o in range(nnear.shape[0]):
            m = nnear[o]
            if m == 0:
                continue
            _sample_depths(T, centres, offsets, objf, grids, near, o, m, P, L, D)
            scale = objf[o, F_SCALE]
            cnt, sd, sdp0, sdp1, sdp2, sp0, sp1, sp2, deep = _integrate(P, D, near, o, m, ns, scale, last_force, S)
            deepest = max(deepest, deep)
            if cnt > 0:
                _add_springs(w, K, S, scale, cnt, sd, sdp0, sdp1, sdp2, sp0, sp1, sp2, T[0, 2], T[1, 2], T[2, 2])
        last[LAST_VALID] = 1.0  # keep the result for this pose
        for i in range(4):
            for k in range(4):
                last[LAST_T + 4 * i + k] = T[i, k]
        for i in range(6):
            last[LAST_W + i] = w[i]
            for k in range(6):
                last[LAST_K + 6 * i + k] = K[i, k]
        last[LAST_DEEPEST] = deepest
    if job[J_FORCES] != 0.0:
        for i in range(last_force.shape[0]):
            force[i] = last_force[i]
    if job[J_CONTACT] != 0.0:
        for i in range(CONTACT_SIZE):
            wK[i] = last[LAST_W + i]
    job[J_DEEPEST] = last[LAST_DEEPEST]
    return job[J_DEEPEST]


@njit(**OPTS)
def foam_spread(force, Gr, Gc, radius, rows, cols):
    """The foam's spread, ``G_r F G_c^T``, in place on the row-major tactel forces ``force``
    (band matrices of ``radius``; ``rows`` x ``cols`` tactels)."""
    F = np.empty((rows, cols))
    for i in range(rows):
        for c in range(cols):
            acc = 0.0
            for k in range(max(0, i - radius), min(rows, i + radius + 1)):
                acc += Gr[i, k] * force[k * cols + c]
            F[i, c] = acc
    for i in range(rows):
        for j in range(cols):
            acc = 0.0
            for c in range(max(0, j - radius), min(cols, j + radius + 1)):
                acc += F[i, c] * Gc[j, c]
            force[i * cols + j] = acc


@njit(**OPTS)
def raw_counts(force, cal, z, gain, padf, raw):
    """Raw counts of the tactel forces ``force`` into ``raw``: the tactels' characteristic, the
    frame gain ``gain``, per-tactel noise from the standard normal draws ``z``, rounding,
    saturation (:meth:`tactile_bt.sim.pad.SensorModel.raw_frame`)."""
    adc = padf[PF_ADC]
    for i in range(force.shape[0]):
        offset = cal[0, i]
        f = max(force[i], 0.0)
        signal = (offset + cal[1, i] * -math.expm1(-f / cal[2, i])) - offset
        sigma = padf[PF_NOISE] + padf[PF_NOISE_REL] * signal
        noisy = np.rint(offset + gain * signal + sigma * z[i])
        noisy = min(max(noisy, 0.0), adc)
        raw[i] = np.uint16(noisy)
