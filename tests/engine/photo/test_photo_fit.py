"""The photo fit's machinery without pictures (thesis 3.2.4): a face of the model projected by a known camera
is recovered (pose, focal length, shape); a face turned past the limit is refused with its yaw; the
rasteriser covers what it should and keeps the nearest surface; MediaPipe's crops map points both ways."""
from __future__ import annotations

import numpy as np
import pytest

from faces_hands_addon.core.errors import UserError
from faces_hands_addon.detector.crops import Crop, from_crop, sample_crop
from faces_hands_addon.morph.population import default_model
from faces_hands_addon.photo.camera import FRONT, Camera, focal_from_35mm, rotation, yaw_pitch_roll
from faces_hands_addon.photo.fit import FitSettings, View, fit_views
from faces_hands_addon.photo.head_model import HeadModel
from faces_hands_addon.photo.pipeline import HeadBuild, Photo
from faces_hands_addon.photo.raster import rasterize


@pytest.fixture(scope="module")
def model():
    return HeadModel.from_morphable(default_model())


def _projected(model, alpha, camera, rng, noise_px=0.7):
    truth = model.shape(alpha)
    uv, z = camera.project(truth[model.landmarks])
    points = np.zeros((478, 3))
    points[:468, :2] = uv + rng.normal(0.0, noise_px, uv.shape)
    points[:468, 2] = (z - z.mean()) * camera.focal / z.mean()
    for start, ids in ((468, (33, 133, 159, 145)), (473, (362, 263, 386, 374))):
        points[start:start + 5] = points[list(ids)].mean(axis=0)
    return truth, points


def test_a_projected_face_gives_back_its_camera_and_shape(model):
    rng = np.random.default_rng(3)
    alpha = rng.standard_normal(model.components) * model.sd * 0.7
    width, height = 900, 1200
    turn = rotation(np.radians([6.0, 0.0, 0.0])) @ rotation(np.radians([0.0, 22.0, 0.0]))
    camera = Camera(width, height, focal_from_35mm(50.0, width, height), turn @ FRONT, np.array([0.02, -0.01, 0.6]))
    truth, points = _projected(model, alpha, camera, rng)
    fit = fit_views(model, [View(points, width, height)], FitSettings(correction=False, silhouette=False))
    found = fit.cameras[0]
    angle = np.degrees(np.arccos(np.clip((np.trace(found.rotation.T @ camera.rotation) - 1) / 2, -1, 1)))
    assert angle < 1.0, angle
    assert abs(found.focal / camera.focal - 1.0) < 0.15
    centred = lambda v: v - v.mean(axis=0)                                   # noqa: E731
    rms_mm = 1000 * np.sqrt(((centred(fit.vertices) - centred(truth)) ** 2).sum(axis=1).mean())
    mean_mm = 1000 * np.sqrt(((centred(model.mean) - centred(truth)) ** 2).sum(axis=1).mean())
    assert rms_mm < 0.5 * mean_mm, (rms_mm, mean_mm)
    assert np.median(fit.residuals[0]) < 2.0


def test_a_face_turned_past_the_limit_is_refused_with_its_yaw(model):
    rng = np.random.default_rng(5)
    width, height = 800, 800
    camera = Camera(width, height, focal_from_35mm(50.0, width, height),
                    rotation(np.radians([0.0, 70.0, 0.0])) @ FRONT, np.array([0.0, 0.0, 0.25]))
    _, points = _projected(model, np.zeros(model.components), camera, rng, 0.3)
    assert abs(yaw_pitch_roll(camera.rotation)[0]) > 65
    photo = Photo(np.full((height, width, 3), 0.5, np.float32), "turned.png", focal_35mm=50.0, landmarks=points)
    build = HeadBuild([photo], model, FitSettings(silhouette=False), rig=False)
    with pytest.raises(UserError, match=r"turned (69|70|71) degrees"):
        while build.step() < 1.0:
            pass


def test_the_rasteriser_covers_a_triangle_and_keeps_the_nearest_surface():
    xy = np.array([[10.0, 10.0], [90.0, 10.0], [10.0, 90.0], [10.0, 10.0], [90.0, 10.0], [90.0, 90.0]])
    depth = np.array([1.0, 1.0, 1.0, 2.0, 2.0, 2.0])
    raster = rasterize(xy, np.array([[0, 1, 2], [3, 4, 5]]), 100, 100, depth)
    near = raster.triangle == 0
    assert abs(near.sum() - 0.5 * 80 * 80) < 80                               # its area, to an edge of pixels
    assert (raster.triangle[30, 85] == 1) and (raster.triangle[70, 20] == 0)
    assert raster.triangle[15, 15] == 0                                       # both cover it: the nearer wins
    assert np.allclose(raster.bary[raster.mask].sum(axis=1), 1.0, atol=1e-5)


def test_a_crop_maps_points_into_the_model_input_and_back():
    image = np.zeros((300, 400, 3), np.float32)
    image[118:123, 248:253] = 1.0                                             # a bright dot at (250.5, 120.5)
    crop = Crop((230.0, 140.0), 120.0, np.radians(25.0))
    patch = sample_crop(image, crop, 64)
    y, x = np.unravel_index(np.argmax(patch[..., 0]), patch.shape[:2])
    back = from_crop(np.array([[x + 0.5, y + 0.5]]), crop, 64)[0]
    assert np.linalg.norm(back - [250.5, 120.5]) < 2.5
    flipped = sample_crop(image, crop, 64, flip=True)
    assert np.allclose(flipped[:, ::-1], patch, atol=1e-6)


def test_an_edited_person_keeps_what_the_model_could_not_say(model):
    """3.2.4: the fitted person made older with the model's attribute: the attribute's value rises by what
    was set, the correction beyond the model stays, the texture is scaled, not replaced."""
    from faces_hands_addon.morph.editing import EditFace
    from faces_hands_addon.photo.edit import edited_head
    rng = np.random.default_rng(11)
    width, height = 420, 420
    camera = Camera(width, height, focal_from_35mm(50.0, width, height), FRONT.copy(), np.array([0.0, 0.0, 0.4]))
    _, points = _projected(model, rng.standard_normal(model.components) * model.sd * 0.5, camera, rng)
    photo = Photo(np.full((height, width, 3), 0.45, np.float32), "grey.png", focal_35mm=50.0, landmarks=points)
    build = HeadBuild([photo], model, FitSettings(silhouette=False), rig=False)
    while build.step() < 1.0:
        pass
    result = build.result
    older = edited_head(result, [("younger-older", 1.5)])
    before, after = EditFace(model.source), EditFace(model.source)
    for face, alpha in ((before, result.shape.alpha), (after, older.shape.alpha)):
        face.run({"op": "create", "kind": "coefficients", "shape": alpha.tolist(), "colour": None})
    assert after.value("younger-older") - before.value("younger-older") > 1.0
    assert np.allclose(older.vertices - model.shape(older.shape.alpha), result.shape.correction)
    assert older.texture.srgb.shape == result.texture.srgb.shape
    assert not np.array_equal(older.texture.srgb, result.texture.srgb)
    assert "younger-older" in older.notes[-1]
