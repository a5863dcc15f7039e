"""Shared fixtures of the behaviour tests: utterances built directly (``utterances.py``) and their behaviour
over many seeds."""
from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))

from utterances import long_monologue  # noqa: E402

SEEDS = 80


@pytest.fixture(scope="session")
def monologues():
    """(utterance, accent peaks) of SEEDS different monologues."""
    return [long_monologue(seed) for seed in range(SEEDS)]


@pytest.fixture(scope="session")
def neutral_runs(monologues):
    """The neutral style's behaviour of every monologue, one seed each."""
    from faces_hands_addon.behavior import generate_behavior
    return [(u, generate_behavior(u, "neutral", seed=seed)) for seed, (u, _) in enumerate(monologues)]
