# SPDX-License-Identifier: GPL-3.0-or-later
"""Run a TensorFlow Lite model with numpy (:mod:`.ops`), operator by operator in the file's order (TFLite
stores them topologically sorted)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..core.errors import UserError
from . import ops
from .tflite import Model, read_model

__all__ = ["Interpreter"]

MAX_MODEL_BYTES = 64_000_000


class Interpreter:
    """``Interpreter(path).run(image)`` -> the model's outputs (a list of arrays, in the file's output order)."""

    def __init__(self, path: str | Path):
        path = Path(path)
        if not path.is_file():
            raise UserError(f"detector model {path} does not exist")
        if path.stat().st_size > MAX_MODEL_BYTES:
            raise UserError(f"{path}: too large for a detector model")
        self.model: Model = read_model(path.read_bytes(), str(path))
        self.constants = {}
        for index, tensor in enumerate(self.model.tensors):
            if tensor.data is not None:
                self.constants[index] = tensor.data.astype(np.float32) if tensor.data.dtype == np.float16 \
                    else tensor.data

    @property
    def input_shape(self) -> tuple:
        return self.model.tensors[self.model.inputs[0]].shape

    def output_names(self) -> list[str]:
        return [self.model.tensors[i].name for i in self.model.outputs]

    def run(self, *inputs: np.ndarray) -> list[np.ndarray]:
        values = dict(self.constants)
        for index, array in zip(self.model.inputs, inputs):
            expected = self.model.tensors[index].shape
            array = np.asarray(array, np.float32)
            if array.shape != tuple(expected):
                raise UserError(f"detector input must be {tuple(expected)}, not {array.shape}")
            values[index] = array
        for op in self.model.operators:
            args = [values.get(i) if i >= 0 else None for i in op.inputs]
            values[op.outputs[0]] = self._apply(op, args)
        return [values[i] for i in self.model.outputs]

    @staticmethod
    def _apply(op, a):
        o, kind = op.options, op.kind
        if kind == "DEQUANTIZE":
            return a[0].astype(np.float32)
        if kind == "CONV_2D":
            return ops.conv2d(a[0], a[1], a[2] if len(a) > 2 else None, o["stride"], o["padding"], o["activation"],
                              o["dilation"])
        if kind == "DEPTHWISE_CONV_2D":
            return ops.depthwise_conv2d(a[0], a[1], a[2] if len(a) > 2 else None, o["stride"], o["padding"],
                                        o["activation"], o["multiplier"], o["dilation"])
        if kind in ("MAX_POOL_2D", "AVERAGE_POOL_2D"):
            return ops.pool2d(a[0], o["filter"], o["stride"], o["padding"], o["activation"],
                              "max" if kind == "MAX_POOL_2D" else "average")
        if kind == "ADD":
            return ops.activate(a[0] + a[1], o.get("activation", 0))
        if kind == "MUL":
            return ops.activate(a[0] * a[1], o.get("activation", 0))
        if kind == "PRELU":
            return ops.prelu(a[0], a[1])
        if kind == "PAD":
            return ops.pad(a[0], a[1])
        if kind == "RESHAPE":
            shape = a[1] if len(a) > 1 and a[1] is not None else o["shape"]
            return a[0].reshape([int(v) for v in shape])
        if kind == "RESIZE_BILINEAR":
            return ops.resize_bilinear(a[0], a[1], o["align_corners"], o["half_pixel"])
        if kind == "CONCATENATION":
            return ops.activate(np.concatenate(a, axis=o["axis"]), o["activation"])
        if kind == "MEAN":
            return ops.mean(a[0], a[1], o["keep_dims"])
        if kind == "FULLY_CONNECTED":
            return ops.fully_connected(a[0], a[1], a[2] if len(a) > 2 else None, o["activation"], o["keep_dims"])
        if kind == "LOGISTIC":
            return (1.0 / (1.0 + np.exp(-a[0]))).astype(np.float32)
        if kind == "RELU":
            return np.maximum(a[0], 0.0)
        if kind == "RELU6":
            return np.clip(a[0], 0.0, 6.0)
        raise UserError(f"operator {kind} is not supported by the numpy runtime")
