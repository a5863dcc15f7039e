# SPDX-License-Identifier: GPL-3.0-or-later
"""The shared core every subsystem plugs into: errors, mesh geometry, presets, controls and the rig
protocol. Nothing here knows about faces, speech or hands, and nothing here imports a subsystem."""
