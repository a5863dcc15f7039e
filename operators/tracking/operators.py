# SPDX-License-Identifier: GPL-3.0-or-later
"""Pitch tracker operators (placeholder list, filled below)."""
CLASSES = []
