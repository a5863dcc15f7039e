"""The rig protocol and the one registry of rig kinds: a face rig is a Rig, its pose is plain arrays, saved
rigs of every kind load through one function, and the same rig always gives the same bytes."""
from __future__ import annotations

import zipfile

import numpy as np
import pytest

from faces_hands_addon import UserError
from faces_hands_addon.core import rig as core_rig
from faces_hands_addon.face.rig import FaceRig, build_default_rig


@pytest.fixture(scope="module")
def rig():
    return build_default_rig("coarse")


def test_face_rig_implements_the_protocol(rig):
    assert isinstance(rig, core_rig.Rig)
    pose = rig.step({"ctrl": {"jaw_open": 1.0}, "speech": {"jaw_open": 0.5}}, 1 / 24)
    assert set(pose.positions) == {"skin"} and pose.positions["skin"].dtype == np.float32
    assert pose.positions["skin"].shape == (rig.template.node_count, 3)
    assert {"jaw", "eye_L", "eye_R", "teeth_lower", "tongue"} <= set(pose.transforms)
    assert rig.controls["jaw_open"] == 1.0                              # layers added, then clamped
    assert all(v.shape == (4, 4) for v in pose.transforms.values())
    rest = rig.rest_pose()
    np.testing.assert_array_equal(rest.positions["skin"], rig.rest_positions)


def test_settled_is_independent_of_what_came_before(rig):
    first = rig.settled({"ctrl": {"zygomaticus_major_L": 1.0}}, 0.5).positions["skin"]
    rig.step({"ctrl": {"jaw_open": 1.0}}, 1 / 24)
    again = rig.settled({"ctrl": {"zygomaticus_major_L": 1.0}}, 0.5).positions["skin"]
    assert first.tobytes() == again.tobytes()


def test_registry_loads_every_kind_and_refuses_others(rig, tmp_path):
    assert {"faces_hands.face_rig/1", "faces_hands.fitted_face_rig/1", "faces_hands.character_rig/1"} <= \
        set(core_rig.rig_kinds())
    data = core_rig.save_rig(rig)
    assert rig.identity == core_rig.rig_identity(data)
    loaded = core_rig.load_rig_bytes(data)
    assert isinstance(loaded, FaceRig) and loaded.identity == rig.identity
    assert core_rig.save_rig(loaded) == data, "saving the same rig twice gave different bytes"
    alien = tmp_path / "alien.npz"
    core_rig.write_rig_archive(alien, {"format": "faces_hands.teapot/1"}, {"x": np.zeros(3)})
    with pytest.raises(UserError, match="teapot"):
        core_rig.load_rig(alien)
    with pytest.raises(UserError):
        core_rig.load_rig_bytes(b"PK\x03\x04 truncated")


def test_damaged_archives_are_refused(rig, tmp_path):
    path = tmp_path / "rig.npz"
    rig.save(path)
    meta, arrays = core_rig.read_rig_archive(path, "faces_hands.face_rig/1", "face rig", ("positions",))
    arrays["positions"] = arrays["positions"].copy()
    arrays["positions"][0, 0] = np.nan
    broken = tmp_path / "nan.npz"
    core_rig.write_rig_archive(broken, meta, arrays)
    with pytest.raises(UserError, match="non-finite"):
        core_rig.read_rig_archive(broken, "faces_hands.face_rig/1", "face rig", ("positions",))
    bomb = tmp_path / "bomb.npz"
    with zipfile.ZipFile(bomb, "w", zipfile.ZIP_DEFLATED) as archive:
        archive.writestr("meta_json.npy", b"\0" * 2_000_000)
    old, core_rig.MAX_RIG_BYTES = core_rig.MAX_RIG_BYTES, 1_000_000
    try:
        with pytest.raises(UserError, match="unpacks to"):
            core_rig.load_rig(bomb)
    finally:
        core_rig.MAX_RIG_BYTES = old


def _rig_classes():
    from faces_hands_addon.character.rig import CharacterRig
    from faces_hands_addon.character.user import FittedCharacterRig
    from faces_hands_addon.face.fitted import FittedFaceRig
    from faces_hands_addon.hand.rig import HandRig
    return [FaceRig, FittedFaceRig, HandRig, CharacterRig, FittedCharacterRig]


@pytest.mark.parametrize("cls", _rig_classes(), ids=lambda c: c.__name__)
def test_every_rig_class_offers_exactly_the_protocol_signatures(cls):
    """Every method the bakes, live preview, jobs and export call (core.rig.PROTOCOL_METHODS) exists on every
    rig class with the protocol's parameter names, so a rig of rigs can stand in for any of them."""
    import inspect
    for name in core_rig.PROTOCOL_METHODS:
        assert callable(getattr(cls, name, None)), f"{cls.__name__} lacks {name}"
        wanted = list(inspect.signature(getattr(core_rig.Rig, name)).parameters)
        have = list(inspect.signature(getattr(cls, name)).parameters)
        assert have[:len(wanted)] == wanted, f"{cls.__name__}.{name}{tuple(have)} is not the protocol's {wanted}"
    assert isinstance(getattr(cls, "kind", None), str)


def test_a_hand_worker_copy_settles_like_its_original():
    from faces_hands_addon.hand.rig import build_hand_rig
    hand = build_hand_rig("left")
    values = {"ctrl": {"flexor_digitorum_superficialis_index": 0.6}}
    hand.step({"ctrl": {"extensor_digitorum_middle": 1.0}}, 1 / 30)         # state the copy must not share
    copy = hand.worker_copy()
    assert copy is not hand and copy.hand.network is not hand.hand.network
    assert copy.settled(values, 0.3, 1 / 30).positions["skin"].tobytes() == \
        hand.settled(values, 0.3, 1 / 30).positions["skin"].tobytes()
