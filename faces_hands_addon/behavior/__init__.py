# SPDX-License-Identifier: GPL-3.0-or-later
"""Non-verbal speech-related behaviour from text (thesis 4.3.5, with the timing of 4.2.1): blinks, head
and eyebrow movement at pitch maxima, glances at accents and phrase boundaries, questions, thinking and
word search, turn-taking signals and gaze jitter, in character styles (4.2.2).

* :func:`generate_behavior` -- :class:`~faces_hands_addon.speech.Utterance` + style + seed ->
  :class:`BehaviorResult` (tracks for the ``behavior`` layer and the list of events).
* :func:`load_style` / :func:`style_names` -- the editable styles of ``presets/behavior/styles.json``.

Engine only: numpy/scipy, no Blender.
"""
from .events import HEAD_CHANNELS, BehaviorEvent, channel_specs, control_names
from .generate import BehaviorResult, generate_behavior
from .prosody import Extremum, pitch_extrema
from .styles import CharacterStyle, load_style, load_styles, style_names

__all__ = ["generate_behavior", "BehaviorResult", "BehaviorEvent", "CharacterStyle", "load_style", "load_styles",
           "style_names", "channel_specs", "control_names", "HEAD_CHANNELS", "pitch_extrema", "Extremum"]
