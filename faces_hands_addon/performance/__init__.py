# SPDX-License-Identifier: GPL-3.0-or-later
"""A performance: speech, non-verbal behaviour and emotion composed into one take (thesis 4.3.5, 4.4), with
speech owning the lips while it articulates (Bui et al. 2004, thesis 2.1). This package sits above
``speech``, ``behavior`` and ``emotion``; none of them imports it."""
from .compose import perform, take_of, voice_settings, with_loudness, with_nonverbal
from .priority import Articulation, load_priority, ownership, owned_controls, with_speech_priority

__all__ = ["perform", "take_of", "voice_settings", "with_loudness", "with_nonverbal", "Articulation",
           "load_priority", "ownership", "owned_controls", "with_speech_priority"]
