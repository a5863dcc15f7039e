# SPDX-License-Identifier: GPL-3.0-or-later
"""What belongs to no single subsystem: the preferences page, the default assets and presets operators,
``info`` and the ``demo`` that runs the subsystems together."""
from . import demo, info, operators, preferences

CLASSES = list(preferences.CLASSES) + list(operators.CLASSES)
COMMANDS = [info.Info, demo.Demo]
