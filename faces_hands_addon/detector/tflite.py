# SPDX-License-Identifier: GPL-3.0-or-later
"""Reading a TensorFlow Lite model file: the FlatBuffers binary of the TFLite schema (``schema.fbs``), only the
tables an interpreter needs (model, operator codes, subgraph, tensors, buffers, operators and their options).

FlatBuffers in brief: a table starts with a signed 32-bit offset back to its vtable; the vtable lists, per
field, its 16-bit offset inside the table (0: absent, the default applies); references to tables, vectors
and strings are unsigned 32-bit offsets from where they are stored; a vector is a 32-bit length and its items.
"""
from __future__ import annotations

import struct
from dataclasses import dataclass, field

import numpy as np

from ..core.errors import UserError

__all__ = ["Model", "Tensor", "Operator", "read_model", "OPERATORS", "DTYPES"]

#: TFLite BuiltinOperator codes of the operators :mod:`.ops` runs
OPERATORS = {0: "ADD", 2: "CONCATENATION", 3: "CONV_2D", 4: "DEPTHWISE_CONV_2D", 6: "DEQUANTIZE",
             9: "FULLY_CONNECTED", 14: "LOGISTIC", 17: "MAX_POOL_2D", 22: "RESHAPE", 23: "RESIZE_BILINEAR",
             34: "PAD", 40: "MEAN", 54: "PRELU", 1: "AVERAGE_POOL_2D", 18: "MUL", 19: "RELU", 21: "RELU6"}
#: TFLite TensorType -> numpy
DTYPES = {0: np.float32, 1: np.float16, 2: np.int32, 3: np.uint8, 4: np.int64, 9: np.int8}


class _Table:
    def __init__(self, buf: bytes, pos: int):
        self.buf, self.pos = buf, pos
        vtable = pos - struct.unpack_from("<i", buf, pos)[0]
        self.vsize = struct.unpack_from("<H", buf, vtable)[0]
        self.vtable = vtable

    def _field(self, index: int) -> int:
        slot = 4 + 2 * index
        if slot >= self.vsize:
            return 0
        offset = struct.unpack_from("<H", self.buf, self.vtable + slot)[0]
        return self.pos + offset if offset else 0

    def scalar(self, index: int, fmt: str, default):
        at = self._field(index)
        return struct.unpack_from("<" + fmt, self.buf, at)[0] if at else default

    def table(self, index: int) -> "_Table | None":
        at = self._field(index)
        return _Table(self.buf, at + struct.unpack_from("<I", self.buf, at)[0]) if at else None

    def _vector(self, index: int) -> tuple[int, int]:
        at = self._field(index)
        if not at:
            return 0, 0
        start = at + struct.unpack_from("<I", self.buf, at)[0]
        return start + 4, struct.unpack_from("<I", self.buf, start)[0]

    def vector(self, index: int, dtype) -> np.ndarray:
        start, count = self._vector(index)
        return np.frombuffer(self.buf, dtype=dtype, count=count, offset=start) if count else np.zeros(0, dtype)

    def tables(self, index: int) -> list["_Table"]:
        start, count = self._vector(index)
        out = []
        for k in range(count):
            at = start + 4 * k
            out.append(_Table(self.buf, at + struct.unpack_from("<I", self.buf, at)[0]))
        return out

    def string(self, index: int) -> str:
        start, count = self._vector(index)
        return self.buf[start:start + count].decode("utf-8", "replace") if count else ""


@dataclass
class Tensor:
    name: str
    shape: tuple
    dtype: object
    data: np.ndarray | None            # constant tensors (weights); None for activations


@dataclass
class Operator:
    kind: str
    inputs: list[int]
    outputs: list[int]
    options: dict = field(default_factory=dict)


@dataclass
class Model:
    tensors: list[Tensor]
    operators: list[Operator]
    inputs: list[int]
    outputs: list[int]


