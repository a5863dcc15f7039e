# SPDX-License-Identifier: GPL-3.0-or-later
"""Speech: text-to-speech, recorded audio and lip sync (thesis 3.1.3, 3.1.4, 4.3).

* :func:`synthesize` -- text -> :class:`Utterance` with espeak-ng (audio, phones, words, sentences,
  phrases, accents, pauses, F0, emotion tags of the emoticons).
* :func:`align_audio` -- recorded audio (+ transcript) -> :class:`Utterance` with pocketsphinx.
* :func:`load_articulation` / :func:`load_viseme_targets` -- editable target presets.
* :func:`coarticulate` -- Cohen-Massaro coarticulation -> :class:`~faces_hands_addon.anim.TrackSet`.

Nothing here imports bpy; pocketsphinx and the espeak-ng wheel are loaded only when used.
"""
from .align import align_audio
from .articulation import TargetSet, load_articulation, load_target_set, load_viseme_targets
from .audio import load_audio, save_wav, to_analysis_rate
from .coarticulation import CoarticulationResult, Segment, coarticulate, expand_segments, sample_times
from .emoticons import TABLE_4_1, EmotionTag, extract_emoticons
from .espeak import VoiceInfo, list_voices
from .espeak import available as espeak_available
from .evaluation import compare_phone_onsets, pair_phones
from .phonemes import VISEMES, from_arpabet, from_espeak, from_ipa, from_sampa, to_arpabet, viseme_of
from .pitch import PitchContour, track_pitch
from .tts import synthesize
from .utterance import Pause, Phone, Phrase, Sentence, Syllable, Utterance, Word

__all__ = [
    # text and audio in
    "synthesize", "align_audio", "load_audio", "save_wav", "to_analysis_rate", "list_voices",
    "VoiceInfo", "espeak_available", "extract_emoticons", "TABLE_4_1", "EmotionTag",
    # the utterance
    "Utterance", "Phone", "Syllable", "Word", "Phrase", "Sentence", "Pause", "PitchContour",
    "track_pitch",
    # phones
    "VISEMES", "from_arpabet", "from_espeak", "from_ipa", "from_sampa", "to_arpabet", "viseme_of",
    # lip sync
    "TargetSet", "load_articulation", "load_viseme_targets", "load_target_set", "coarticulate",
    "CoarticulationResult", "Segment", "expand_segments", "sample_times",
    # evaluation
    "compare_phone_onsets", "pair_phones",
]
