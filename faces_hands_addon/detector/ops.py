# SPDX-License-Identifier: GPL-3.0-or-later
"""TFLite operators in numpy, float32, NHWC tensors (batch 1), with TFLite's padding rules: SAME pads
``max((out - 1) * stride + k - in, 0)``, the smaller half before; fused activations NONE, RELU, RELU_N1_TO_1,
RELU6."""
from __future__ import annotations

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

__all__ = ["conv2d", "depthwise_conv2d", "pool2d", "activate", "resize_bilinear", "mean", "pad",
           "fully_connected", "prelu"]

SAME, VALID = 0, 1


def activate(x: np.ndarray, activation: int) -> np.ndarray:
    if activation == 1:
        return np.maximum(x, 0.0)
    if activation == 2:
        return np.clip(x, -1.0, 1.0)
    if activation == 3:
        return np.clip(x, 0.0, 6.0)
    return x


def _padded(x: np.ndarray, kernel: tuple[int, int], stride: tuple[int, int], padding: int,
            dilation=(1, 1), value: float = 0.0) -> np.ndarray:
    if padding == VALID:
        return x
    pads = []
    for axis, (k, s, d) in enumerate(zip(kernel, stride, dilation)):
        size = x.shape[1 + axis]
        out = -(-size // s)
        extent = (k - 1) * d + 1
        total = max((out - 1) * s + extent - size, 0)
        pads.append((total // 2, total - total // 2))
    return np.pad(x, [(0, 0), pads[0], pads[1], (0, 0)], constant_values=value)


def _windows(x: np.ndarray, kernel, stride, dilation=(1, 1)) -> np.ndarray:
    """(1, OH, OW, C, KH, KW) views of the (already padded) input."""
    kh, kw = kernel
    dh, dw = dilation
    view = sliding_window_view(x, ((kh - 1) * dh + 1, (kw - 1) * dw + 1), axis=(1, 2))
    return view[:, ::stride[0], ::stride[1], :, ::dh, ::dw]


def conv2d(x, weights, bias, stride, padding, activation, dilation=(1, 1)) -> np.ndarray:
    """weights (OC, KH, KW, IC)."""
    oc, kh, kw, ic = weights.shape
    xp = _padded(x, (kh, kw), stride, padding, dilation)
    if kh == kw == 1 and tuple(dilation) == (1, 1):
        cols = xp[:, ::stride[0], ::stride[1], :]
        out = cols @ weights.reshape(oc, ic).T
    else:
        win = _windows(xp, (kh, kw), stride, dilation)                    # (1, OH, OW, IC, KH, KW)
        out = np.einsum("nhwcij,oijc->nhwo", win, weights, optimize=True)
    if bias is not None:
        out = out + bias
    return activate(out.astype(np.float32), activation)


def depthwise_conv2d(x, weights, bias, stride, padding, activation, multiplier=1, dilation=(1, 1)) -> np.ndarray:
    """weights (1, KH, KW, C * multiplier)."""
    _, kh, kw, oc = weights.shape
    xp = _padded(x, (kh, kw), stride, padding, dilation)
    if multiplier != 1:
        xp = np.repeat(xp, multiplier, axis=3)
    win = _windows(xp, (kh, kw), stride, dilation)                        # (1, OH, OW, C, KH, KW)
    out = np.einsum("nhwcij,ijc->nhwc", win, weights[0], optimize=True)
    if bias is not None:
        out = out + bias
    return activate(out.astype(np.float32), activation)


def pool2d(x, kernel, stride, padding, activation, kind: str = "max") -> np.ndarray:
    if kind == "max":
        xp = _padded(x, kernel, stride, padding, value=-np.inf)
        out = _windows(xp, kernel, stride).max(axis=(4, 5))
    else:
        xp = _padded(x, kernel, stride, padding, value=0.0)
        ones = _padded(np.ones_like(x[..., :1]), kernel, stride, padding, value=0.0)
        out = _windows(xp, kernel, stride).sum(axis=(4, 5)) / _windows(ones, kernel, stride).sum(axis=(4, 5))
    return activate(out.astype(np.float32), activation)


def pad(x, paddings) -> np.ndarray:
    return np.pad(x, [tuple(int(v) for v in p) for p in paddings])


def resize_bilinear(x, size, align_corners: bool, half_pixel: bool) -> np.ndarray:
    _, h, w, _ = x.shape
    oh, ow = int(size[0]), int(size[1])

    def coords(out, inp):
        o = np.arange(out, dtype=np.float64)
        if align_corners and out > 1:
            return o * (inp - 1) / (out - 1)
        scale = inp / out
        return np.maximum((o + 0.5) * scale - 0.5, 0.0) if half_pixel else o * scale

    ys, xs = coords(oh, h), coords(ow, w)
    y0, x0 = np.floor(ys).astype(int), np.floor(xs).astype(int)
    y1, x1 = np.minimum(y0 + 1, h - 1), np.minimum(x0 + 1, w - 1)
    fy, fx = (ys - y0)[None, :, None, None], (xs - x0)[None, None, :, None]
    top = x[:, y0][:, :, x0] * (1 - fx) + x[:, y0][:, :, x1] * fx
    bottom = x[:, y1][:, :, x0] * (1 - fx) + x[:, y1][:, :, x1] * fx
    return (top * (1 - fy) + bottom * fy).astype(np.float32)


def mean(x, axes, keep_dims: bool) -> np.ndarray:
    return np.mean(x, axis=tuple(int(a) for a in np.atleast_1d(axes)), keepdims=keep_dims).astype(np.float32)


def fully_connected(x, weights, bias, activation, keep_dims: bool = False) -> np.ndarray:
    """weights (OUT, IN); the input flattened to (-1, IN)."""
    flat = x.reshape(-1, weights.shape[1])
    out = flat @ weights.T
    if bias is not None:
        out = out + bias
    if keep_dims:
        out = out.reshape(x.shape[:-1] + (weights.shape[0],))
    return activate(out.astype(np.float32), activation)


def prelu(x, alpha) -> np.ndarray:
    return np.where(x >= 0, x, x * alpha).astype(np.float32)
