# SPDX-License-Identifier: GPL-3.0-or-later
"""A small detector runtime: TensorFlow Lite models (the MediaPipe hand and face models) run with numpy alone.

Blender 5.2+ embeds Python 3.13, for which ``mediapipe`` has no wheel, and no LiteRT/TFLite wheel covers
every platform and Python line the extension ships for; the MediaPipe models use a dozen plain operators
(convolutions, depthwise convolutions, pooling, additions, PReLU, resizing, a fully connected head), which
numpy runs on every platform with nothing to install. :mod:`.tflite` reads the model file (FlatBuffers),
:mod:`.ops` has the operators, :class:`.interpreter.Interpreter` runs a model. Used by the markerless pitch
replay (hand landmarks, thesis 6.3) and meant for the face landmarks of the photo work too.
"""
from .interpreter import Interpreter

__all__ = ["Interpreter"]
