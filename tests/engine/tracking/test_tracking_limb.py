"""The ball's limb under a lamp beside the camera (thesis 6.3.3, the circle fit's boundary points): the
brightness profile model of :func:`.images.limb_profiles` places the limb where the half-way crossing, pulled
inwards by the shading's slope, does not; a whole disc lit from below keeps its circle centre closer."""
from __future__ import annotations

import numpy as np
from scipy import ndimage

from faces_hands_addon.tracking.ball import find_silhouettes, refine_centre
from faces_hands_addon.tracking.camera import Camera, look_at
from faces_hands_addon.tracking.images import limb_profiles, radial_edges
from pitch_images import sphere_image


def _profile(edge: float, steps: np.ndarray, slope: float, sigma: float = 0.9) -> np.ndarray:
    """A limb at ``edge``: shading 0.45 there rising by ``slope`` a pixel inwards, Gaussian-blurred, on 0.02."""
    fine = np.arange(steps[0] - 10, steps[-1] + 10, 0.01)
    inside = np.where(fine < edge, 0.45 + slope * (edge - fine), 0.0)
    kernel = np.exp(-0.5 * (np.arange(-500, 501) * 0.01 / sigma) ** 2)
    blurred = np.convolve(inside, kernel / kernel.sum(), mode="same") + 0.02
    return np.interp(steps, fine, blurred)


def test_profile_places_a_shaded_limb_where_the_crossing_does_not():
    pixels = np.arange(40.0)                            # distance of each pixel centre from the ray's start
    steps = np.arange(0.0, 30.0, 0.25)
    crossing, samples = [], []
    for slope in (0.0, 0.06, 0.12):
        row = _profile(18.3, pixels, slope)
        image = np.tile(row, (5, 1))                    # the ray runs along a row from pixel (0, 2)'s centre
        found = radial_edges(image, np.array([0.5, 2.5]), 18.0, 0.2, count=1, reach=1.6, nearest=True)
        crossing.append(found[0, 0] - 0.5)
        samples.append(np.interp(steps, pixels, row))
    crossing = np.array(crossing)
    fitted = limb_profiles(np.array(samples), steps, crossing)
    assert np.all(np.abs(fitted - 18.3) < 0.06)
    assert abs(crossing[-1] - 18.3) > 0.15          # the steeper the shading, the further in the crossing lands
    assert abs(fitted[-1] - 18.3) < 0.3 * abs(crossing[-1] - 18.3)


def test_whole_disc_lit_from_below_keeps_its_centre():
    eye = np.array([-3.5, 1.5, 1.6])
    R = look_at(eye, [0.0, 1.5, 1.6])
    cam = Camera("c", (160, 120), 1700.0, 1700.0, 80.0, 60.0, np.zeros(4), R, -R @ eye)
    centre, radius = np.array([0.0, 1.5, 1.6]), 0.0366
    image = sphere_image(cam, centre[None], radius, eye + [0.0, 0.0, -0.4], ambient=0.2, supersample=4)
    image = np.repeat(ndimage.gaussian_filter(image[..., 0], 1.0)[..., None], 3, axis=2)
    value = image.max(axis=2)
    silhouette = find_silhouettes(image, 10).silhouettes[0]
    true = cam.project(centre[None])[0]
    errors = [np.linalg.norm(refine_centre(cam, value, silhouette, centre + [0.003, 0, 0], radius, 0.3,
                                           ellipse_fallback=False, profile=p) - true) for p in (False, True)]
    assert errors[1] < 0.6 * errors[0]
    assert errors[1] < 0.3