def _options(kind: str, table: "_Table | None") -> dict:
    """The builtin options an operator of ``kind`` needs (field indices from the TFLite schema)."""
    if table is None:
        return {}
    if kind == "CONV_2D":
        return {"padding": table.scalar(0, "b", 0), "stride": (table.scalar(2, "i", 1), table.scalar(1, "i", 1)),
                "activation": table.scalar(3, "b", 0), "dilation": (table.scalar(5, "i", 1), table.scalar(4, "i", 1))}
    if kind == "DEPTHWISE_CONV_2D":
        return {"padding": table.scalar(0, "b", 0), "stride": (table.scalar(2, "i", 1), table.scalar(1, "i", 1)),
                "multiplier": table.scalar(3, "i", 1), "activation": table.scalar(4, "b", 0),
                "dilation": (table.scalar(6, "i", 1), table.scalar(5, "i", 1))}
    if kind in ("MAX_POOL_2D", "AVERAGE_POOL_2D"):
        return {"padding": table.scalar(0, "b", 0), "stride": (table.scalar(2, "i", 1), table.scalar(1, "i", 1)),
                "filter": (table.scalar(4, "i", 1), table.scalar(3, "i", 1)), "activation": table.scalar(5, "b", 0)}
    if kind in ("ADD", "MUL", "FULLY_CONNECTED"):
        out = {"activation": table.scalar(0, "b", 0)}
        if kind == "FULLY_CONNECTED":
            out["keep_dims"] = bool(table.scalar(2, "B", 0))
        return out
    if kind == "CONCATENATION":
        return {"axis": table.scalar(0, "i", 0), "activation": table.scalar(1, "b", 0)}
    if kind == "RESHAPE":
        return {"shape": table.vector(0, np.int32).tolist()}
    if kind == "RESIZE_BILINEAR":
        return {"align_corners": bool(table.scalar(2, "B", 0)), "half_pixel": bool(table.scalar(3, "B", 0))}
    if kind == "MEAN":
        return {"keep_dims": bool(table.scalar(0, "B", 0))}
    return {}


def read_model(data: bytes, source: str = "model") -> Model:
    """The first subgraph of a ``.tflite`` file's bytes, with its constant tensors as arrays."""
    if len(data) < 8 or data[4:8] != b"TFL3":
        raise UserError(f"{source}: not a TensorFlow Lite model (no TFL3 identifier)")
    root = _Table(data, struct.unpack_from("<I", data, 0)[0])
    codes = []
    for code in root.tables(1):
        builtin = max(code.scalar(0, "b", 0), code.scalar(3, "i", 0))
        codes.append(builtin)
    buffers = [b.vector(0, np.uint8) for b in root.tables(4)]
    graph = root.tables(2)[0]
    tensors = []
    for t in graph.tables(0):
        dtype = DTYPES.get(t.scalar(1, "b", 0))
        if dtype is None:
            raise UserError(f"{source}: tensor type {t.scalar(1, 'b', 0)} is not supported")
        shape = tuple(int(v) for v in t.vector(0, np.int32))
        raw = buffers[t.scalar(2, "I", 0)] if t.scalar(2, "I", 0) < len(buffers) else np.zeros(0, np.uint8)
        array = raw.view(dtype).reshape(shape) if raw.size else None
        tensors.append(Tensor(t.string(3), shape, dtype, array))
    operators = []
    for op in graph.tables(3):
        builtin = codes[op.scalar(0, "I", 0)]
        kind = OPERATORS.get(builtin)
        if kind is None:
            raise UserError(f"{source}: operator {builtin} is not supported by the numpy runtime")
        operators.append(Operator(kind, op.vector(1, np.int32).tolist(), op.vector(2, np.int32).tolist(),
                                  _options(kind, op.table(4))))
    return Model(tensors, operators, graph.vector(1, np.int32).tolist(), graph.vector(2, np.int32).tolist())
