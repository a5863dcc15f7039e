# SPDX-License-Identifier: GPL-3.0-or-later
"""Template -> the artist's own mesh (thesis 3.1.2 "Creating New Animatable Head Models from the Template").

The thesis warps the template skin onto the new head and keeps the template's topology. Here the artist's
mesh *is* the skin and its topology never changes, so the direction is reversed: the template is built on
the canonical face registered onto the mesh (:mod:`.fitted`), and then every vertex of the mesh takes
over what the template skin has at the vertex's closest point on it:

* continuous data by barycentric interpolation of the three corners: jaw weight, the muscle
  attachment map (3.1.2: skin nodes "attached to the closest points on the muscle", with the template's
  smoothing already applied, so the pull spreads the same way whatever the mesh resolution), the mouth
  region, the distance to the lip margins and the wrinkle masks;
* discrete data from the nearest corner: node groups (lip, mouth bag, lid, rim flags) and the bone a node
  belongs to.

Two things are decided on the artist's mesh itself, by its connectivity, because position alone cannot:
which *side of the mouth* a vertex is on (over the skin it is nearer the upper or the lower outer lip
contour; for lips that touch, the upper lip's margin and the lower lip's margin share positions but not
neighbours), and whether the mouth and the eyes are *open* (the path over the skin from the upper to the
lower lip or lid is much longer than the straight line only if there is an opening between them; an eye is
first looked for in a front view of the skin, :mod:`..fitting.eye_openings`, whose edges then are the lid
margins: lid landmarks over an opening can settle on one lid).

Vertices beyond the template's face (forehead above the hairline, temples, ears, under the chin, neck,
shoulders) are not face skin: the muscle and lid influence fades out between ``FACE_DISTANCE`` and
``ACTIVE_REACH`` from the template skin, and beyond it vertices are no longer simulated; they stay fixed
to the skull except that skin below the jaw joint follows the jaw by the weight at the face's rim, fading
out over ``JAW_REACH``, where the mandible is (below the jaw joint, not far behind it): under the chin
the skin goes with the mandible and stretches towards the neck, further down the neck stays put; ears,
scalp and the back of the neck stay with the skull. Pieces of the mesh not connected to the main skin
ride the rigid part they lie on (eyeballs, teeth, tongue modelled into the head mesh), stay fixed if they
are mostly not face (ears, a hair cap) or follow the skin if they are (eyebrows, lashes).
All distances are in head space (human scale, metres).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy import sparse
from scipy.sparse.csgraph import connected_components, dijkstra
from scipy.spatial import cKDTree

from ..core import geometry
from .attachment import JAW, SKULL
from .template import HeadTemplate

__all__ = ["MeshTransfer", "transfer_to_mesh", "FACE_DISTANCE", "ACTIVE_REACH", "JAW_REACH", "UPPER",
           "LOWER", "CARRIERS"]

FACE_DISTANCE = 0.005   # m: vertices this close to the template skin are face skin (full weight)
ACTIVE_REACH = 0.015    # m: muscle and lid influence has faded out here; farther vertices are not simulated
JAW_REACH = 0.080       # m: jaw-carried skin beyond the face fades to the fixed neck over this distance
JOINT_CLEARANCE = (0.015, 0.045)   # m below the jaw joint over which off-face skin starts following the jaw
JOINT_BEHIND = (0.005, 0.035)      # m behind the joint over which it stops again (ears, back of the neck)
SEED_SKIP = 3           # outer lip contour landmarks at each mouth corner that do not seed the side
MOUTH_REACH = 0.025     # m over the skin from the outer lip contours: where the side of the mouth matters
MOUTH_REGION = 0.026    # m over the skin from the lip margins: the mouth region (template: 22 mm)
OPENING_RATIO = 1.8     # path over the skin / straight distance above which there is an opening
NONE, UPPER, LOWER = 0, 1, 2
CARRIERS = ("eye_L", "eye_R", "teeth_upper", "teeth_lower", "tongue")   # rigid parts a separate piece can ride
PART_REACH = 0.008      # m: a piece within this of a rigid part (most of its vertices) rides that part
LIP_TOUCH = 0.003       # m: lips whose nearest vertices lie this close together (summed) touch
LINING_LIP = 0.005      # m over the lining from the line where the lips meet: the lips' inner surface
LINING_PATH = 0.03      # m: longest stretch of that line between two of its vertices
LINING_SHARE = 0.25     # a "lining" larger than this share of the face is no mouth pocket: left alone


def fade(distance: np.ndarray, start: float, end: float) -> np.ndarray:
    """1 up to ``start``, smoothstep down to 0 at ``end``."""
    t = np.clip((end - distance) / (end - start), 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


@dataclass
class MeshTransfer:
    """Per vertex of the artist's mesh (head space): where it lies on the template skin and what it took
    over from there (module docstring)."""
    triangle: np.ndarray            # (n,) template skin triangle of the closest point
    barycentric: np.ndarray         # (n, 3)
    distance: np.ndarray            # (n,) m
    interpolation: sparse.csr_matrix    # (n, N_template) barycentric rows
    face_weight: np.ndarray         # (n,) 1 on the face, 0 from ACTIVE_REACH on (muscles, lids)
    jaw_weight: np.ndarray          # (n,) how far the vertex is carried by the jaw
    groups: np.ndarray              # (n,) skin.GROUPS flags of the nearest template node
    node_bone: np.ndarray           # (n,) 0 skull, 1 jaw
    mouth_region: np.ndarray        # (n,) bool
    lip_distance: np.ndarray        # (n,) m over the template skin to the nearest lip margin
    wrinkles: dict[str, np.ndarray]
    side: np.ndarray                # (n,) NONE / UPPER / LOWER side of the mouth (over the artist's skin)
    edges: np.ndarray | None = None     # (E, 2) the mesh's unique edges
    carrier: np.ndarray | None = None   # (n,) index into CARRIERS of the rigid part a separate shell rides, -1
    lip_margins: dict[str, np.ndarray] = field(default_factory=dict)   # vertex ids, sorted along +X
    eye_margins: dict[str, np.ndarray] = field(default_factory=dict)   # "eye_L_upper"...: (k, 3) points, +X
    openings: dict[str, bool] = field(default_factory=dict)            # "mouth", "eye_L", "eye_R"
    warnings: list[str] = field(default_factory=list)
    lining: np.ndarray | None = None    # vertex ids of the artist's mouth lining (:func:`_mouth_lining`)


def _closest(template: HeadTemplate, vertices: np.ndarray, allowed: np.ndarray | None = None):
    faces = template.skin.faces
    index = np.arange(len(faces)) if allowed is None else np.flatnonzero(allowed)
    point, tri, bary, dist = geometry.closest_points(template.skin.vertices, faces[index], vertices)
    return index[tri], bary, dist


def _closest_near(template: HeadTemplate, vertices: np.ndarray):
    """Closest points for the vertices that can lie within ``JAW_REACH`` of the template skin; the others
    (most of a full body) only get a lower bound of their distance, the corner of a triangle at their
    nearest template node and no weight."""
    nodes, faces = template.skin.vertices, template.skin.faces
    longest = float(np.max(np.linalg.norm(nodes[faces] - nodes[np.roll(faces, 1, axis=1)], axis=2)))
    node_distance, node = cKDTree(nodes).query(vertices)
    near = np.flatnonzero(node_distance - longest <= JAW_REACH)
    owner, corner = np.zeros(len(nodes), np.int64), np.zeros(len(nodes), np.int64)
    for k in (2, 1, 0):
        owner[faces[:, k]] = np.arange(len(faces))
        corner[faces[:, k]] = k
    tri, bary, dist = owner[node], np.zeros((len(vertices), 3)), node_distance.copy()
    bary[np.arange(len(vertices)), corner[node]] = 1.0
    tri[near], bary[near], dist[near] = _closest(template, vertices[near])
    return tri, bary, dist


def _opening(graph: sparse.csr_matrix, vertices: np.ndarray, a: int, b: int, reach: float) -> bool:
    """Is there an opening between vertices a and b (the skin path is much longer than the gap)?"""
    straight = float(np.linalg.norm(vertices[a] - vertices[b]))
    path = dijkstra(graph, indices=a, limit=reach)[b]
    return bool(path > OPENING_RATIO * max(straight, 1e-4))


def _closest_by_side(template: HeadTemplate, vertices: np.ndarray, side: np.ndarray):
    """Closest points on the template skin: everything first, then per side of the mouth (a vertex of the
    upper lip must not take over the lower lip's data, and the other way round) and, for vertices off the
    face, on the visible surface only (the face's rim, not the mouth bag)."""
    skin = template.skin
    t_faces = skin.faces
    bone = template.attachment.node_bone[t_faces]
    in_mouth = skin.mouth_region[t_faces].any(axis=1)
    upper_only = in_mouth & (bone == SKULL).all(axis=1)
    lower_only = in_mouth & (bone == JAW).all(axis=1)
    surface_tri = skin.group("surface")[t_faces].all(axis=1)
    tri, bary, dist = _closest_near(template, vertices)
    far = dist > FACE_DISTANCE            # not face skin: take the visible face's rim, not the mouth bag
    klass = side + 3 * far.astype(np.int8)
    klass[dist >= JAW_REACH] = 0          # nothing to take over out there: the first query stands
    for value in np.unique(klass):
        if value == 0:
            continue
        which, off_face = int(value) % 3, value >= 3
        allowed = np.ones(len(t_faces), bool)
        if which == UPPER:
            allowed &= ~lower_only
        elif which == LOWER:
            allowed &= ~upper_only
        if off_face:
            allowed &= surface_tri
        select = np.flatnonzero(klass == value)
        tri[select], bary[select], dist[select] = _closest(template, vertices[select], allowed)
    return tri, bary, dist


def _outside_off_the_bag(template: HeadTemplate, vertices: np.ndarray, faces: np.ndarray, side: np.ndarray,
                         tri: np.ndarray, bary: np.ndarray, dist: np.ndarray) -> None:
    """A vertex whose closest template point is on the mouth bag but that faces the other way (the outer
    skin of a full lip next to the template's thinner lip and its bag) takes the visible skin instead."""
    skin = template.skin
    t_faces = skin.faces
    bag = skin.group("mouth_bag")[t_faces].any(axis=1) | skin.group("lip_inner")[t_faces].any(axis=1)
    t_normal = np.cross(skin.vertices[t_faces[:, 1]] - skin.vertices[t_faces[:, 0]],
                        skin.vertices[t_faces[:, 2]] - skin.vertices[t_faces[:, 0]])
    normal = geometry.vertex_normals(vertices, faces)
    normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-18)
    teeth_front = float(np.min(template.organs.arches["upper"][0][:, 1]))
    facing_front = (normal[:, 1] < -0.5) & (vertices[:, 1] < teeth_front)   # outer skin, in front of the teeth
    wrong = np.flatnonzero(bag[tri] & (np.einsum("ij,ij->i", normal, t_normal[tri]) < 0) & (side != NONE)
                           & facing_front)
    if not len(wrong):
        return
    bone = template.attachment.node_bone[t_faces]
    in_mouth = skin.mouth_region[t_faces].any(axis=1)
    surface = skin.group("surface")[t_faces].all(axis=1)
    for which, other in ((UPPER, JAW), (LOWER, SKULL)):
        select = wrong[side[wrong] == which]
        if len(select):
            allowed = surface & ~(in_mouth & (bone == other).all(axis=1))
            tri[select], bary[select], dist[select] = _closest(template, vertices[select], allowed)


def transfer_to_mesh(template: HeadTemplate, vertices: np.ndarray, faces: np.ndarray,
                     landmarks: np.ndarray) -> MeshTransfer:
    """Closest-point transfer from ``template`` (built on ``landmarks``, head space) to the mesh
    ``vertices``/``faces`` (head space); see the module docstring."""
    n = len(vertices)
    skin = template.skin
    t_faces = skin.faces
    contours = template.inputs.contours
    used = np.zeros(n, bool)
    used[faces.ravel()] = True
    edges, counts = geometry.unique_edges(faces, return_counts=True)
    graph = geometry.edge_length_graph(vertices, edges)
    used_index = np.flatnonzero(used)
    tree = cKDTree(vertices[used_index])

    def nearest_vertex(points: np.ndarray) -> np.ndarray:
        return used_index[tree.query(points)[1]]

    # -- the side of the mouth, over the artist's skin --------------------------------------------------
    # the seeds leave out three landmarks at each mouth corner: where the lips are modelled together, the
    # outer lower contour's third landmark lies on the line where they meet (MakeHuman: 18 mm from the
    # midline, level with the upper lip's margin row), and the row up to 4 mm from the midline was nearer
    # to it than to the upper contour, "lower lip" carried by the jaw (weight 0.97)
    upper_seeds = np.unique(nearest_vertex(landmarks[contours["lips_outer_upper"][SEED_SKIP:-SEED_SKIP]]))
    lower_seeds = np.unique(nearest_vertex(landmarks[contours["lips_outer_lower"][SEED_SKIP:-SEED_SKIP]]))
    shared = np.intersect1d(upper_seeds, lower_seeds)
    upper_seeds = np.setdiff1d(upper_seeds, shared)
    lower_seeds = np.setdiff1d(lower_seeds, shared)
    d_up, d_low = (dijkstra(graph, indices=seeds, min_only=True, limit=2 * MOUTH_REACH) if len(seeds)
                   else np.full(n, np.inf) for seeds in (upper_seeds, lower_seeds))
    near_mouth = np.minimum(d_up, d_low) < MOUTH_REACH
    side = np.where(near_mouth, np.where(d_low < d_up, LOWER, UPPER), NONE).astype(np.int8)

    tri, bary, dist = _closest_by_side(template, vertices, side)
    _outside_off_the_bag(template, vertices, faces, side, tri, bary, dist)

    corners = t_faces[tri]
    rows = np.repeat(np.arange(n), 3)
    interpolation = sparse.csr_matrix((bary.ravel(), (rows, corners.ravel())), shape=(n, skin.node_count))
    nearest = corners[np.arange(n), np.argmax(bary, axis=1)]
    face_weight = fade(dist, FACE_DISTANCE, ACTIVE_REACH) * used
    # beyond the face, skin follows the jaw by the weight at the face's rim, fading with the distance from
    # it, and only where the mandible is: below the jaw joint and not far behind it (under the chin, the
    # front and sides of the neck); the ears, the scalp and the back of the neck stay with the skull
    beyond = 1.0 - fade(dist, FACE_DISTANCE, ACTIVE_REACH)
    joint = template.bones.tmj_pivot
    below = 1.0 - fade(joint[2] - vertices[:, 2], JOINT_CLEARANCE[0], JOINT_CLEARANCE[1])
    ahead = fade(vertices[:, 1] - joint[1], *JOINT_BEHIND)
    jaw_weight = (np.clip(interpolation @ template.attachment.jaw_weight, 0.0, 1.0) * fade(dist, FACE_DISTANCE, JAW_REACH)
                  * (1.0 - beyond * (1.0 - below * ahead)))
    jaw_weight[jaw_weight < 1e-3] = 0.0            # far skin stays exactly where it is
    carrier = _separate_shells(template, vertices, graph, used, face_weight)
    mouth_region = ((interpolation @ skin.mouth_region.astype(np.float64)) > 0.5) & (face_weight > 0.5)
    lip_distance = interpolation @ np.minimum(skin.lip_distance, 1.0)      # inf beyond the search
    wrinkles = {name: (interpolation @ mask) * face_weight for name, mask in skin.wrinkle_regions.items()}
    transfer = MeshTransfer(tri, bary, dist, interpolation, face_weight, jaw_weight, skin.groups[nearest].copy(),
                            template.attachment.node_bone[nearest].copy(), mouth_region, lip_distance, wrinkles, side,
                            edges=edges, carrier=carrier)
    _lip_margins(transfer, template, vertices, edges, counts)
    # the mouth region (no bone guard, lips kept in front of the teeth) over the artist's own skin as well:
    # a jaw-carried node just outside it can be caught by the upper teeth's bone plane as the jaw opens
    margins = np.concatenate(list(transfer.lip_margins.values()))
    if len(margins):
        d_margin = dijkstra(graph, indices=margins, min_only=True, limit=MOUTH_REGION)
        transfer.mouth_region |= (d_margin < MOUTH_REGION) & (face_weight > 0.5)
    _openings(transfer, graph, vertices, faces, landmarks, nearest_vertex, contours)
    _mouth_lining(transfer, graph, nearest_vertex(landmarks[[contours["lips_outer_upper"][0],
                                                             contours["lips_outer_upper"][-1]]]))
    return transfer


def _separate_shells(template: HeadTemplate, vertices: np.ndarray, graph, used: np.ndarray,
                     face_weight: np.ndarray) -> np.ndarray:
    """Pieces of the mesh that are not connected to the main skin (the piece with the most face on it).

    A piece lying mostly on one of the rigid parts (its own eyeballs, teeth or tongue modelled into the
    head mesh) rides that part (returned: index into :data:`CARRIERS` per vertex, -1 elsewhere); a piece
    that is mostly not face (ears or a hair cap modelled as separate pieces) is not simulated at all
    (``face_weight`` set to 0 in place), so it does not wobble where it comes near the face. Pieces that
    are mostly face (eyebrows, lashes) follow the skin like the main piece."""
    count, component = connected_components(graph, directed=False)
    on_face = np.bincount(component, (face_weight > 0.5) & used, count)
    size = np.maximum(np.bincount(component, used, count), 1)
    main = int(np.argmax(on_face))
    carrier = np.full(len(vertices), -1, np.int8)
    share = np.zeros((len(CARRIERS), count))
    for index, name in enumerate(CARRIERS):
        distance, _ = cKDTree(template.organs.parts[name].vertices).query(vertices, distance_upper_bound=PART_REACH)
        share[index] = np.bincount(component, np.isfinite(distance) & used, count) / size
    best = np.argmax(share, axis=0)
    rides = (share[best, np.arange(count)] > 0.6) & (np.arange(count) != main)
    carrier[rides[component]] = best[component[rides[component]]]
    not_face = ((on_face / size) < 0.5) & (np.arange(count) != main)
    face_weight[(not_face | rides)[component]] = 0.0
    return carrier


def _lip_margins(transfer: MeshTransfer, template: HeadTemplate, vertices: np.ndarray, edges: np.ndarray,
                 counts: np.ndarray) -> None:
    """The vertices that must meet when the lips close: the border of the artist's mouth opening (if any)
    plus, per side, the vertex nearest each node of the template's inner lip contour, or, where the artist's
    lips touch, the vertices where they meet (:func:`_lip_contact`)."""
    border = np.zeros(len(vertices), bool)
    border[edges[counts == 1].ravel()] = True
    contours = {name: template.skin.vertices[template.skin.contours[name][1:-1]]
                for name in ("lips_inner_upper", "lips_inner_lower")}
    sides = {name: np.flatnonzero((transfer.side == which) & (transfer.face_weight > 0.5))
             for name, which in (("lips_inner_upper", UPPER), ("lips_inner_lower", LOWER))}
    if any(len(on_side) == 0 for on_side in sides.values()):
        for name in contours:
            transfer.lip_margins[name] = np.zeros(0, np.int64)
        return
    trees = {name: cKDTree(vertices[on_side]) for name, on_side in sides.items()}
    found = _lip_contact(contours, sides, trees, vertices)
    for name, on_side in sides.items():
        margin = on_side[border[on_side] & (transfer.lip_distance[on_side] < 0.003)]
        gap, k = trees[name].query(contours[name])
        margin = np.union1d(margin, on_side[k[(gap < 0.003) & ~found["touch_" + name]]])
        margin = np.union1d(margin, found[name])
        transfer.lip_margins[name] = margin[np.argsort(vertices[margin, 0], kind="stable")]


def _lip_contact(contours: dict, sides: dict, trees: dict, vertices: np.ndarray, samples: int = 11) -> dict[str, np.ndarray]:
    """Where the artist's lips touch: the template's inner lip contours lie where the registered canonical
    face has them, ~5 mm apart (its mouth is a little open), so on a head modelled with its lips together one
    of them lies on the front of a lip (MakeHuman: the upper inner contour on the upper lip's red, 5 mm above
    the line where the lips meet; its African head: the lower one on the lower lip's front). From each
    contour node towards the other contour at its x, the point both lips come nearest (sum of the distances
    to the closest upper-side and lower-side vertex) is on that line if the sum is below ``LIP_TOUCH``; its
    two closest vertices are the margins there (3.1.3: the margins are what meets when the lips close).
    Returns per contour the margin vertices found and, per node, whether the lips touch there."""
    names = ("lips_inner_upper", "lips_inner_lower")
    out = {name: [] for name in names}
    for name, other in (names, names[::-1]):
        points, partner = contours[name], contours[other]
        order = np.argsort(partner[:, 0], kind="stable")
        towards = np.stack([np.interp(points[:, 0], partner[order, 0], partner[order, axis]) for axis in range(3)], 1)
        t = np.linspace(0.0, 1.0, samples)
        line = points[:, None, :] + t[None, :, None] * (towards - points)[:, None, :]
        flat = line.reshape(-1, 3)
        dist = {key: trees[key].query(flat) for key in names}
        cost = (dist[names[0]][0] + dist[names[1]][0]).reshape(len(points), samples)
        best = np.argmin(cost, axis=1)
        pick = np.arange(len(points)) * samples + best
        apart = (vertices[sides[names[0]][dist[names[0]][1][pick]]]
                 - vertices[sides[names[1]][dist[names[1]][1][pick]]])[:, 1:]
        touch = np.linalg.norm(apart, axis=1) < LIP_TOUCH
        for key in names:
            out[key].append(sides[key][dist[key][1][pick[touch]]])
        out["touch_" + name] = touch
    for key in names:
        out[key] = np.unique(np.concatenate(out[key])).astype(np.int64)
    return out


def _margin_loop(graph, upper: np.ndarray, lower: np.ndarray, corners: np.ndarray) -> np.ndarray:
    """The vertices of the closed line where the lips meet: corner, upper margin, other corner, lower margin
    back, joined by shortest paths over the skin."""
    def path(a: int, b: int) -> list[int]:
        _, previous = dijkstra(graph, indices=a, return_predecessors=True, limit=LINING_PATH)
        out = [b]
        while out[-1] != a and out[-1] >= 0:
            out.append(int(previous[out[-1]]))
        return out if out[-1] == a else []
    loop: list[int] = []
    for margin in (upper, lower):
        stops = [int(corners[0]), *(int(v) for v in margin), int(corners[1])]
        for a, b in zip(stops[:-1], stops[1:]):
            if a != b:
                loop += path(a, b)
    return np.unique(np.asarray(loop, np.int64))


def _mouth_lining(transfer: MeshTransfer, graph, corners: np.ndarray) -> None:
    """The artist's mouth lining: a head modelled with its mouth as a pocket behind the lips (MakeHuman,
    SOMA-X: the lips run on into a closed mouth, the mesh's only hole is at the neck) has skin behind the
    line where the lips meet that the template's closest points can call outer skin, above all at the
    commissures, where the pocket reaches sideways past the template's mouth bag. Cut along that line
    (the lip margins, closed at the mouth corners ``corners``: the mesh vertices at the outer lip contour's
    ends); what the cut separates from the face is the lining: within ``LINING_LIP`` of the line the lips'
    inner surface (the template's ``lip_inner``), deeper the ``mouth_bag`` (thesis 3.1.2 "Skin": the lining is
    not the visible surface; it is soft, unguarded and not pushed out by the cheeks' air pressure). A mouth
    modelled as a hole has nothing behind its rim and keeps its groups."""
    from .skin import GROUPS
    upper, lower = transfer.lip_margins.get("lips_inner_upper"), transfer.lip_margins.get("lips_inner_lower")
    if upper is None or lower is None or not len(upper) or not len(lower):
        return
    loop = _margin_loop(graph, upper, lower, corners)
    keep = np.ones(graph.shape[0], bool)
    keep[loop] = False
    cut = graph[keep][:, keep]
    count, component = connected_components(cut, directed=False)
    index = np.flatnonzero(keep)
    face = transfer.face_weight[index] > 0.5
    main = int(np.argmax(np.bincount(component, face, count)))
    pocket = index[component != main]
    if not len(pocket) or len(pocket) > LINING_SHARE * np.count_nonzero(transfer.face_weight > 0.5):
        return
    depth = dijkstra(graph, indices=loop, min_only=True, limit=2 * LINING_LIP)[pocket]
    groups = transfer.groups[pocket] & ~(GROUPS["surface"] | GROUPS["lip_inner"] | GROUPS["mouth_bag"])
    transfer.groups[pocket] = groups | np.where(depth < LINING_LIP, GROUPS["lip_inner"], GROUPS["mouth_bag"])
    transfer.lining = pocket


def _openings(transfer: MeshTransfer, graph, vertices: np.ndarray, faces: np.ndarray, landmarks: np.ndarray,
              nearest_vertex, contours: dict) -> None:
    """Mouth and eye openings on the artist's mesh (module docstring); warnings where there are none.

    An eye's opening is first looked for in a front view of the main skin (:mod:`..fitting.eye_openings`): its
    edges are the lid margins the lids are rigged on (``eye_margins``). Only where there is none there, the
    lid landmarks decide as the lip landmarks do (they can settle on one lid where the lids fold back into
    a socket, so they are not asked first)."""
    from ..fitting.eye_openings import find_eye_opening
    checks = {"mouth": (0, 17, 0.15), "eye_R": (159, 145, 0.08), "eye_L": (386, 374, 0.08)}
    count, component = connected_components(graph, directed=False)
    main = int(np.argmax(np.bincount(component, transfer.face_weight > 0.5, count)))
    skin_faces = faces[(component[faces] == main).all(axis=1)]
    for name, (upper, lower, reach) in checks.items():
        if name != "mouth":
            found = find_eye_opening(vertices, skin_faces, landmarks[contours[f"{name}_upper"]],
                                     landmarks[contours[f"{name}_lower"]])
            if found is not None:
                transfer.eye_margins[f"{name}_upper"], transfer.eye_margins[f"{name}_lower"] = found.upper, found.lower
                transfer.openings[name] = True
                continue
        a, b = nearest_vertex(landmarks[[upper, lower]])
        transfer.openings[name] = a != b and _opening(graph, vertices, int(a), int(b), reach)
    if not transfer.openings["mouth"]:
        transfer.warnings.append("lips cannot part: no mouth opening between the lip contours (cut the mesh "
                                 "along the line where the lips meet to let the jaw open the mouth)")
    for side, label in (("L", "left"), ("R", "right")):
        if not transfer.openings[f"eye_{side}"]:
            transfer.warnings.append(f"the {label} eyelids cannot open or close: no eye opening between the "
                                     "lid contours (cut the eye opening into the mesh)")
